//! Restarted GMRES for a linear operator given as a closure (`w = A v`), for systems whose
//! matrix is never formed: a Newton–Krylov solve whose Jacobian-vector products are finite
//! differences of a residual, preconditioned inside the closure. Arnoldi with modified
//! Gram–Schmidt and Givens rotations (Saad & Schultz 1986); the Krylov basis is allocated
//! once per size and reused, so repeated solves allocate nothing.

use super::dot;

/// The operator: `apply(v, w)` sets `w = A v`; an error ends the solve.
pub type Operator<'a, E> = dyn FnMut(&[f64], &mut [f64]) -> Result<(), E> + 'a;

/// What a solve did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GmresReport {
    /// Operator applications (Arnoldi steps over all restarts).
    pub iterations: usize,
    /// `‖b − A x‖ / ‖b‖` by the recurrence (no extra operator application).
    pub relative_residual: f64,
    /// Whether it reached the tolerance.
    pub converged: bool,
}

/// GMRES(m) with its workspace.
#[derive(Debug, Default)]
pub struct Gmres {
    restart: usize,
    /// `restart + 1` basis vectors of length n, one after the other.
    basis: Vec<f64>,
    /// The Hessenberg matrix, column-major `(restart + 1) × restart`.
    hessenberg: Vec<f64>,
    cosines: Vec<f64>,
    sines: Vec<f64>,
    /// The rotated right-hand side `‖r‖ e_1`.
    g: Vec<f64>,
    y: Vec<f64>,
    w: Vec<f64>,
}

impl Gmres {
    /// A solver restarting every `restart` steps (at least 1).
    pub fn new(restart: usize) -> Self {
        Self {
            restart: restart.max(1),
            ..Self::default()
        }
    }

    /// Solve `A x = b` from `x = 0` until `‖b − A x‖ <= tolerance ‖b‖` or `max_iterations`
    /// operator applications; `x` holds the best iterate. `apply(v, w)` sets `w = A v`; its
    /// error ends the solve.
    pub fn solve<E>(
        &mut self,
        apply: &mut Operator<'_, E>,
        b: &[f64],
        x: &mut [f64],
        tolerance: f64,
        max_iterations: usize,
    ) -> Result<GmresReport, E> {
        let n = b.len();
        let m = self.restart;
        self.basis.resize((m + 1) * n, 0.0);
        self.hessenberg.resize((m + 1) * m, 0.0);
        for v in [&mut self.cosines, &mut self.sines, &mut self.y] {
            v.resize(m, 0.0);
        }
        self.g.resize(m + 1, 0.0);
        self.w.resize(n, 0.0);
        x.iter_mut().for_each(|v| *v = 0.0);
        let b_norm = dot(b, b).sqrt();
        let mut report = GmresReport {
            iterations: 0,
            relative_residual: 1.0,
            converged: b_norm == 0.0,
        };
        if report.converged {
            report.relative_residual = 0.0;
            return Ok(report);
        }
        let target = tolerance * b_norm;
        while report.iterations < max_iterations {
            // r = b − A x into the first basis vector.
            let (first, rest) = self.basis.split_at_mut(n);
            if report.iterations == 0 {
                first.copy_from_slice(b);
            } else {
                apply(x, &mut rest[..n])?;
                for ((r, bi), ax) in first.iter_mut().zip(b).zip(&rest[..n]) {
                    *r = bi - ax;
                }
            }
            let beta = dot(first, first).sqrt();
            if beta <= target {
                report.relative_residual = beta / b_norm;
                report.converged = true;
                return Ok(report);
            }
            first.iter_mut().for_each(|v| *v /= beta);
            self.g.iter_mut().for_each(|v| *v = 0.0);
            self.g[0] = beta;
            let mut k = 0;
            while k < m && report.iterations < max_iterations {
                self.arnoldi(apply, n, k)?;
                report.iterations += 1;
                k += 1;
                let residual = self.g[k].abs();
                report.relative_residual = residual / b_norm;
                if residual <= target {
                    report.converged = true;
                    break;
                }
            }
            self.update(x, n, k);
            if report.converged {
                return Ok(report);
            }
        }
        Ok(report)
    }

