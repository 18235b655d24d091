//! Responses applied around a step of any integrator: [`WithContactResponse`] runs the inner
//! integrator, then corrects the free vertices that ended inside an obstacle, and reports the
//! contacts of the new state.
//!
//! Both corrections put each such vertex's normal coordinate on a target and change its
//! velocity by the [`VelocityRule`]; they differ in the target:
//! - projection: the obstacle's surface (the vertex's position is corrected after the fact);
//! - velocity-flip (predictive): where the vertex's flipped velocity takes it from its
//!   start-of-step position, `x_0 + dt v'`, so the step is redone with the flipped velocity
//!   and the vertex never lands inside (exactly for a plane, to O(dt² v²/R) on a curved
//!   surface of radius R), as the seeds do for a vertex that *would* penetrate.
//!
//! The rest of the body follows the correction as a backward Euler step would
//! ([`super::correction`]), so the correction does not store elastic energy the impact never
//! had.

use super::Contact;
use super::correction::{ContactRow, Correction};
use super::obstacle::{ObstacleSample, Obstacles};
use crate::integrate::IntegratorSettings;
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
    /// Change the velocity (see [`VelocityRule`]) of a vertex that would end the step inside,
    /// and move it from its start-of-step position by `dt` times the new velocity (normal
    /// coordinate), so it stays outside.
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
    correction: Correction,
    /// The state at the start of the step (restored if the correction fails).
    start_q: Vec<f64>,
    start_v: Vec<f64>,
    /// This step's contacts and the new velocity of each.
    rows: Vec<ContactRow>,
    velocities: Vec<Vector3<f64>>,
    /// Row of each free vertex in `rows`, if any.
    row_of: Vec<Option<usize>>,
    /// The inner step's result while the state is corrected.
    end_q: Vec<f64>,
    end_v: Vec<f64>,
    /// The independent intersection check of sampled frames, if attached.
    check: Option<Arc<super::frame_check::FrameCheck>>,
}

/// Passes of the correction: vertices the previous pass pushed inside join the next one.
const MAX_PASSES: usize = 4;

impl WithContactResponse {
    /// `inner` followed by `response` against `obstacles`; vertices within `margin` (m) of an
    /// obstacle count as contacts in the report.
    /// The same, answering [`Integrator::intersection_free`] with `check`.
    pub fn with_check(mut self, check: Arc<super::frame_check::FrameCheck>) -> Self {
        self.check = Some(check);
        self
    }

    pub fn new(
        inner: Box<dyn Integrator>,
        obstacles: Arc<Obstacles>,
        response: Response,
        margin: f64,
    ) -> Self {
        let correction = Correction::new(inner.is_explicit());
        Self {
            inner,
            obstacles,
            response,
            margin,
            correction,
            start_q: Vec::new(),
            start_v: Vec::new(),
            rows: Vec::new(),
            velocities: Vec::new(),
            row_of: Vec::new(),
            end_q: Vec::new(),
            end_v: Vec::new(),
            check: None,
        }
    }

    /// The response.
    pub fn response(&self) -> Response {
        self.response
    }

    /// Add a row for every free vertex of `q` inside an obstacle at time `t` that has none
    /// yet (its deepest obstacle); returns how many were added.
    fn add_rows(&mut self, q: &[f64], v: &[f64], t: f64, dt: f64) -> usize {
        let (rule, predictive) = match self.response {
            Response::ReportOnly => return 0,
            Response::Projection(rule) => (rule, false),
            Response::VelocityFlip(rule) => (rule, true),
        };
        let mut added = 0;
        for (f, x) in q.chunks_exact(3).enumerate() {
            if self.row_of[f].is_some() {
                continue;
            }
            let p = Vector3::new(x[0], x[1], x[2]);
            let deepest = self
                .obstacles
                .iter()
                .map(|o| o.sample(&p, t))
                .filter(|s| s.sdf.distance < 0.0)
                .min_by(|a, b| a.sdf.distance.total_cmp(&b.sdf.distance));
            let Some(s) = deepest else { continue };
            let n = s.sdf.gradient;
            let u = rule.apply(Vector3::from_column_slice(&v[3 * f..][..3]), &s);
            let target = if predictive {
                n.dot(&(Vector3::from_column_slice(&self.start_q[3 * f..][..3]) + dt * u))
            } else {
                n.dot(&p) - s.sdf.distance
            };
            self.row_of[f] = Some(self.rows.len());
            self.rows.push(ContactRow {
                vertex: f,
                normal: n,
                target,
            });
            self.velocities.push(u);
            added += 1;
        }
        added
    }

