//! The work-precision study kind, measuring: its columns, the work its runs share and one run's
//! measurement.

use super::{WorkPrecision, settings};
use crate::study::kind::{Measure, RunInputs, number};
use crate::study::vocabulary::columns;
use crate::study::vocabulary::columns::{CAPS, SUMMARY};
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::format::cell;
use crate::study::vocabulary::measured::{Measured, build, outcome_of, picture_surface};
use crate::study::vocabulary::meter::StepMeter;
use crate::study::vocabulary::reference::{
    Reference, ScoringSettings, errors, sampled_run, stride,
};
use crate::study::vocabulary::spec::{RunSpec, Study};
use softbench_core::parallel::Parallelism;
use std::sync::LazyLock;

/// A work-precision study's own columns of `runs.csv` (after the identity and parameters; the run's
/// summary and the integrator's caps follow, [`COLUMNS`]).
pub const OWN_COLUMNS: &[&str] = &[
    "dt",
    "outcome",
    "error",
    "error_final",
    "error_l2",
    "energy_error",
    "wall_seconds_min",
    "wall_seconds_max",
    "repeats",
    "repeatable",
    "scored",
    "error_unscored",
    "reference_method",
    "reference_dt",
    "reference_difference",
    "phases",
    "error_phase1",
    "reference_difference_phase1",
    "error_phase2",
    "reference_difference_phase2",
    "error_phase3",
    "reference_difference_phase3",
    "error_phase4",
    "reference_difference_phase4",
    "centroid_error",
    "bounding_box_error",
    "modal_error",
    "reference_modal_difference",
    "modal_modes",
    "modal_omega_cutoff",
    "tets",
];

/// Every measured column of a work-precision study's `runs.csv`: its own, the run's summary
/// and the integrator's caps.
pub static COLUMNS: LazyLock<Vec<&'static str>> =
    LazyLock::new(|| columns::declare(OWN_COLUMNS, true, true));

impl Measure for WorkPrecision {
    fn columns(&self) -> &'static [&'static str] {
        &COLUMNS
    }

    fn progress(&self, m: &Measured) -> Option<String> {
        number(m, "error").map(|e| format!(", error {e}"))
    }

    fn needs_omega(&self, file: &StudyFile) -> bool {
        settings(file).is_some_and(|w| w.reference.method.is_none() && !w.reference.same_dt)
    }

    fn reference_settings(&self, file: &StudyFile, _: &RunSpec) -> Option<ScoringSettings> {
        settings(file)
    }

    fn reference_dt(&self, study: &Study, w: &ScoringSettings, spec: &RunSpec) -> f64 {
        reference_dt(study, w, spec)
    }

    fn measure(
        &self,
        study: &Study,
        spec: &RunSpec,
        inputs: &RunInputs,
        parallelism: Parallelism,
    ) -> Result<Measured, String> {
        let settings = settings(&study.file).ok_or("no [work-precision] table")?;
        let reference = inputs.reference.ok_or("no reference solution")?;
        measure_with(spec, &settings, reference, parallelism, true, inputs.meter)
    }
}

/// The reference step for the physics of `spec`: as set, or the smallest dt of the grid over
/// `dt_factor`.
fn reference_dt(study: &Study, w: &ScoringSettings, spec: &RunSpec) -> f64 {
    if w.reference.same_dt {
        return spec.loaded.config.run.dt;
    }
    w.reference.dt.unwrap_or_else(|| {
        let smallest = study
            .runs
            .iter()
            .filter(|r| r.physics == spec.physics)
            .map(|r| r.loaded.config.run.dt)
            .fold(f64::INFINITY, f64::min);
        smallest / w.reference.dt_factor
    })
}

