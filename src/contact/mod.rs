//! Obstacles and contact (issue 4).
//!
//! Obstacles are signed distance functions with gradient and Hessian, one file per shape —
//! [`HalfSpace`] (the ground), [`Sphere`], [`Cuboid`] (an oriented box), [`Capsule`] — each
//! placed by a rigid transform and optionally moving along a [`Path`]; a group is the union of
//! its members (the minimum distance). See [`obstacle`].
//!
//! Responses:
//! - `penalty` ([`PenaltyContact`]): a per-vertex potential `1/2 k d^2` on the penetration
//!   depth; every integrator sees it as a force, implicit ones also see its Hessian;
//! - `projection` and `velocity-flip` ([`WithContactResponse`]): after each step of any
//!   integrator, penetrating vertices are moved to the surface (projection only) and their
//!   velocity relative to the obstacle is reflected with restitution and damped tangentially
//!   by friction ([`VelocityRule`]).

mod capsule;
mod cuboid;
mod half_space;
pub mod obstacle;
mod path;
mod penalty;
mod response;
mod sdf;
mod sphere;

pub use capsule::Capsule;
pub use cuboid::Cuboid;
pub use half_space::HalfSpace;
pub use obstacle::{ContactStats, Obstacle, ObstacleSample, Obstacles, Shape, query_count};
pub use path::Path;
pub use penalty::PenaltyContact;
pub use response::{Response, VelocityRule, WithContactResponse};
pub use sdf::{Sdf, SdfValue};
pub use sphere::Sphere;
