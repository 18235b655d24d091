//! What running a study asks of its kind: the columns its runs write, the work they share
//! (the highest mode of each scene, reference solutions) and how one run is measured.

use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::measured::Measured;
use crate::study::vocabulary::meter::StepMeter;
use crate::study::vocabulary::reference::{Reference, ScoringSettings};
use crate::study::vocabulary::spec::{RunSpec, Study};
use softbench_core::parallel::Parallelism;

/// What the runner and the shared work ask of a study kind.
pub(in crate::study) trait Measure: Sync {
    /// The measured columns of `runs.csv` (after the identity and parameter columns): its
    /// own, then the groups of [`crate::study::vocabulary::columns`] its runs fill (made by
    /// [`crate::study::vocabulary::columns::declare`]). A run writes no other column, and some
    /// run writes each one (`StudyRun::unfilled_columns`).
    fn columns(&self) -> &'static [&'static str];

    /// What the progress line adds after a finished run's outcome (", error 1e-3").
    fn progress(&self, _: &Measured) -> Option<String> {
        None
    }

    /// Whether the runs need the highest mode of each scene before they start.
    fn needs_omega(&self, _: &StudyFile) -> bool {
        false
    }

    /// The settings of the reference solution `spec` is scored against, if the study computes
    /// any (a kind whose scenes state their own protocol gives each its own).
    fn reference_settings(&self, _: &StudyFile, _spec: &RunSpec) -> Option<ScoringSettings> {
        None
    }

    /// The reference step for the physics of a run (asked only when
    /// [`Kind::reference_settings`] gives settings).
    fn reference_dt(&self, _: &Study, w: &ScoringSettings, _: &RunSpec) -> f64 {
        w.horizon / 4000.0
    }

    /// Whether the runs go on without a reference that failed (else the study stops).
    fn reference_optional(&self) -> bool {
        false
    }

    /// Measure one run with what the runs share.
    fn measure(
        &self,
        study: &Study,
        spec: &RunSpec,
        inputs: &RunInputs,
        parallelism: Parallelism,
    ) -> Result<Measured, String>;
}

/// What one run gets from the work the runs share (its scene's highest mode and its
/// reference solution), and where it counts its steps for the ETA.
pub(in crate::study) struct RunInputs<'a> {
    pub omega: Option<f64>,
    pub reference: Option<&'a Reference>,
    /// Where the run's trajectories count their steps (`measured::run_observed`); none
    /// outside a study's runner.
    pub meter: Option<&'a StepMeter>,
}

/// A measured number, shortened for a progress line.
pub(in crate::study) fn number(m: &Measured, name: &str) -> Option<String> {
    m.get(name)
        .and_then(|s| s.parse::<f64>().ok())
        .map(crate::study::vocabulary::format::short)
}