    /// Correct the state after the inner step: positions at `t`, start-of-step copies in
    /// `start_q`/`start_v`.
    fn respond(
        &mut self,
        model: &mut Model,
        state: &mut State,
        t: f64,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        // The inner step's result, kept while `state` is corrected (buffers reused).
        let mut q1 = std::mem::take(&mut self.end_q);
        let mut v1 = std::mem::take(&mut self.end_v);
        q1.clone_from(&state.q);
        v1.clone_from(&state.v);
        let result = self.correct(model, state, &q1, &v1, t, dt, report);
        self.end_q = q1;
        self.end_v = v1;
        result
    }

    #[allow(clippy::too_many_arguments)]
    fn correct(
        &mut self,
        model: &mut Model,
        state: &mut State,
        q1: &[f64],
        v1: &[f64],
        t: f64,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        self.rows.clear();
        self.velocities.clear();
        self.row_of.clear();
        self.row_of.resize(q1.len() / 3, None);
        let mut added = self.add_rows(q1, v1, t, dt);
        let mut passes = 0;
        while added > 0 && passes < MAX_PASSES {
            passes += 1;
            let dx = self
                .correction
                .solve(model, q1, dt, &self.rows, passes == 1, report)?;
            for ((q, x), d) in state.q.iter_mut().zip(q1).zip(dx) {
                *q = x + d;
            }
            added = self.add_rows(&state.q, v1, t, dt);
        }
        // Contact vertices take the rule's velocity; the rest of the body follows the
        // correction with the velocity change dx / dt (backward Euler's v = (x - x_0) / dt).
        for (f, ((v, q), x)) in state
            .v
            .chunks_exact_mut(3)
            .zip(state.q.chunks_exact(3))
            .zip(q1.chunks_exact(3))
            .enumerate()
        {
            match self.row_of[f] {
                Some(r) => v.copy_from_slice(self.velocities[r].as_slice()),
                None => {
                    for i in 0..3 {
                        v[i] += (q[i] - x[i]) / dt;
                    }
                }
            }
        }
        Ok(())
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

    fn check_model(&self, model: &Model) -> Result<(), StepError> {
        self.inner.check_model(model)
    }

    fn internal_steps(&self) -> &[f64] {
        self.inner.internal_steps()
    }

    fn drain_iteration_log(&mut self, out: &mut Vec<crate::integrate::newton::IterationRecord>) {
        self.inner.drain_iteration_log(out);
    }

    fn intersection_free(&self, model: &Model, state: &State) -> Option<bool> {
        let check = self.check.as_ref()?;
        Some(check.intersection_free(&model.full_positions(&state.q), state.t))
    }

    fn advance(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        if self.response != Response::ReportOnly {
            self.start_q.clone_from(&state.q);
            self.start_v.clone_from(&state.v);
        }
        self.inner.advance(model, state, dt, report)?;
        let t = state.t + dt;
        if self.response != Response::ReportOnly
            && let Err(e) = self.respond(model, state, t, dt, report)
        {
            state.q.clone_from(&self.start_q);
            state.v.clone_from(&self.start_v);
            return Err(e);
        }
        let stats = self.obstacles.stats(&state.q, t, self.margin);
        report.contacts = stats.contacts;
        report.max_penetration = stats.max_penetration;
        Ok(())
    }

    fn reset(&mut self) {
        self.inner.reset();
    }
}

/// The projection response: the scene's integrator, then penetrating vertices moved to the
/// surface with their velocity changed.
pub(super) fn projection(contact: &Contact, settings: &IntegratorSettings) -> Box<dyn Integrator> {
    contact.wrapped(
        settings.build(),
        Response::Projection(contact.velocity_rule()),
    )
}

/// The velocity-flip response: the scene's integrator, then a vertex that would penetrate
/// gets the new velocity and redoes its move.
pub(super) fn velocity_flip(
    contact: &Contact,
    settings: &IntegratorSettings,
) -> Box<dyn Integrator> {
    contact.wrapped(
        settings.build(),
        Response::VelocityFlip(contact.velocity_rule()),
    )
}
