//! The contact responses, one line each: a response's name, its description and the facts the
//! rest of the code asks of it — where it acts, what it sees, and the two functions that build
//! it (in the response's own file). A new response is its file plus one line here; the scene
//! asks these facts and never names a response, and `tests/contact_scene.rs` runs every
//! response listed.

use super::Contact;
use super::{constrained, ipc, penalty, response};
use crate::integrate::{Integrator, IntegratorSettings};
use crate::model::Model;

/// What the code asks of a contact response.
#[derive(Clone, Copy, Debug)]
pub struct ResponseFacts {
    /// It is a potential inside the model (any integrator handles it unchanged).
    pub in_model: bool,
    /// It works inside the Newton loop (only with a method whose unknown is the end-of-step
    /// position); otherwise it wraps the scene's integrator or lives in the model.
    pub in_newton_loop: bool,
    /// It sees the faces of triangle-mesh obstacles; the others need a signed distance.
    pub sees_mesh_obstacles: bool,
    /// It keeps the body off itself (self-contact), so a scene without obstacles has it too,
    /// on the body's boundary surface.
    pub self_contact: bool,
    /// It chooses the Newton direction, globalization and convergence test itself (the
    /// scene's `integrator.newton` choices of them would do nothing).
    pub owns_newton_components: bool,
    /// Builds it for a scene: adds what lives in the model (a potential) and keeps what its
    /// integrator needs.
    pub build: fn(&super::ContactSetup<'_>, &mut Model) -> Contact,
    /// The scene's integrator with the response: wrapped, or with the response inside its
    /// Newton loop.
    pub integrator: fn(&Contact, &IntegratorSettings) -> Box<dyn Integrator>,
}

impl crate::registry::ListFacts for ResponseFacts {
    fn list(&self) -> Vec<crate::registry::Fact> {
        let how = if self.in_model && self.in_newton_loop {
            "potential+newton-filter"
        } else if self.in_model {
            "potential"
        } else if self.in_newton_loop {
            "newton-constraints"
        } else {
            "wraps-integrator"
        };
        vec![("acts-as", how.to_owned())]
    }
}

crate::named_enum! {
    /// How contact is resolved (`response` in `[contact]`).
    pub enum ContactResponse: "contact response", UnknownContactResponse, ResponseFacts {
        /// A stiff spring `1/2 k d^2` on the penetration depth, inside the model.
        Penalty = "penalty",
            "spring 1/2 k d^2 on the depth; any integrator, penetrates ~ load/k",
            ResponseFacts {
                in_model: true,
                in_newton_loop: false,
                sees_mesh_obstacles: false,
                self_contact: false,
                owns_newton_components: false,
                build: penalty::build,
                integrator: penalty::integrator,
            },
        /// After each step, move penetrating vertices to the surface (the body following
        /// as in a backward Euler step) and change their velocity (restitution, friction).
        Projection = "projection",
            "move to the surface after the step, restitution/friction; any integrator",
            ResponseFacts {
                in_model: false,
                in_newton_loop: false,
                sees_mesh_obstacles: false,
                self_contact: false,
                owns_newton_components: false,
                build: Contact::with_analytic_obstacles,
                integrator: response::projection,
            },
        /// Predictive: a vertex that would end the step inside gets the new velocity
        /// (restitution, friction) and moves by dt times it from where it started, so it
        /// never lands inside.
        VelocityFlip = "velocity-flip",
            "predictive: reflect the velocity of a vertex that would penetrate, redo its move",
            ResponseFacts {
                in_model: false,
                in_newton_loop: false,
                sees_mesh_obstacles: false,
                self_contact: false,
                owns_newton_components: false,
                build: Contact::with_analytic_obstacles,
                integrator: response::velocity_flip,
            },
        /// Linearized non-penetration constraints inside the Newton loop (a QP per
        /// iteration) of backward Euler, BDF-k, the Newmark family or static.
        Constrained = "constrained",
            "QP-constrained Newton (backward Euler, BDF, Newmark, static); no penetration",
            ResponseFacts {
                in_model: false,
                in_newton_loop: true,
                sees_mesh_obstacles: false,
                self_contact: false,
                owns_newton_components: true,
                build: Contact::with_analytic_obstacles,
                integrator: constrained::integrator,
            },
        /// Incremental potential contact: a barrier on the distances of every vertex–face
        /// and edge–edge pair (body, self, mesh obstacles) and of vertices to analytic
        /// obstacles, continuous collision detection in the line search, lagged friction.
        Ipc = "ipc",
            "barrier + CCD line search (backward Euler, BDF, Newmark, static); intersection-free, self-contact, friction",
            ResponseFacts {
                in_model: true,
                in_newton_loop: true,
                sees_mesh_obstacles: true,
                self_contact: true,
                owns_newton_components: false,
                build: ipc::build,
                integrator: ipc::integrator,
            },
    }
}
