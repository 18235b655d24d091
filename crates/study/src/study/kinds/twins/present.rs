//! The twins study kind, presenting: the report's table of each pair and what its columns
//! mean.

use super::Twins;
use crate::study::kind::Present;
use crate::study::present::charts::{Emit, SceneRows, label};
use crate::study::vocabulary::table::Table;
use softbench_run::plot::{Chart, LineChart, PlotError, Series};
use std::path::Path;

impl Present for Twins {
    fn summary_columns(&self) -> &'static [&'static str] {
        &[
            "partner",
            "outcome",
            "check_energy_ratio",
            "check_force_difference",
            "check_mass_difference",
            "check_fixed_equal",
            "difference_first_step",
            "difference_max",
            "difference_final",
            "energy_difference_max",
            "iterations_per_step",
            "partner_iterations_per_step",
            "first_step_seconds",
            "step_seconds_median",
            "partner_step_seconds_median",
            "cost_ratio",
            "unmatched_settings",
            "check_note",
        ]
    }

    /// Its steps are two methods' side by side, not one run's phases.
    fn draws_phases(&self) -> bool {
        false
    }

    fn scene_charts(&self, s: &SceneRows, dir: &Path, emit: &mut Emit) -> Result<(), PlotError> {
        scene_charts(s, dir, emit)
    }

    fn sweep_metrics(&self) -> &'static [&'static str] {
        &["difference_max", "cost_ratio"]
    }

    fn quick_notice(&self) -> &'static str {
        "runs are shortened"
    }

    fn unit_notes(&self, _: &Table, shown: &dyn Fn(&str) -> bool) -> Vec<String> {
        let mut notes = Vec::new();
        if shown("difference_max") {
            notes.push(
                "difference: the largest distance between a vertex of the method's trajectory \
                 and the same vertex of its partner's, over the partner's largest displacement \
                 from the start so far (per step in series/<run>-steps.csv; after the first \
                 step, the largest, and at the end)"
                    .into(),
            );
        }
        if shown("check_energy_ratio") || shown("check_force_difference") {
            notes.push(
                "checks, at a deformation of 1 % of the body's size before any step: the peer's \
                 own elastic energy over the model's (ratio), or the largest difference of its \
                 elastic forces over the model's largest force; its lumped masses (largest \
                 relative difference) and fixed set (equal or not); empty where the peer's API \
                 exposes none (check_note says so)"
                    .into(),
            );
        }
        if shown("energy_difference_max") {
            notes.push(
                "energy difference: the largest |E - E_partner| (both on softbench's model) over \
                 the largest energy the partner exchanged from its start"
                    .into(),
            );
        }
        if shown("cost_ratio") {
            notes.push(
                "cost ratio: the method's median step time over its partner's, the first step \
                 (a peer's set-up and Warp's kernel compilation) left out and shown apart"
                    .into(),
            );
        }
        notes
    }
}

/// Per scene: each pair's difference against time (log scale).
fn scene_charts(s: &SceneRows, dir: &Path, emit: &mut Emit) -> Result<(), PlotError> {
    let runs = s.runs;
    let mut series = Vec::new();
    for r in s.rows {
        let id = runs.get(r, "run_id").unwrap_or_default();
        let path = dir.join("series").join(format!("{id}-steps.csv"));
        let Ok(Some(table)) = Table::read(&path) else {
            continue;
        };
        let partner = runs.get(r, "partner").unwrap_or_default();
        series.push(Series {
            label: format!("{} vs {partner}", label(runs, s.params, r, &[])),
            points: table
                .rows
                .iter()
                .filter_map(|row| Some((table.number(row, "t")?, table.number(row, "difference")?)))
                .filter(|(_, d)| *d > 0.0 && d.is_finite())
                .collect(),
            ended: runs.get(r, "outcome") != Some("completed"),
        });
    }
    if series.is_empty() {
        return Ok(());
    }
    emit(
        format!("difference-{}", s.slug),
        "How far each method's trajectory is from its partner's: the largest vertex distance \
         over the partner's largest displacement so far, against time (log scale); a large \
         marker ends a pair that did not complete.",
        Chart::Line(LineChart {
            title: format!("{}: method vs partner", s.scene),
            x_label: "t [s]".into(),
            y_label: "difference / displacement".into(),
            x_log: false,
            y_log: true,
            series,
        }),
    )
}
