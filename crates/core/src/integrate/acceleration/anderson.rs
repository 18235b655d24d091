//! Type-II Anderson acceleration (Walker & Ni 2011; safeguarded as in Peng et al. 2018,
//! "Anderson acceleration for geometry optimization and physics simulation").
//!
//! With `g_k = G(x_k)` and the residual `f_k = g_k − x_k`, the last `m` differences
//! `Δf_i = f_{i+1} − f_i`, `Δg_i = g_{i+1} − g_i` are kept (a ring of columns). The next
//! iterate is `x_{k+1} = g_k − ΔG γ` with `γ = argmin ‖f_k − ΔF γ‖₂`.
//!
//! The least-squares problem is solved by its normal equations `(ΔFᵀΔF + εI) γ = ΔFᵀ f_k`
//! with a Cholesky factorization of the m×m Gram matrix. Squaring the condition number is
//! harmless here: every column pair is scaled by `1/‖Δf‖` so the Gram matrix has a unit
//! diagonal, `ε = 1e-10` keeps it positive definite when columns become nearly parallel, the
//! Gram matrix is updated one row per iteration (O(m n), the cost of a QR update without its
//! bookkeeping), and a poor γ can only cost an iteration: the safeguard rejects it.
//!
//! Safeguard: if the accelerated iterate's incremental potential is not finite or exceeds
//! the plain iterate's, the plain iterate is kept and the history restarted; these fallbacks
//! (and restarts for a singular Gram matrix) are counted in
//! [`StepReport::anderson_fallbacks`]. Every buffer is sized in [`Accelerate::start`].

use super::accelerate::Accelerate;
use crate::integrate::{StepError, StepReport};

/// Tikhonov regularization of the unit-diagonal Gram matrix.
const REGULARIZATION: f64 = 1e-10;

/// The Anderson accelerator's state.
#[derive(Debug, Default)]
pub struct Anderson {
    m: usize,
    n: usize,
    /// Columns stored, and the slot the next one goes into.
    columns: usize,
    head: usize,
    /// Whether `f_prev`/`g_prev` hold the previous iteration's residual and plain iterate.
    has_previous: bool,
    /// `ΔF`, `ΔG`: m columns of n, column-major.
    delta_f: Vec<f64>,
    delta_g: Vec<f64>,
    /// `ΔFᵀ ΔF` (m × m, only the stored columns meaningful) and the Cholesky scratch.
    gram: Vec<f64>,
    factor: Vec<f64>,
    gamma: Vec<f64>,
    x_k: Vec<f64>,
    f: Vec<f64>,
    f_prev: Vec<f64>,
    g_prev: Vec<f64>,
    accelerated: Vec<f64>,
    /// Fallbacks and restarts in this step.
    fallbacks: u32,
}

impl Anderson {
    /// An Anderson accelerator with history `m` (differences kept, at least 1).
    pub fn new(m: u32) -> Self {
        Self {
            m: m.max(1) as usize,
            ..Self::default()
        }
    }

    fn restart(&mut self) {
        self.columns = 0;
        self.head = 0;
    }

    /// Store the newest difference pair in the ring and refresh its Gram row; false when
    /// `Δf` vanishes (nothing to learn from it).
    fn push_difference(&mut self, g: &[f64]) -> bool {
        let (n, slot) = (self.n, self.head);
        let df = &mut self.delta_f[slot * n..(slot + 1) * n];
        let dg = &mut self.delta_g[slot * n..(slot + 1) * n];
        let mut norm2 = 0.0;
        for i in 0..n {
            df[i] = self.f[i] - self.f_prev[i];
            dg[i] = g[i] - self.g_prev[i];
            norm2 += df[i] * df[i];
        }
        let norm = norm2.sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            return false;
        }
        for i in 0..n {
            df[i] /= norm;
            dg[i] /= norm;
        }
        self.head = (self.head + 1) % self.m;
        self.columns = (self.columns + 1).min(self.m);
        let m = self.m;
        for j in 0..self.columns {
            let dot = if j == slot {
                1.0
            } else {
                let other = &self.delta_f[j * n..(j + 1) * n];
                let df = &self.delta_f[slot * n..(slot + 1) * n];
                df.iter().zip(other).map(|(a, b)| a * b).sum()
            };
            self.gram[slot * m + j] = dot;
            self.gram[j * m + slot] = dot;
        }
        true
    }

    /// γ of the least-squares problem over the stored columns; false if the regularized Gram
    /// matrix is not numerically positive definite.
    fn solve_gamma(&mut self) -> bool {
        let (n, m, c) = (self.n, self.m, self.columns);
        for j in 0..c {
            let col = &self.delta_f[j * n..(j + 1) * n];
            self.gamma[j] = col.iter().zip(&self.f).map(|(a, b)| a * b).sum();
        }
        // Cholesky of the leading c×c block (slots 0..c hold the columns, in ring order).
        let l = &mut self.factor;
        for j in 0..c {
            for i in j..c {
                let mut s = self.gram[i * m + j] + if i == j { REGULARIZATION } else { 0.0 };
                for k in 0..j {
                    s -= l[i * m + k] * l[j * m + k];
                }
                if i == j {
                    if !(s > 0.0 && s.is_finite()) {
                        return false;
                    }
                    l[j * m + j] = s.sqrt();
                } else {
                    l[i * m + j] = s / l[j * m + j];
                }
            }
        }
        for i in 0..c {
            let mut s = self.gamma[i];
            for k in 0..i {
                s -= l[i * m + k] * self.gamma[k];
            }
            self.gamma[i] = s / l[i * m + i];
        }
        for i in (0..c).rev() {
            let mut s = self.gamma[i];
            for k in i + 1..c {
                s -= l[k * m + i] * self.gamma[k];
            }
            self.gamma[i] = s / l[i * m + i];
        }
        self.gamma[..c].iter().all(|g| g.is_finite())
    }
}

