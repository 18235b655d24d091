//! What the phases of a study ask of a study kind, one trait per phase: [`Plan`] (loading and
//! checking a study file, adapting its runs), [`Measure`] (the columns, the shared work and
//! one run's measurement) and [`Present`] (verdicts, report, charts, pictures). Each kind is one
//! folder of `kinds/` implementing the three; each orchestrator takes the phase it calls
//! (`kinds::plan`, `kinds::measure`, `kinds::present`).
//!
//! Dependencies point one way: these traits see the study's vocabulary and the presentation
//! helpers kinds draw with, and nothing that orchestrates studies; the orchestrators see kinds
//! only through them.

mod measure;
mod plan;
mod present;

pub(in crate::study) use measure::{Measure, RunInputs, number};
pub(in crate::study) use plan::{OwnKey, Plan, parse_quick};
pub(in crate::study) use present::{Present, SweepLine, Verdict, not_ok};

/// A study kind: the three phases, which the registry lists.
pub(in crate::study) trait Kind: Plan + Measure + Present {}

impl<K: Plan + Measure + Present> Kind for K {}
