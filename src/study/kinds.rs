//! The one `match` over study kinds that picks a kind's [`KindSpec`]; the rest of the study
//! code asks the spec instead of matching on the kind.

use super::config::StudyKind;
use super::kind::KindSpec;
use super::{stability, trajectory, work_precision};

/// The spec of `kind` (a sweep's runs are measured by its inner kind, which the caller passes).
pub(super) fn spec(kind: StudyKind) -> &'static KindSpec {
    match kind {
        StudyKind::Stability => &stability::SPEC,
        StudyKind::WorkPrecision => &work_precision::SPEC,
        StudyKind::Trajectory | StudyKind::Sweep => &trajectory::SPEC,
    }
}
