//! Twin studies: a method beside its twin on the same scene — a peer method (another package's
//! implementation, see `softbench_core::integrate::peer`) beside the softbench method it
//! implements, or any method beside a partner the study names. Each run first checks the
//! conventions (the peer's own masses, fixed set and elastic energy or forces against the
//! model's), then steps both from the same state and reports per step how far the two
//! trajectories are apart relative to the displacement, their energies, iteration counts and
//! times, with the first step (a peer's set-up, Warp's kernel compilation) timed apart.

mod measure;
mod plan;
mod present;

use crate::study::vocabulary::config::StudyFile;
use std::collections::BTreeMap;

/// The kind's name in study files and the name of its table.
const NAME: &str = "twins";

/// The `[twins]` table.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TwinsSettings {
    /// A partner for a method that is not a peer, or another partner for a peer (method name →
    /// method name). A peer's partner is its twin by default.
    pub partners: BTreeMap<String, String>,
}

fn settings(file: &StudyFile) -> TwinsSettings {
    file.settings(NAME).unwrap_or_default()
}

/// A twins study.
pub(in crate::study) struct Twins;