impl Accelerate for Anderson {
    fn start(&mut self, x0: &[f64]) {
        let n = x0.len();
        if self.n != n || self.gram.len() != self.m * self.m {
            self.n = n;
            let m = self.m;
            self.delta_f = vec![0.0; m * n];
            self.delta_g = vec![0.0; m * n];
            self.gram = vec![0.0; m * m];
            self.factor = vec![0.0; m * m];
            self.gamma = vec![0.0; m];
            self.f = vec![0.0; n];
            self.f_prev = vec![0.0; n];
            self.g_prev = vec![0.0; n];
            self.accelerated = vec![0.0; n];
            self.x_k = vec![0.0; n];
        }
        self.x_k.copy_from_slice(x0);
        self.has_previous = false;
        self.fallbacks = 0;
        self.restart();
    }

    fn update(
        &mut self,
        x: &mut [f64],
        energy: &mut dyn FnMut(&[f64]) -> Result<f64, StepError>,
    ) -> Result<(), StepError> {
        for ((f, g), xk) in self.f.iter_mut().zip(x.iter()).zip(&self.x_k) {
            *f = g - xk;
        }
        let pushed = self.has_previous && self.push_difference(x);
        if self.has_previous && !pushed {
            self.restart();
        }
        self.f_prev.copy_from_slice(&self.f);
        self.g_prev.copy_from_slice(x);
        self.has_previous = true;
        if self.columns > 0 {
            if self.solve_gamma() {
                let n = self.n;
                self.accelerated.copy_from_slice(x);
                for j in 0..self.columns {
                    let (gj, col) = (self.gamma[j], &self.delta_g[j * n..(j + 1) * n]);
                    for (a, d) in self.accelerated.iter_mut().zip(col) {
                        *a -= gj * d;
                    }
                }
                let plain = energy(x).unwrap_or(f64::INFINITY);
                match energy(&self.accelerated) {
                    Ok(e) if e.is_finite() && e <= plain => x.copy_from_slice(&self.accelerated),
                    _ => {
                        self.fallbacks += 1;
                        self.restart();
                    }
                }
            } else {
                self.fallbacks += 1;
                self.restart();
            }
        }
        self.x_k.copy_from_slice(x);
        Ok(())
    }

    fn report(&self, report: &mut StepReport) {
        report.anderson_fallbacks += self.fallbacks;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// G(x) = A x + b with a slowly contracting diagonal A: Anderson with m >= 2 solves a
    /// 2-D linear fixed point exactly in a few iterations; the plain iteration does not.
    #[test]
    fn anderson_solves_a_linear_fixed_point_far_faster_than_plain_iteration() {
        let g = |x: &[f64], out: &mut [f64]| {
            out[0] = 0.99 * x[0] + 1.0;
            out[1] = 0.95 * x[1] - 2.0;
        };
        let solution = [100.0, -40.0];
        let error =
            |x: &[f64]| ((x[0] - solution[0]).powi(2) + (x[1] - solution[1]).powi(2)).sqrt();
        // Energy ½‖x − x*‖² in the metric where G contracts: the safeguard never trips here.
        let mut energy = |x: &[f64]| Ok(error(x));
        let mut anderson = Anderson::new(3);
        let mut x = [0.0, 0.0];
        anderson.start(&x);
        let mut plain = x;
        for _ in 0..6 {
            let mut next = [0.0; 2];
            g(&x, &mut next);
            anderson.update(&mut next, &mut energy).unwrap();
            x = next;
            let mut p = [0.0; 2];
            g(&plain, &mut p);
            plain = p;
        }
        assert!(error(&x) < 1e-8, "anderson error {}", error(&x));
        assert!(error(&plain) > 10.0, "plain error {}", error(&plain));
        assert_eq!(anderson.fallbacks, 0);
    }
}
