//! The incremental potential `E` of a [`Problem`] and its gradient, evaluated with reusable
//! buffers, with the scale of each value's round-off.

use super::vectors::{axpy, dot, norm};
use crate::model::{Model, ModelError};
use crate::sparse::SymmetricMatrix;

/// One incremental potential to minimize (see the module docs), plus the damping term
/// `1/2 gamma (x - x_d)^T D (x - x_d)` when [`Newton::prepare_damping`] set one for the step,
/// and a constant linear term `l^T x` (a force known at the start of the step, as the
/// generalized-α family has).
#[derive(Clone, Copy, Debug, Default)]
pub struct Problem<'a> {
    /// `x_hat`.
    pub x_hat: &'a [f64],
    /// The start-of-step positions (the convergence scale; the fallback initial guess).
    pub x_ref: &'a [f64],
    /// `beta`.
    pub beta: f64,
    /// `x_d`, where the damping term is zero.
    pub damping_anchor: &'a [f64],
    /// `l`, or empty for none.
    pub linear: &'a [f64],
    /// No inertial term: minimize `beta V(x) + l^T x` alone (a static equilibrium).
    pub quasi_static: bool,
    /// The size of the forces when the scheme knows it better than `‖grad V‖` at the guess
    /// (a static solve that starts at equilibrium); 0 for none.
    pub force_scale: f64,
}

/// Energies whose predicted decrease is below this many ulps of their scale are treated as
/// round-off in the line search.
const ROUNDOFF_ULPS: f64 = 256.0;

/// An objective value with the scale of its round-off.
pub struct Objective {
    pub value: f64,
    pub roundoff: f64,
    /// The sum of the magnitudes of its terms (what its round-off is relative to).
    pub scale: f64,
}

/// Evaluates the incremental potential `E` of a [`Problem`] and its gradient with reusable
/// buffers.
#[derive(Default)]
pub struct IncrementalPotential {
    /// The gradient `g` after [`Self::gradient`].
    pub g: Vec<f64>,
    /// `grad V(x)` after [`Self::gradient`].
    pub grad_v: Vec<f64>,
    d: Vec<f64>,
    md: Vec<f64>,
    dd: Vec<f64>,
    trial_d: Vec<f64>,
}

impl IncrementalPotential {
    /// Size the buffers for `n` DOFs (allocates only when `n` grows).
    pub fn resize(&mut self, n: usize) {
        for buf in [
            &mut self.g,
            &mut self.grad_v,
            &mut self.d,
            &mut self.md,
            &mut self.dd,
            &mut self.trial_d,
        ] {
            buf.resize(n, 0.0);
        }
    }

    /// `‖M (x_hat − x_ref)‖ + ‖l‖`, the size of the step's inertial and constant terms.
    pub fn inertial_scale(&mut self, model: &Model, p: &Problem<'_>) -> f64 {
        let linear = norm(p.linear);
        if p.quasi_static {
            return linear;
        }
        for ((d, a), b) in self.d.iter_mut().zip(p.x_hat).zip(p.x_ref) {
            *d = a - b;
        }
        model.mass().mul_vec(&self.d, &mut self.md);
        norm(&self.md) + linear
    }

    /// `1/2 gamma (x - x_d)^T D (x - x_d)` and, into `self.dd`, `gamma D (x - x_d)`.
    fn damping_term(
        &mut self,
        damping: Option<(&SymmetricMatrix, f64)>,
        x: &[f64],
        anchor: &[f64],
    ) -> f64 {
        let Some((d, gamma)) = damping else {
            self.dd.fill(0.0);
            return 0.0;
        };
        for ((t, xi), a) in self.trial_d.iter_mut().zip(x).zip(anchor) {
            *t = xi - a;
        }
        d.mul_vec(&self.trial_d, &mut self.dd);
        let e = 0.5 * gamma * dot(&self.trial_d, &self.dd);
        self.dd.iter_mut().for_each(|v| *v *= gamma);
        e
    }

    /// `E(x)` and the scale of its round-off (which includes the magnitudes of the terms that
    /// cancel in the potential, [`Model::energy_roundoff_scale`]).
    pub fn objective(
        &mut self,
        model: &mut Model,
        damping: Option<(&SymmetricMatrix, f64)>,
        p: &Problem<'_>,
        x: &[f64],
    ) -> Result<Objective, ModelError> {
        let inertia = if p.quasi_static {
            0.0
        } else {
            for ((d, xi), xh) in self.d.iter_mut().zip(x).zip(p.x_hat) {
                *d = xi - xh;
            }
            model.mass().mul_vec(&self.d, &mut self.md);
            0.5 * dot(&self.d, &self.md)
        };
        let parts = model.potential_parts(x)?;
        let damping = self.damping_term(damping, x, p.damping_anchor);
        let linear = if p.linear.is_empty() {
            0.0
        } else {
            dot(p.linear, x)
        };
        let value = inertia + p.beta * parts.total() + damping + linear;
        let terms = parts.elastic.abs()
            + parts.springs.abs()
            + parts.gravity.abs()
            + parts.vertex.abs()
            + parts.contact.abs();
        let scale = inertia.abs()
            + p.beta * (terms + model.energy_roundoff_scale())
            + damping.abs()
            + linear.abs();
        Ok(Objective {
            value,
            roundoff: ROUNDOFF_ULPS * f64::EPSILON * scale,
            scale,
        })
    }

    /// `g = M (x - x_hat) + beta grad V(x) + gamma D (x - x_d) + l` into `self.g`, and
    /// `grad V(x)` into `self.grad_v`.
    pub fn gradient(
        &mut self,
        model: &mut Model,
        damping: Option<(&SymmetricMatrix, f64)>,
        p: &Problem<'_>,
        x: &[f64],
    ) -> Result<(), ModelError> {
        if p.quasi_static {
            self.md.fill(0.0);
        } else {
            for ((d, xi), xh) in self.d.iter_mut().zip(x).zip(p.x_hat) {
                *d = xi - xh;
            }
            model.mass().mul_vec(&self.d, &mut self.md);
        }
        model.gradient(x, &mut self.grad_v)?;
        self.damping_term(damping, x, p.damping_anchor);
        for (((g, md), gv), dd) in self
            .g
            .iter_mut()
            .zip(&self.md)
            .zip(&self.grad_v)
            .zip(&self.dd)
        {
            *g = md + p.beta * gv + dd;
        }
        if !p.linear.is_empty() {
            axpy(1.0, p.linear, &mut self.g);
        }
        Ok(())
    }
}
