//! Running a scene and measuring it: the run loop with blow-up detection ([`run`]), the
//! energy balance that decides a blow-up ([`balance`]) from the growth of its excess ([`growth`]), the sampled metrics ([`Sample`]) and
//! the run's outcome ([`RunSummary`], [`Outcome`]).

pub mod balance;
pub mod growth;
mod metrics;
mod outcome;
mod progress;
mod run_loop;

pub use balance::{EnergyBalance, EnergyScale, Violation};
pub use growth::GrowthFit;
pub use metrics::{Energies, Metrics};
pub use outcome::{Outcome, OutcomeKind};
pub use progress::RunProgress;
pub use run_loop::{Observer, RunSummary, Sample, StepSizes, run, spent_on};
