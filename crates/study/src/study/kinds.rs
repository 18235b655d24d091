//! The study kinds: one line each. A new kind is its own file implementing
//! [`Kind`](super::kind::Kind) plus one line here; `tests/study_kinds.rs` runs every kind listed.

use super::kind::Kind;
use super::{contact, solver, stability, suite, trajectory, work_precision};

/// Every kind a study can measure.
pub(super) static KINDS: [&dyn Kind; 6] = [
    &trajectory::Trajectory,
    &contact::ContactStudy,
    &work_precision::WorkPrecision,
    &stability::Stability,
    &solver::Solver,
    &suite::Suite,
];

/// The registered kind named `name`, if there is one.
pub(super) fn named(name: &str) -> Option<&'static dyn Kind> {
    KINDS.iter().copied().find(|k| k.name() == name)
}

/// The registered kind named `name`: a study's kind, resolved when it was loaded (or, for a
/// results folder, checked when its meta.json was read).
pub(super) fn of(name: &str) -> &'static dyn Kind {
    named(name).expect("a study's kind is checked against the registry when it is read")
}
