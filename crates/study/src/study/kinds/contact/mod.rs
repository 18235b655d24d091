//! Contact studies: each run as a trajectory run, plus what contact did — contacts, the
//! deepest penetration into analytic obstacles, the smallest distance incremental potential
//! contact kept, how many sampled frames the independent exact check found intersecting,
//! collision-detection work, barrier stiffness, and where the body ended (its centroid's
//! height along −gravity, which tells a body that went through a thin obstacle, and how far
//! it moved: sticking or sliding).
//!
//! Grid `contact.response` over the responses to compare them on the same scenes.

mod measure;
mod plan;
mod present;

/// A contact study.
pub(in crate::study) struct ContactStudy;
