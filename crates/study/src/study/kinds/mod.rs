//! The study kinds: one folder each, one line each here. A new kind is its own folder
//! implementing the phases of [`Kind`](crate::study::kind::Kind) plus one line in [`KINDS`];
//! `tests/study_kinds.rs` runs every kind listed.

pub mod contact;
pub mod solver;
pub mod stability;
pub mod suite;
pub mod trajectory;
pub mod twins;
pub mod work_precision;

use crate::study::kind::{Kind, Measure, Plan, Present};

/// Every kind a study can measure.
pub(in crate::study) static KINDS: &[&dyn Kind] = &[
    &trajectory::Trajectory,
    &contact::ContactStudy,
    &work_precision::WorkPrecision,
    &stability::Stability,
    &solver::Solver,
    &suite::Suite,
    &twins::Twins,
];

/// The registered kind named `name`, if there is one.
fn named(name: &str) -> Option<&'static dyn Kind> {
    KINDS.iter().copied().find(|k| k.name() == name)
}

/// The registered kind named `name`: a study's kind, resolved when it was loaded (or, for a
/// results folder, checked when its meta.json was read).
fn of(name: &str) -> &'static dyn Kind {
    named(name).expect("a study's kind is checked against the registry when it is read")
}

/// Whether a kind named `name` is registered.
pub(in crate::study) fn is_registered(name: &str) -> bool {
    named(name).is_some()
}

/// Every registered kind's name, in registry order.
pub(in crate::study) fn names() -> Vec<&'static str> {
    KINDS.iter().map(|k| k.name()).collect()
}

/// What planning asks of every registered kind, in registry order.
pub(in crate::study) fn planning() -> impl Iterator<Item = &'static dyn Plan> {
    KINDS.iter().map(|&k| k as &dyn Plan)
}

/// The planning phase of the kind named `name`, if there is one.
pub(in crate::study) fn plan_named(name: &str) -> Option<&'static dyn Plan> {
    named(name).map(|k| k as &dyn Plan)
}

/// The planning phase of a study's kind.
pub(in crate::study) fn plan(name: &str) -> &'static dyn Plan {
    of(name)
}

/// The measuring phase of a study's kind.
pub(in crate::study) fn measure(name: &str) -> &'static dyn Measure {
    of(name)
}

/// The presenting phase of a study's kind.
pub(in crate::study) fn present(name: &str) -> &'static dyn Present {
    of(name)
}

/// The presenting phase of the kind named `name`, if there is one.
pub(in crate::study) fn present_named(name: &str) -> Option<&'static dyn Present> {
    named(name).map(|k| k as &dyn Present)
}

/// A registered study kind, as `softbench list` and the docs show it.
#[derive(Clone, Copy, Debug)]
pub struct KindInfo {
    /// The name in study files (`study = "..."`).
    pub name: &'static str,
    /// One line: what a run of this kind measures.
    pub description: &'static str,
    /// Its `runs.csv` columns after the identity and parameter columns.
    pub columns: &'static [&'static str],
    /// The tables a minimal study of this kind adds (its settings table and grid).
    pub example: &'static str,
    /// What its scenes add to a plain scene file (empty for kinds that run any scene).
    pub scene_example: &'static str,
}

/// Every registered study kind, in registry order. (A `sweep` study runs one of these over a
/// parameter.)
pub fn kinds() -> Vec<KindInfo> {
    KINDS
        .iter()
        .map(|k| KindInfo {
            name: k.name(),
            description: k.description(),
            columns: k.columns(),
            example: k.example(),
            scene_example: k.scene_example(),
        })
        .collect()
}