/// [`measure`], recording the snapshots the pictures are drawn from only with `pictures` and
/// counting the steps of every repeat on `meter`; the `tets` cell says how many elastic tets
/// the body has.
pub(in crate::study) fn measure_with(
    spec: &RunSpec,
    settings: &ScoringSettings,
    reference: &Reference,
    parallelism: Parallelism,
    pictures: bool,
    meter: Option<&StepMeter>,
) -> Result<Measured, String> {
    let mut scene = build(spec, parallelism).map_err(|e| e.to_string())?;
    let run = scene.config.run;
    let tets = scene.model.elastic_elements().map_or(0, |e| e.tets.len());
    let surface = if pictures {
        picture_surface(&scene, spec)?
    } else {
        None
    };
    let (summary, rows, snapshots, pictures) =
        sampled_run(&mut scene, &run, stride(settings, run.dt), surface, meter);
    let (outcome, message) = outcome_of(&summary.outcome);
    let mut m = Measured {
        outcome,
        message,
        cells: SUMMARY.cells(&summary),
        series: rows,
        snapshots: pictures,
        ..Measured::default()
    };
    m.cells.extend(CAPS.cells(spec));
    m.set("tets", tets.to_string());
    repeat(
        spec,
        settings,
        parallelism,
        &summary,
        &snapshots,
        &mut m,
        meter,
    )?;
    m.set("dt", cell(Some(run.dt)));
    m.set("reference_method", reference.method.name().to_owned());
    m.set("reference_dt", cell(Some(reference.dt)));
    m.set("reference_difference", cell(Some(reference.difference)));
    let floor = settings.reference.floor_factor * reference.difference;
    match errors(&snapshots, &reference.snapshots, &reference.rest) {
        Some((error, energy)) if summary.outcome.is_completed() => {
            let scored = error > floor;
            m.set("scored", if scored { "yes" } else { "no" }.into());
            m.set("error", cell(scored.then_some(error)));
            m.set(
                "error_final",
                cell(
                    crate::study::vocabulary::reference::final_error(
                        &snapshots,
                        &reference.snapshots,
                        &reference.rest,
                    )
                    .filter(|_| scored),
                ),
            );
            m.set(
                "error_l2",
                cell(reference.relative_l2_error(&snapshots.q).filter(|_| scored)),
            );
            m.set("error_unscored", cell((!scored).then_some(error)));
            m.set("energy_error", cell(Some(energy)));
            crate::study::vocabulary::reference::set_phase_cells(&mut m, reference, &snapshots.q);
            reference.set_modal_cells(&mut m, &snapshots.q);
            if !scored {
                m.message = format!(
                    "error {error:.3e} is below {} x the reference's own difference {:.3e}: \
                     not scored",
                    settings.reference.floor_factor, reference.difference
                );
            }
        }
        _ => m.set("scored", "no".into()),
    }
    Ok(m)
}

/// Run `spec` `settings.repeats - 1` more times: `wall_seconds` becomes the median over all
/// runs, with `wall_seconds_min` and `_max`, and `repeatable` says whether every repeat
/// ended in the same state at every sample time, bit for bit.
fn repeat(
    spec: &RunSpec,
    settings: &ScoringSettings,
    parallelism: Parallelism,
    first: &softbench_run::run::RunSummary,
    snapshots: &crate::study::vocabulary::reference::Snapshots,
    m: &mut Measured,
    meter: Option<&StepMeter>,
) -> Result<(), String> {
    let mut seconds = vec![first.totals.times.total];
    let mut repeatable = true;
    for _ in 1..settings.repeats {
        let mut scene = build(spec, parallelism).map_err(|e| e.to_string())?;
        let run = scene.config.run;
        let (summary, _, again, _) =
            sampled_run(&mut scene, &run, stride(settings, run.dt), None, meter);
        seconds.push(summary.totals.times.total);
        repeatable &= again.q == snapshots.q && summary.outcome == first.outcome;
    }
    seconds.sort_by(f64::total_cmp);
    let n = seconds.len();
    let median = if n % 2 == 1 {
        seconds[n / 2]
    } else {
        0.5 * (seconds[n / 2 - 1] + seconds[n / 2])
    };
    m.set("repeats", n.to_string());
    m.set("wall_seconds", cell(Some(median)));
    m.set("wall_seconds_min", cell(Some(seconds[0])));
    m.set("wall_seconds_max", cell(Some(seconds[n - 1])));
    m.set("repeatable", if repeatable { "yes" } else { "no" }.into());
    Ok(())
}
