//! The study kinds: one line each. A new kind is its own file implementing
//! [`Kind`](super::kind::Kind) plus one line here; `tests/study_kinds.rs` runs every kind listed.

use super::config::StudyKind;
use super::kind::Kind;
use super::{stability, trajectory, work_precision};

/// Every kind a study can measure.
pub(super) static KINDS: [&dyn Kind; 3] = [
    &trajectory::Trajectory,
    &work_precision::WorkPrecision,
    &stability::Stability,
];

/// The kind that measures the runs of a study of `kind` (a sweep's runs are measured by its
/// inner kind, which the caller passes; a sweep itself is measured as a trajectory).
pub(super) fn of(kind: StudyKind) -> &'static dyn Kind {
    let name = match kind {
        StudyKind::Sweep => StudyKind::Trajectory.name(),
        other => other.name(),
    };
    KINDS
        .iter()
        .copied()
        .find(|k| k.name() == name)
        .expect("every study kind but sweep is registered (tests/study_kinds.rs)")
}
