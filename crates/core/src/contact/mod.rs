//! Obstacles and contact (issue 4).
//!
//! Obstacles are signed distance functions with gradient and Hessian, one file per shape —
//! [`HalfSpace`] (the ground), [`Sphere`], [`Cuboid`] (an oriented box), [`Capsule`] — each
//! placed by a rigid transform and optionally moving along a [`Path`]; a group is the union of
//! its members (the minimum distance). See [`obstacle`].
//!
//! Five responses, chosen per scene (`[contact] response`) so a study can compare them on the
//! same scene; [`responses`](ContactResponse) lists them, one line each with the facts the scene
//! asks and the two functions (in the response's own file) that build it:
//! - `penalty` ([`PenaltyContact`]): a per-vertex potential `1/2 k d^2` on the penetration
//!   depth; every integrator sees it as a force, implicit ones also see its Hessian;
//! - `projection` and `velocity-flip` ([`WithContactResponse`]): after each step of any
//!   integrator, vertices that ended inside get their velocity relative to the obstacle
//!   reflected with restitution and damped tangentially by friction ([`VelocityRule`]) and
//!   are moved to the surface (projection) or to where the new velocity takes them from their
//!   start-of-step position (velocity-flip, predictive); after implicit methods the body
//!   follows the correction (`correction.rs`);
//! - `constrained` ([`ContactConstraints`]): inside the Newton loop of any method whose
//!   unknown is the end-of-step position, iterations solve a convex QP with linearized
//!   non-penetration constraints (clarabel) and the line search keeps iterates outside.
//! - `ipc` ([`ipc`]): incremental potential contact — a barrier on the distances between the
//!   body's surface primitives (self-contact), static triangle-mesh obstacles and the analytic
//!   obstacles, in the model; continuous collision detection caps every Newton step; lagged
//!   friction. Intersection-free at any step.
//!
//! [`intersection`] certifies sampled frames intersection-free with exact predicates,
//! independently of every response.
//!
//! Every response reports contacts (pairs within the margin) and the deepest penetration in
//! the [`crate::integrate::StepReport`]. A scene without obstacles (and whose response does not
//! keep the body off itself) builds none of this: [`Contact::build`] returns `None`, and no
//! obstacle is ever queried ([`query_count`]).

pub mod broad_phase;
mod capsule;
pub mod config;
pub mod constrained;
mod correction;
mod cuboid;
pub mod frame_check;
mod half_space;
pub mod intersection;
pub mod ipc;
pub mod mesh_obstacle;
pub mod obstacle;
mod path;
mod penalty;
pub mod qp;
mod response;
mod responses;
mod sdf;
mod sphere;

pub use capsule::Capsule;
pub use config::{ContactConfig, ObstacleConfig, ObstacleKind};
pub use constrained::ContactConstraints;
pub use cuboid::Cuboid;
pub use half_space::HalfSpace;
pub use obstacle::{ContactStats, Obstacle, ObstacleSample, Obstacles, Shape, query_count};
pub use path::Path;
pub use penalty::PenaltyContact;
pub use response::{Response, VelocityRule, WithContactResponse};
pub use responses::{ContactResponse, ResponseFacts};
pub use sdf::{Sdf, SdfValue};
pub use sphere::Sphere;

use crate::integrate::{Integrator, IntegratorSettings};
use crate::model::Model;
use std::sync::Arc;

/// A scene's obstacles with its contact settings.
#[derive(Clone, Debug)]
pub struct Contact {
    obstacles: Arc<Obstacles>,
    config: ContactConfig,
    /// Incremental potential contact's shared state (response `ipc`).
    ipc: Option<Arc<ipc::Ipc>>,
    /// The independent intersection check of sampled frames.
    check: Arc<frame_check::FrameCheck>,
}

/// What a scene's contact is built from.
#[derive(Clone, Copy, Debug)]
pub struct ContactSetup<'a> {
    /// The `[[obstacles]]` tables (validated).
    pub obstacles: &'a [ObstacleConfig],
    /// The triangle-mesh obstacles among them, read (only for a response that
    /// [sees them](ResponseFacts::sees_mesh_obstacles); empty otherwise).
    pub meshes: &'a [ipc::MeshObstacle],
    /// The `[contact]` section.
    pub config: &'a ContactConfig,
    /// The body's boundary triangles (empty for a scene that has no contact).
    pub surface: &'a [[usize; 3]],
    /// The scene's time step.
    pub dt: f64,
}

impl ContactSetup<'_> {
    /// Whether the scene has contact at all: obstacles, or a response that keeps the body off
    /// itself.
    pub fn has_contact(&self) -> bool {
        !self.obstacles.is_empty() || self.config.response.facts().self_contact
    }
}

impl Contact {
    /// The scene's contact, built by its response ([`ResponseFacts::build`]), which adds what
    /// lives in the model (a potential) to `model`; `None` when the scene has none
    /// ([`ContactSetup::has_contact`]).
    pub fn build(setup: &ContactSetup<'_>, model: &mut Model) -> Option<Self> {
        setup
            .has_contact()
            .then(|| (setup.config.response.facts().build)(setup, model))
    }

    /// Contact with the analytic obstacles of `setup` (mesh tables skipped) and the frame check
    /// of the body's surface against them: what a response needs that adds nothing to the
    /// model.
    pub(crate) fn with_analytic_obstacles(setup: &ContactSetup<'_>, _: &mut Model) -> Self {
        let obstacles: Obstacles = setup
            .obstacles
            .iter()
            .filter(|o| !o.is_mesh())
            .map(ObstacleConfig::obstacle)
            .collect();
        let obstacles = Arc::new(obstacles);
        let check =
            frame_check::FrameCheck::new(setup.surface.to_vec(), Vec::new(), obstacles.clone());
        Self {
            obstacles,
            config: *setup.config,
            ipc: None,
            check: Arc::new(check),
        }
    }

    /// Incremental potential contact's state, if the response is `ipc`.
    pub fn ipc(&self) -> Option<&Arc<ipc::Ipc>> {
        self.ipc.as_ref()
    }

    /// The obstacles.
    pub fn obstacles(&self) -> &Arc<Obstacles> {
        &self.obstacles
    }

    /// The settings.
    pub fn config(&self) -> &ContactConfig {
        &self.config
    }

    /// The integrator `settings` describe, with this contact response
    /// ([`ResponseFacts::integrator`]): the method wrapped, or with the response inside its
    /// Newton loop (scene validation requires a method that can take it).
    pub fn integrator(&self, settings: &IntegratorSettings) -> Box<dyn Integrator> {
        (self.config.response.facts().integrator)(self, settings)
    }

    /// `inner` wrapped so that after each step it applies `response` and reports contacts,
    /// with the frame check.
    pub(crate) fn wrapped(
        &self,
        inner: Box<dyn Integrator>,
        response: Response,
    ) -> Box<dyn Integrator> {
        Box::new(
            WithContactResponse::new(inner, self.obstacles.clone(), response, self.config.margin)
                .with_check(self.check.clone()),
        )
    }

    /// The restitution and friction of the `[contact]` section.
    pub(crate) fn velocity_rule(&self) -> VelocityRule {
        VelocityRule {
            restitution: self.config.restitution,
            friction: self.config.friction,
        }
    }
}
