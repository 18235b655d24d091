//! Springs between two vertices: energy `k/2 (|x_i - x_j| - L)^2` with gradient and Hessian.

use crate::fem::ElementFilter;
use nalgebra::{Matrix3, Vector3};

/// A spring joining vertices `i` and `j` with rest length `rest_length` (>= 0), stiffness
/// `stiffness` (N/m) and damping `damping` (N s/m) along its direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spring {
    pub i: usize,
    pub j: usize,
    pub rest_length: f64,
    pub stiffness: f64,
    /// Damping coefficient c: force `-c ((v_i - v_j) . u) u` on `i` (0 for none).
    pub damping: f64,
}

impl Spring {
    /// Energy at endpoint positions `xi`, `xj`.
    #[inline]
    pub fn energy(&self, xi: &Vector3<f64>, xj: &Vector3<f64>) -> f64 {
        let stretch = (xi - xj).norm() - self.rest_length;
        0.5 * self.stiffness * stretch * stretch
    }

    /// Gradient with respect to `[xi, xj]`, written to `out[0..6]`.
    #[inline]
    pub fn gradient(&self, xi: &Vector3<f64>, xj: &Vector3<f64>, out: &mut [f64]) {
        let d = xi - xj;
        let l = d.norm();
        // For L = 0 the force k d is exact and defined at l = 0; otherwise k (l - L) d / l,
        // with no force when the direction is undefined (l = 0).
        let f = if self.rest_length == 0.0 {
            d * self.stiffness
        } else if l > 0.0 {
            d * (self.stiffness * (l - self.rest_length) / l)
        } else {
            Vector3::zeros()
        };
        out[0..3].copy_from_slice(f.as_slice());
        out[3..6].copy_from_slice((-f).as_slice());
    }

    /// Hessian `[[K, -K], [-K, K]]` with `K = k (u u^T + (1 - L/l)(I - u u^T))`, written
    /// block-major (see [`crate::fem`]) to `out[0..36]`. With `project`, the compressive term `1 - L/l < 0` is
    /// clamped to 0, which makes the block positive semi-definite.
    #[inline]
    pub fn hessian(&self, xi: &Vector3<f64>, xj: &Vector3<f64>, project: bool, out: &mut [f64]) {
        self.hessian_filtered(xi, xj, project.then_some(&ElementFilter::CLAMP), out);
    }

    /// [`Self::hessian`] through an eigenvalue filter, in closed form: the 6×6 matrix has
    /// eigenvalues `2k` (stretch, > 0), `2k t` twice (transverse, `t = 1 - L/l`) and three
    /// zeros (translations); the filter maps `2k t` to `φ(2k t)` (see
    /// [`crate::fem::ElementFilter`]) and leaves the others. Returns whether it changed `t`.
    #[inline]
    pub fn hessian_filtered(
        &self,
        xi: &Vector3<f64>,
        xj: &Vector3<f64>,
        filter: Option<&ElementFilter>,
        out: &mut [f64],
    ) -> bool {
        let d = xi - xj;
        let l = d.norm();
        let k = self.stiffness;
        let mut changed = false;
        let block = if self.rest_length == 0.0 || l == 0.0 {
            Matrix3::identity() * k
        } else {
            let u = d / l;
            let uu = u * u.transpose();
            let mut t = 1.0 - self.rest_length / l;
            if let Some(f) = filter {
                let transverse = 2.0 * k * t;
                if f.needed(transverse.min(2.0 * k), transverse.abs().max(2.0 * k)) {
                    t = f.map(transverse) / (2.0 * k);
                    changed = true;
                }
            }
            (uu + (Matrix3::identity() - uu) * t) * k
        };
        for (a, b) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            let sign = if a == b { 1.0 } else { -1.0 };
            let o = crate::fem::block_offset(2, a, b);
            for (dst, src) in out[o..o + 9].iter_mut().zip(block.iter()) {
                *dst = sign * src;
            }
        }
        changed
    }
}

impl Spring {
    /// The dashpot force on `[xi, xj]` for velocities `[vi, vj]`: `c ((vi - vj) . u) u` on `i`
    /// (the negative on `j`), written to `out[0..6]` as `D v` (the force is its negative).
    #[inline]
    pub fn damping_force(
        &self,
        xi: &Vector3<f64>,
        xj: &Vector3<f64>,
        vi: &Vector3<f64>,
        vj: &Vector3<f64>,
        out: &mut [f64],
    ) {
        let d = xi - xj;
        let l = d.norm();
        let f = if l > 0.0 && self.damping != 0.0 {
            let u = d / l;
            u * (self.damping * (vi - vj).dot(&u))
        } else {
            Vector3::zeros()
        };
        out[0..3].copy_from_slice(f.as_slice());
        out[3..6].copy_from_slice((-f).as_slice());
    }

    /// The dashpot matrix `c [[u u^T, -u u^T], [-u u^T, u u^T]]` plus `beta` times the
    /// (projected) spring Hessian, written block-major to `out[0..36]`.
    #[inline]
    pub fn damping_matrix(&self, xi: &Vector3<f64>, xj: &Vector3<f64>, beta: f64, out: &mut [f64]) {
        if beta != 0.0 {
            self.hessian(xi, xj, true, out);
            out.iter_mut().for_each(|x| *x *= beta);
        } else {
            out.fill(0.0);
        }
        let d = xi - xj;
        let l = d.norm();
        if l > 0.0 && self.damping != 0.0 {
            let u = d / l;
            let block = u * u.transpose() * self.damping;
            for (a, b) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let sign = if a == b { 1.0 } else { -1.0 };
                let o = crate::fem::block_offset(2, a, b);
                for (dst, src) in out[o..o + 9].iter_mut().zip(block.iter()) {
                    *dst += sign * src;
                }
            }
        }
    }
}