    /// Arnoldi step `k`: `w = A v_k` orthogonalized against `v_0..v_k` into `v_{k+1}`, the
    /// Hessenberg column rotated by the earlier Givens rotations and a new one that zeroes
    /// its subdiagonal, applied to `g`.
    fn arnoldi<E>(&mut self, apply: &mut Operator<'_, E>, n: usize, k: usize) -> Result<(), E> {
        let m1 = self.restart + 1;
        apply(&self.basis[k * n..(k + 1) * n], &mut self.w)?;
        let column = &mut self.hessenberg[k * m1..(k + 1) * m1];
        for (i, h) in column.iter_mut().enumerate().take(k + 1) {
            let v = &self.basis[i * n..(i + 1) * n];
            *h = dot(&self.w, v);
            for (wj, vj) in self.w.iter_mut().zip(v) {
                *wj -= *h * vj;
            }
        }
        let norm = dot(&self.w, &self.w).sqrt();
        column[k + 1] = norm;
        let next = &mut self.basis[(k + 1) * n..(k + 2) * n];
        if norm > 0.0 {
            for (vj, wj) in next.iter_mut().zip(&self.w) {
                *vj = wj / norm;
            }
        }
        for i in 0..k {
            let (c, s) = (self.cosines[i], self.sines[i]);
            let (a, b) = (column[i], column[i + 1]);
            column[i] = c * a + s * b;
            column[i + 1] = -s * a + c * b;
        }
        let (a, b) = (column[k], column[k + 1]);
        let r = a.hypot(b);
        let (c, s) = if r == 0.0 { (1.0, 0.0) } else { (a / r, b / r) };
        self.cosines[k] = c;
        self.sines[k] = s;
        column[k] = r;
        column[k + 1] = 0.0;
        self.g[k + 1] = -s * self.g[k];
        self.g[k] *= c;
        Ok(())
    }

    /// `x += V_k y` with `y` solving the `k × k` triangular system `R y = g`.
    fn update(&mut self, x: &mut [f64], n: usize, k: usize) {
        let m1 = self.restart + 1;
        for i in (0..k).rev() {
            let mut sum = self.g[i];
            for j in i + 1..k {
                sum -= self.hessenberg[j * m1 + i] * self.y[j];
            }
            let diagonal = self.hessenberg[i * m1 + i];
            self.y[i] = if diagonal == 0.0 { 0.0 } else { sum / diagonal };
        }
        for j in 0..k {
            let yj = self.y[j];
            for (xi, vi) in x.iter_mut().zip(&self.basis[j * n..(j + 1) * n]) {
                *xi += yj * vi;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A non-symmetric 40×40 system: GMRES reaches the tolerance, and without restarts in at
    /// most n steps; restarted, it still converges (the matrix is diagonally dominant).
    #[test]
    fn gmres_solves_a_nonsymmetric_system() {
        let n = 40;
        let a = nalgebra::DMatrix::from_fn(n, n, |i, j| {
            if i == j {
                4.0 + i as f64 * 0.1
            } else if j == i + 1 {
                -1.5
            } else if i == j + 2 {
                0.7
            } else {
                0.0
            }
        });
        let expected = nalgebra::DVector::from_fn(n, |i, _| (i as f64 * 0.37).sin());
        let b = &a * &expected;
        for restart in [n, 7] {
            let mut gmres = Gmres::new(restart);
            let mut x = vec![0.0; n];
            let mut apply = |v: &[f64], w: &mut [f64]| -> Result<(), ()> {
                let r = &a * nalgebra::DVector::from_column_slice(v);
                w.copy_from_slice(r.as_slice());
                Ok(())
            };
            let report = gmres
                .solve(&mut apply, b.as_slice(), &mut x, 1e-12, 400)
                .unwrap();
            assert!(report.converged, "restart {restart}: {report:?}");
            let error = (nalgebra::DVector::from_column_slice(&x) - &expected).norm();
            assert!(error < 1e-9, "restart {restart}: {error}");
            // The recurrence's residual is the true one.
            let true_residual = (&b - &a * nalgebra::DVector::from_column_slice(&x)).norm();
            assert!((true_residual / b.norm() - report.relative_residual).abs() < 1e-10);
        }
    }
}
