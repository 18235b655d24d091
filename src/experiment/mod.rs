//! Running a scene and measuring it: the run loop with blow-up detection ([`run`]), the
//! sampled metrics ([`Sample`]) and the run's outcome ([`RunSummary`]).

mod metrics;
mod run;

pub use metrics::{Energies, Metrics};
pub use run::{Observer, Outcome, RunSummary, Sample, run};
