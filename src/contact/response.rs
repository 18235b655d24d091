//! Responses applied after a step of any integrator: [`WithContactResponse`] runs the inner
//! integrator, then corrects the free vertices that ended inside an obstacle, and reports the
//! contacts of the new state.

use super::obstacle::{ObstacleSample, Obstacles};
use crate::integrate::{Integrator, State, StepError, StepReport};
use crate::model::Model;
use nalgebra::Vector3;
use std::sync::Arc;

/// What happens to a vertex found inside an obstacle after a step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Response {
    /// Nothing: contact is a force inside the model (the penalty potential); the wrapper only
    /// reports contacts.
    ReportOnly,
    /// Move the vertex to the nearest surface point and change its velocity relative to the
    /// obstacle (see [`VelocityRule`]).
    Projection(VelocityRule),
    /// Change the velocity only (see [`VelocityRule`]); the position is left inside.
    VelocityFlip(VelocityRule),
}

/// The velocity change at a contact, relative to the obstacle's own velocity: with `v_n` the
/// normal and `v_t` the tangential part,
/// - if the vertex approaches (`v_n < 0`), `v_n' = -restitution v_n` (1: elastic reflection,
///   0: the normal velocity is removed); a vertex already separating keeps its `v_n`;
/// - `v_t' = (1 - friction) v_t`: friction 0 keeps the tangential velocity (frictionless),
///   1 removes it (the vertex sticks).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VelocityRule {
    /// In [0, 1].
    pub restitution: f64,
    /// In [0, 1].
    pub friction: f64,
}

impl VelocityRule {
    /// The new velocity of a vertex with velocity `v` in contact with `obstacle`.
    pub fn apply(&self, v: Vector3<f64>, obstacle: &ObstacleSample) -> Vector3<f64> {
        let n = obstacle.sdf.gradient;
        let relative = v - obstacle.velocity;
        let vn = relative.dot(&n);
        let tangential = relative - n * vn;
        let vn = if vn < 0.0 { -self.restitution * vn } else { vn };
        obstacle.velocity + n * vn + tangential * (1.0 - self.friction)
    }
}

/// An integrator followed by a contact response.
pub struct WithContactResponse {
    inner: Box<dyn Integrator>,
    obstacles: Arc<Obstacles>,
    response: Response,
    margin: f64,
}

impl WithContactResponse {
    /// `inner` followed by `response` against `obstacles`; vertices within `margin` (m) of an
    /// obstacle count as contacts in the report.
    pub fn new(
        inner: Box<dyn Integrator>,
        obstacles: Arc<Obstacles>,
        response: Response,
        margin: f64,
    ) -> Self {
        Self {
            inner,
            obstacles,
            response,
            margin,
        }
    }

    /// The response.
    pub fn response(&self) -> Response {
        self.response
    }

    /// Apply the response to every free vertex at time `t`.
    fn respond(&self, state: &mut State, t: f64) {
        let (rule, project) = match self.response {
            Response::ReportOnly => return,
            Response::Projection(rule) => (rule, true),
            Response::VelocityFlip(rule) => (rule, false),
        };
        for (x, v) in state.q.chunks_exact_mut(3).zip(state.v.chunks_exact_mut(3)) {
            let mut p = Vector3::new(x[0], x[1], x[2]);
            let mut u = Vector3::new(v[0], v[1], v[2]);
            for o in self.obstacles.iter() {
                let s = o.sample(&p, t);
                if s.sdf.distance < 0.0 {
                    if project {
                        p -= s.sdf.gradient * s.sdf.distance;
                    }
                    u = rule.apply(u, &s);
                }
            }
            x.copy_from_slice(p.as_slice());
            v.copy_from_slice(u.as_slice());
        }
    }
}

impl Integrator for WithContactResponse {
    fn name(&self) -> &'static str {
        self.inner.name()
    }

    fn order(&self) -> u32 {
        self.inner.order()
    }

    fn is_explicit(&self) -> bool {
        self.inner.is_explicit()
    }

    fn advance(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        self.inner.advance(model, state, dt, report)?;
        let t = state.t + dt;
        self.respond(state, t);
        let stats = self.obstacles.stats(&state.q, t, self.margin);
        report.contacts = stats.contacts;
        report.max_penetration = stats.max_penetration;
        Ok(())
    }

    fn reset(&mut self) {
        self.inner.reset();
    }
}
