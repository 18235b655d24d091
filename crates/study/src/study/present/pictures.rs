//! Pictures of a study's bodies: per scene, a panel PNG (one row per run, the same simulated
//! times in every column, one camera) and a GIF of the runs side by side, drawn from the
//! runs' snapshot files (`series/<run-id>.snapshots`) alone, so `softbench plot` redraws them.

use std::path::Path;

use crate::study::present::charts::{
    Plot, distinguishing, label, least_accurate_per_line, scenes, slug,
};
use crate::study::vocabulary::table::Table;
use softbench_run::render::{self, Coloring, RenderError, RunPictures, Snapshots};

/// The snapshot file of run `id` in a study folder.
pub fn snapshot_path(dir: &Path, id: &str) -> std::path::PathBuf {
    dir.join("series")
        .join(format!("{id}.{}", render::SNAPSHOT_EXTENSION))
}

/// Which runs of a study the pictures show.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PictureRows {
    /// Every run with snapshots, one row each.
    All,
    /// One run per work-precision line (a method with its non-accuracy settings): the least
    /// accurate setting that completed — the coarsest step, fewest iterations or substeps,
    /// loosest tolerance — where methods differ most visibly (a line with no completed run
    /// shows its least accurate run). Labels then name the run's dt.
    LeastAccuratePerLine,
}

/// Draws `pictures-<scene>.png` and `.gif` for every scene with snapshots; returns them as
/// plots (the PNG is the plot, the caption links the GIF).
pub fn draw(
    dir: &Path,
    runs: &Table,
    params: &[String],
    which: PictureRows,
    coloring: Coloring,
) -> Result<Vec<Plot>, RenderError> {
    let mut out = Vec::new();
    for scene in scenes(runs) {
        let of_scene: Vec<&Vec<String>> = runs
            .rows
            .iter()
            .filter(|r| runs.get(r, "scene") == Some(&scene))
            .filter(|r| snapshot_path(dir, &r[0]).exists())
            .collect();
        // Rows are labelled by what tells this scene's runs apart, dt included (issue 24).
        let params = distinguishing(runs, params, &of_scene);
        let shown = match which {
            PictureRows::All => of_scene,
            PictureRows::LeastAccuratePerLine => least_accurate_per_line(runs, &params, &of_scene),
        };
        let mut loaded: Vec<(String, Snapshots)> = Vec::new();
        for row in shown {
            let mut name = label(runs, &params, row, &["run.dt"]);
            let dt_differs = params.iter().any(|p| p == "run.dt");
            if (dt_differs || which == PictureRows::LeastAccuratePerLine)
                && let Some(dt) = runs.get(row, "dt").filter(|d| !d.is_empty())
            {
                name.push_str(&format!(" dt={dt}"));
            }
            loaded.push((name, Snapshots::read(&snapshot_path(dir, &row[0]))?));
        }
        if loaded.is_empty() {
            continue;
        }
        let pictures: Vec<RunPictures> = loaded
            .iter()
            .map(|(label, s)| RunPictures {
                label: label.clone(),
                snapshots: s,
            })
            .collect();
        let stem = format!("pictures-{}", slug(&scene));
        render::panel(&dir.join(format!("{stem}.png")), &pictures, coloring)?;
        render::animation(&dir.join(format!("{stem}.gif")), &pictures, coloring)?;
        let names = loaded
            .iter()
            .map(|(l, _)| l.as_str())
            .collect::<Vec<_>>()
            .join("; ");
        let rows_are = match which {
            PictureRows::All => format!("One row per run (rows: {names})"),
            PictureRows::LeastAccuratePerLine => format!(
                "One row per method, each at its least accurate setting that completed (the \
                 largest dt, fewest iterations or loosest tolerance of its line; rows: {names})"
            ),
        };
        out.push(Plot {
            title: format!("The body over time: {scene}"),
            caption: format!(
                "{rows_are}, at 0, 1/5, ..., 5/5 of the horizon, one camera for all{}. A \
                 run that ended early shows its last valid state framed in red with the cause, \
                 the body magenta where its det F was not recorded. \
                 The runs side by side as an animation: [{stem}.gif]({stem}.gif).",
                match coloring {
                    Coloring::VolumeRatio => {
                        "; coloured by det F of the tet under each face (blue compressed to \
                         0.7, white at rest volume, red stretched to 1.3, black inverted)"
                    }
                    Coloring::EnergyDensity => {
                        "; coloured by the elastic energy density of the tet under each face \
                         (white at 0, dark red at the largest density of the runs that completed, \
                         one scale for all)"
                    }
                    Coloring::Plain => "",
                }
            ),
            stem,
        });
    }
    Ok(out)
}
