//! Obstacles and contact (issue 4).
//!
//! Obstacles are signed distance functions with gradient and Hessian, one file per shape —
//! [`HalfSpace`] (the ground), [`Sphere`], [`Cuboid`] (an oriented box), [`Capsule`] — each
//! placed by a rigid transform and optionally moving along a [`Path`]; a group is the union of
//! its members (the minimum distance). See [`obstacle`].

mod capsule;
mod cuboid;
mod half_space;
pub mod obstacle;
mod path;
mod sdf;
mod sphere;

pub use capsule::Capsule;
pub use cuboid::Cuboid;
pub use half_space::HalfSpace;
pub use obstacle::{ContactStats, Obstacle, ObstacleSample, Obstacles, Shape, query_count};
pub use path::Path;
pub use sdf::{Sdf, SdfValue};
pub use sphere::Sphere;
