//! The penalty response: a stiff spring pushing each penetrating vertex out of each obstacle,
//! as a per-vertex potential of the model, so every integrator sees contact as a force (and
//! implicit ones see its Hessian).

use super::obstacle::Obstacles;
use super::{Contact, ContactSetup, Response};
use crate::integrate::{Integrator, IntegratorSettings};
use crate::model::Model;
use crate::model::VertexPotential;
use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use std::sync::Arc;

/// `phi(x) = sum over obstacles of 1/2 k d^2`, with `d = -sdf(x)` the penetration depth where
/// `sdf < 0` (zero outside). Its gradient is `k sdf n` (pushing out along the normal `n`) and
/// its Hessian `k (n n^T + sdf H_sdf)`: the normal stiffness plus a curvature term, which
/// vanishes for flat faces and is negative semi-definite on convex curved ones (`sdf < 0`,
/// `H_sdf` PSD). With `project`, each block's eigenvalues are clamped at zero — for the convex
/// shapes here that is exactly the Gauss-Newton block `k n n^T`.
///
/// The energy is C1 (the force is continuous at the surface, the stiffness jumps from 0 to k).
/// A resting body sinks until the penalty carries its weight: about `m g / (k N)` for `N`
/// vertices in contact.
#[derive(Debug)]
pub struct PenaltyContact {
    obstacles: Arc<Obstacles>,
    stiffness: f64,
}

impl PenaltyContact {
    /// A penalty of `stiffness` (N/m, per vertex and obstacle).
    ///
    /// # Panics
    /// If `stiffness` is not positive and finite.
    pub fn new(obstacles: Arc<Obstacles>, stiffness: f64) -> Self {
        assert!(
            stiffness > 0.0 && stiffness.is_finite(),
            "PenaltyContact: the stiffness must be positive and finite, got {stiffness}"
        );
        Self {
            obstacles,
            stiffness,
        }
    }

    /// The stiffness (N/m).
    pub fn stiffness(&self) -> f64 {
        self.stiffness
    }

    /// Call `f(vertex, sample)` for every vertex inside an obstacle.
    fn each_penetration(
        &self,
        t: f64,
        x: &[Vector3<f64>],
        f: &mut dyn FnMut(usize, &super::ObstacleSample),
    ) {
        for (v, p) in x.iter().enumerate() {
            for o in self.obstacles.iter() {
                let s = o.sample(p, t);
                if s.sdf.distance < 0.0 {
                    f(v, &s);
                }
            }
        }
    }
}

impl VertexPotential for PenaltyContact {
    fn name(&self) -> &str {
        "contact"
    }

    fn energy(&self, t: f64, x: &[Vector3<f64>]) -> f64 {
        let mut e = 0.0;
        self.each_penetration(t, x, &mut |_, s| {
            e += 0.5 * self.stiffness * s.sdf.distance * s.sdf.distance;
        });
        e
    }

    fn gradient(&self, t: f64, x: &[Vector3<f64>], add: &mut dyn FnMut(usize, Vector3<f64>)) {
        self.each_penetration(t, x, &mut |v, s| {
            add(v, s.sdf.gradient * (self.stiffness * s.sdf.distance));
        });
    }

    fn hessian(
        &self,
        t: f64,
        x: &[Vector3<f64>],
        project: bool,
        add: &mut dyn FnMut(usize, Matrix3<f64>),
    ) {
        let k = self.stiffness;
        self.each_penetration(t, x, &mut |v, s| {
            let n = s.sdf.gradient;
            let block = (n * n.transpose() + s.sdf.hessian * s.sdf.distance) * k;
            add(v, if project { project_psd(block) } else { block });
        });
    }
}

/// The nearest positive semi-definite matrix to a symmetric `m` (eigenvalues clamped at 0).
fn project_psd(m: Matrix3<f64>) -> Matrix3<f64> {
    let mut eig = SymmetricEigen::new(m);
    if eig.eigenvalues.iter().all(|l| *l >= 0.0) {
        return m;
    }
    eig.eigenvalues.iter_mut().for_each(|l| *l = l.max(0.0));
    eig.recompose()
}

/// The penalty response for a scene: its analytic obstacles, and the penalty potential added
/// to `model`.
pub(super) fn build(setup: &ContactSetup<'_>, model: &mut Model) -> Contact {
    let contact = Contact::with_analytic_obstacles(setup, model);
    model.add_vertex_potential(Box::new(PenaltyContact::new(
        contact.obstacles.clone(),
        setup.config.stiffness,
    )));
    contact
}

/// The scene's integrator as it is (the penalty acts in the model), reporting contacts.
pub(super) fn integrator(contact: &Contact, settings: &IntegratorSettings) -> Box<dyn Integrator> {
    contact.wrapped(settings.build(), Response::ReportOnly)
}
