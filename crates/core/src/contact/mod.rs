//! Obstacles and contact (issue 4).
//!
//! Obstacles are signed distance functions with gradient and Hessian, one file per shape —
//! [`HalfSpace`] (the ground), [`Sphere`], [`Cuboid`] (an oriented box), [`Capsule`] — each
//! placed by a rigid transform and optionally moving along a [`Path`]; a group is the union of
//! its members (the minimum distance). See [`obstacle`].
//!
//! Four responses, chosen per scene (`[contact] response`) so a study can compare them on the
//! same scene:
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
//! the [`crate::integrate::StepReport`]. A scene without obstacles builds none of this:
//! [`Contact::build`] returns `None`, and no obstacle is ever queried ([`query_count`]).

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
mod sdf;
mod sphere;

pub use capsule::Capsule;
pub use config::{ContactConfig, ContactResponse, ObstacleConfig, ObstacleKind};
pub use constrained::ContactConstraints;
pub use cuboid::Cuboid;
pub use half_space::HalfSpace;
pub use obstacle::{ContactStats, Obstacle, ObstacleSample, Obstacles, Shape, query_count};
pub use path::Path;
pub use penalty::PenaltyContact;
pub use response::{Response, VelocityRule, WithContactResponse};
pub use sdf::{Sdf, SdfValue};
pub use sphere::Sphere;

use crate::integrate::newton::NewtonContact;
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

impl Contact {
    /// Contact for `obstacles` (validated tables) with `config`, or `None` without
    /// obstacles. With the penalty response, adds the penalty potential to `model`.
    pub fn build(
        obstacles: &[ObstacleConfig],
        config: &ContactConfig,
        model: &mut Model,
        surface: &[[usize; 3]],
    ) -> Option<Self> {
        if obstacles.is_empty() {
            return None;
        }
        let set = obstacles
            .iter()
            .filter(|o| !o.is_mesh())
            .map(ObstacleConfig::obstacle)
            .collect();
        let mut contact = Self::new(set, *config, model);
        contact.check = Arc::new(frame_check::FrameCheck::new(
            surface.to_vec(),
            Vec::new(),
            contact.obstacles.clone(),
        ));
        Some(contact)
    }

    /// Incremental potential contact (`response = "ipc"`) for `model`, whose body's boundary
    /// triangles are `surface`, against the analytic `obstacles` (mesh tables skipped) and
    /// the mesh obstacles `meshes`, with steps of `dt`; adds the contact potential to `model`.
    /// Built even without obstacles (self-contact).
    pub fn build_ipc(
        obstacles: &[ObstacleConfig],
        meshes: &[ipc::MeshObstacle],
        config: &ContactConfig,
        model: &mut Model,
        surface: &[[usize; 3]],
        dt: f64,
    ) -> Self {
        let set: Obstacles = obstacles
            .iter()
            .filter(|o| !o.is_mesh())
            .map(ObstacleConfig::obstacle)
            .collect();
        // Still boxes take part as triangle meshes (their edges and corners then meet the
        // body's edges and faces, not only its vertices); the rest stay signed distances.
        let mut contact_meshes = meshes.to_vec();
        let mut distances = Vec::new();
        for o in set.iter() {
            if o.is_static() {
                o.box_meshes(0.0, &mut contact_meshes);
                distances.extend(o.without_boxes());
            } else {
                distances.push(o.clone());
            }
        }
        let set = Arc::new(set);
        let shared = Arc::new(ipc::Ipc::new(
            model,
            surface,
            Arc::new(Obstacles::new(distances)),
            &contact_meshes,
            config.ipc,
            dt,
        ));
        model.set_contact_potential(Box::new(ipc::IpcPotential(shared.clone())));
        let check = frame_check::FrameCheck::new(surface.to_vec(), meshes.to_vec(), set.clone());
        Self {
            obstacles: set,
            config: *config,
            ipc: Some(shared),
            check: Arc::new(check),
        }
    }

    /// Incremental potential contact's state, if the response is `ipc`.
    pub fn ipc(&self) -> Option<&Arc<ipc::Ipc>> {
        self.ipc.as_ref()
    }

    /// Contact with `obstacles`; with the penalty response, adds the penalty potential to
    /// `model`.
    pub fn new(obstacles: Obstacles, config: ContactConfig, model: &mut Model) -> Self {
        let obstacles = Arc::new(obstacles);
        if config.response == ContactResponse::Penalty {
            model.add_vertex_potential(Box::new(PenaltyContact::new(
                obstacles.clone(),
                config.stiffness,
            )));
        }
        let check = frame_check::FrameCheck::new(Vec::new(), Vec::new(), obstacles.clone());
        Self {
            obstacles,
            config,
            ipc: None,
            check: Arc::new(check),
        }
    }

    /// The obstacles.
    pub fn obstacles(&self) -> &Arc<Obstacles> {
        &self.obstacles
    }

    /// The settings.
    pub fn config(&self) -> &ContactConfig {
        &self.config
    }

    /// The integrator `settings` describe, with this contact response: the method wrapped in
    /// [`WithContactResponse`], or for `constrained` the method with [`ContactConstraints`]
    /// inside its Newton loop (scene validation requires a method that can take them).
    pub fn integrator(&self, settings: &IntegratorSettings) -> Box<dyn Integrator> {
        let c = &self.config;
        let rule = VelocityRule {
            restitution: c.restitution,
            friction: c.friction,
        };
        let response = match c.response {
            ContactResponse::Penalty => Response::ReportOnly,
            ContactResponse::Projection => Response::Projection(rule),
            ContactResponse::VelocityFlip => Response::VelocityFlip(rule),
            ContactResponse::Ipc => {
                let shared = self.ipc.clone().expect("built by Contact::build_ipc");
                let filter = ipc::IpcFilter::new(shared.clone());
                let inner = settings
                    .build_constrained(NewtonContact::Barrier(Box::new(filter)))
                    .expect("scene validation admits ipc only for methods on the Newton loop");
                return Box::new(ipc::WithIpc::new(inner, shared, self.check.clone()));
            }
            ContactResponse::Constrained => {
                let constraints = ContactConstraints::new(self.obstacles.clone(), c.margin);
                let inner = settings
                    .build_constrained(NewtonContact::Constraints(Box::new(constraints)))
                    .expect("scene validation admits constrained contact only for such methods");
                // The constraints record contacts; the wrapper adds the frame check.
                return Box::new(
                    WithContactResponse::new(
                        inner,
                        self.obstacles.clone(),
                        Response::ReportOnly,
                        c.margin,
                    )
                    .with_check(self.check.clone()),
                );
            }
        };
        Box::new(
            WithContactResponse::new(settings.build(), self.obstacles.clone(), response, c.margin)
                .with_check(self.check.clone()),
        )
    }
}
