//! The trust-region subproblem `min_p g·p + 1/2 p·H p` subject to `‖p‖_D <= radius`, solved
//! by Steihaug's truncated conjugate gradients (Nocedal & Wright, Algorithm 7.2, with the
//! preconditioner `D`): CG from `p = 0` that stops at the boundary, at a direction of
//! negative curvature (followed to the boundary), or when the residual meets the forcing
//! tolerance. `D` is the lumped mass diagonal, so the radius is a mass-weighted displacement
//! that means the same on any mesh resolution. `H` is only multiplied, never factored: an
//! indefinite `H` is handled by the subproblem, not by a filter.

use crate::sparse::SymmetricMatrix;

/// How a subproblem ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SubproblemEnd {
    /// The CG residual met the forcing tolerance inside the region.
    Interior,
    /// The step reached the boundary.
    Boundary,
    /// A direction of negative (or zero) curvature, followed to the boundary.
    NegativeCurvature,
    /// The iteration cap: the last iterate.
    Capped,
}

/// Steihaug-CG's vectors, sized once per problem size.
#[derive(Default)]
pub struct Steihaug {
    r: Vec<f64>,
    y: Vec<f64>,
    d: Vec<f64>,
    hd: Vec<f64>,
}

/// One solved subproblem.
pub struct Subproblem {
    /// CG iterations (matrix products).
    pub iterations: u32,
    pub end: SubproblemEnd,
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `‖v‖_D² = Σ D_i v_i²`.
pub fn norm_d_squared(diag: &[f64], v: &[f64]) -> f64 {
    diag.iter().zip(v).map(|(d, x)| d * x * x).sum()
}

/// The `tau >= 0` with `‖p + tau d‖_D = radius` (for `‖p‖_D <= radius`).
fn to_boundary(diag: &[f64], p: &[f64], d: &[f64], radius: f64) -> f64 {
    let (mut dd, mut pd, mut pp) = (0.0, 0.0, 0.0);
    for ((w, pi), di) in diag.iter().zip(p).zip(d) {
        dd += w * di * di;
        pd += w * pi * di;
        pp += w * pi * pi;
    }
    if dd <= 0.0 {
        return 0.0;
    }
    let c = (pp - radius * radius).min(0.0);
    let disc = (pd * pd - dd * c).max(0.0);
    (-pd + disc.sqrt()) / dd
}

impl Steihaug {
    /// Solve the subproblem for gradient `g`, matrix `h` and metric `diag` into `p`, to the
    /// residual `forcing * ‖g‖` or at most `max_iterations` CG iterations.
    #[allow(clippy::too_many_arguments)]
    pub fn solve(
        &mut self,
        h: &SymmetricMatrix,
        g: &[f64],
        diag: &[f64],
        radius: f64,
        forcing: f64,
        max_iterations: u32,
        p: &mut [f64],
    ) -> Subproblem {
        let n = g.len();
        for v in [&mut self.r, &mut self.y, &mut self.d, &mut self.hd] {
            v.resize(n, 0.0);
        }
        p.fill(0.0);
        self.r.copy_from_slice(g);
        let target = forcing * dot(g, g).sqrt();
        for ((y, r), w) in self.y.iter_mut().zip(&self.r).zip(diag) {
            *y = r / w;
        }
        for (d, y) in self.d.iter_mut().zip(&self.y) {
            *d = -y;
        }
        let mut ry = dot(&self.r, &self.y);
        let mut iterations = 0;
        while iterations < max_iterations {
            iterations += 1;
            h.mul_vec(&self.d, &mut self.hd);
            let curvature = dot(&self.d, &self.hd);
            if curvature.is_nan() || curvature <= 0.0 {
                let tau = to_boundary(diag, p, &self.d, radius);
                p.iter_mut().zip(&self.d).for_each(|(x, d)| *x += tau * d);
                return Subproblem {
                    iterations,
                    end: SubproblemEnd::NegativeCurvature,
                };
            }
            let alpha = ry / curvature;
            // Would the next iterate leave the region?
            let mut next = 0.0;
            for ((w, pi), di) in diag.iter().zip(p.iter()).zip(&self.d) {
                let x = pi + alpha * di;
                next += w * x * x;
            }
            if next >= radius * radius {
                let tau = to_boundary(diag, p, &self.d, radius);
                p.iter_mut().zip(&self.d).for_each(|(x, d)| *x += tau * d);
                return Subproblem {
                    iterations,
                    end: SubproblemEnd::Boundary,
                };
            }
            p.iter_mut().zip(&self.d).for_each(|(x, d)| *x += alpha * d);
            self.r
                .iter_mut()
                .zip(&self.hd)
                .for_each(|(r, hd)| *r += alpha * hd);
            if dot(&self.r, &self.r).sqrt() <= target {
                return Subproblem {
                    iterations,
                    end: SubproblemEnd::Interior,
                };
            }
            for ((y, r), w) in self.y.iter_mut().zip(&self.r).zip(diag) {
                *y = r / w;
            }
            let ry_next = dot(&self.r, &self.y);
            let beta = ry_next / ry;
            ry = ry_next;
            for (d, y) in self.d.iter_mut().zip(&self.y) {
                *d = -y + beta * *d;
            }
        }
        Subproblem {
            iterations,
            end: SubproblemEnd::Capped,
        }
    }
}

/// The model's value at `p`: `g·p + 1/2 p·H p` (`hp` is scratch).
pub fn model_value(h: &SymmetricMatrix, g: &[f64], p: &[f64], hp: &mut [f64]) -> f64 {
    h.mul_vec(p, hp);
    dot(g, p) + 0.5 * dot(p, hp)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sparse::SparsityPattern;
    use std::sync::Arc;

    /// A dense symmetric matrix as a `SymmetricMatrix`.
    fn matrix(a: &[&[f64]]) -> SymmetricMatrix {
        let n = a.len();
        let mut col_ptr = vec![0];
        let mut rows = Vec::new();
        let mut values = Vec::new();
        for j in 0..n {
            for (i, row) in a.iter().enumerate() {
                rows.push(i);
                values.push(row[j]);
            }
            col_ptr.push(rows.len());
        }
        let pattern = Arc::new(SparsityPattern::from_csc(n, col_ptr, rows));
        let mut m = SymmetricMatrix::zeros(pattern);
        m.values_mut().copy_from_slice(&values);
        m
    }

    #[test]
    fn an_interior_solution_is_the_newton_step() {
        let h = matrix(&[&[4.0, 1.0], &[1.0, 3.0]]);
        let g = [1.0, 2.0];
        let mut p = [0.0; 2];
        let s = Steihaug::default().solve(&h, &g, &[1.0, 1.0], 10.0, 1e-12, 50, &mut p);
        assert_eq!(s.end, SubproblemEnd::Interior);
        // H p = -g: p = -(1/11) [3 -1; -1 4] g = (-1/11, -7/11).
        assert!((p[0] + 1.0 / 11.0).abs() < 1e-12 && (p[1] + 7.0 / 11.0).abs() < 1e-12);
    }

    #[test]
    fn a_small_region_stops_on_its_boundary_and_negative_curvature_goes_to_it() {
        let h = matrix(&[&[4.0, 1.0], &[1.0, 3.0]]);
        let g = [1.0, 2.0];
        let diag = [2.0, 0.5];
        let mut p = [0.0; 2];
        let s = Steihaug::default().solve(&h, &g, &diag, 0.1, 1e-12, 50, &mut p);
        assert_eq!(s.end, SubproblemEnd::Boundary);
        assert!((norm_d_squared(&diag, &p).sqrt() - 0.1).abs() < 1e-12);
        let mut hp = [0.0; 2];
        assert!(model_value(&h, &g, &p, &mut hp) < 0.0);
        // The first CG direction, -D^-1 g = (-0.5, 0), has curvature -0.25 here.
        let indefinite = matrix(&[&[-1.0, 0.0], &[0.0, 2.0]]);
        let g = [1.0, 0.0];
        let s = Steihaug::default().solve(&indefinite, &g, &diag, 0.5, 1e-12, 50, &mut p);
        assert_eq!(s.end, SubproblemEnd::NegativeCurvature);
        assert!((norm_d_squared(&diag, &p).sqrt() - 0.5).abs() < 1e-12);
        assert!(model_value(&indefinite, &g, &p, &mut hp) < 0.0);
    }
}
