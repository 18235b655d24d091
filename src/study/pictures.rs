//! Pictures of a study's bodies: per scene, a panel PNG (one row per run, the same simulated
//! times in every column, one camera) and a GIF of the runs side by side, drawn from the
//! runs' snapshot files (`series/<run-id>.snapshots`) alone, so `softbench plot` redraws them.

use std::path::Path;

use super::plots::{Plot, label, scenes, slug};
use super::table::Table;
use crate::render::{self, Coloring, RenderError, RunPictures, Snapshots};

/// The snapshot file of run `id` in a study folder.
pub fn snapshot_path(dir: &Path, id: &str) -> std::path::PathBuf {
    dir.join("series")
        .join(format!("{id}.{}", render::SNAPSHOT_EXTENSION))
}

/// Draws `pictures-<scene>.png` and `.gif` for every scene with snapshots; returns them as
/// plots (the PNG is the plot, the caption links the GIF).
pub fn draw(
    dir: &Path,
    runs: &Table,
    params: &[String],
    coloring: Coloring,
) -> Result<Vec<Plot>, RenderError> {
    let mut out = Vec::new();
    for scene in scenes(runs) {
        let mut loaded: Vec<(String, Snapshots)> = Vec::new();
        for row in runs
            .rows
            .iter()
            .filter(|r| runs.get(r, "scene") == Some(&scene))
        {
            let path = snapshot_path(dir, &row[0]);
            if path.exists() {
                loaded.push((label(runs, params, row, &[]), Snapshots::read(&path)?));
            }
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
        out.push(Plot {
            title: format!("The body over time: {scene}"),
            caption: format!(
                "One row per run at 0, 1/5, ..., 5/5 of the horizon, one camera for all{}. A \
                 run that ended early shows its last valid state framed in red with the cause. \
                 The runs side by side as an animation: [{stem}.gif]({stem}.gif).",
                match coloring {
                    Coloring::VolumeRatio => {
                        "; coloured by det F of the tet under each face (blue compressed to \
                         0.7, white at rest volume, red stretched to 1.3, black inverted)"
                    }
                    Coloring::EnergyDensity => {
                        "; coloured by the elastic energy density of the tet under each face \
                         (white at 0, dark red at each run's largest density)"
                    }
                    Coloring::Plain => "",
                }
            ),
            stem,
        });
    }
    Ok(out)
}

/// [`draw`] for a study's results folder, reading its `runs.csv` and `meta.json` (for the
/// swept parameters that label the runs).
pub fn draw_folder(dir: &Path, coloring: Coloring) -> Result<Vec<Plot>, super::RedrawError> {
    let meta_path = dir.join("meta.json");
    let text = std::fs::read_to_string(&meta_path).map_err(|error| super::ResultsError::Io {
        path: meta_path.clone(),
        error,
    })?;
    let meta: super::Meta =
        serde_json::from_str(&text).map_err(|e| super::ResultsError::Malformed {
            path: meta_path.clone(),
            message: e.to_string(),
        })?;
    let runs_path = dir.join("runs.csv");
    let runs = Table::read(&runs_path)?.ok_or_else(|| super::ResultsError::Io {
        path: runs_path.clone(),
        error: std::io::Error::from(std::io::ErrorKind::NotFound),
    })?;
    draw(dir, &runs, &meta.study.parameters, coloring)
        .map_err(|e| super::RedrawError::Plot(crate::plot::PlotError::Draw(e.to_string())))
}
