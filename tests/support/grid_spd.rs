//! Synthetic elasticity-like SPD systems for solver tests and benches: on an `nx × ny × nz`
//! grid graph with 3 DOFs per vertex, `A = Σ_edges [C −C; −C C] + mass·I` (the graph
//! Laplacian ⊗ I₃ plus an SPD 3×3 coupling per edge, plus a mass-like diagonal). Each edge's
//! `C = s (I₃ + (T_u + T_v)/2 + R diag(ξ) Rᵀ)` mixes its vertices' anisotropic material tensors
//! `T` (orientation varying smoothly over the grid), a random SPD part, and a stiffness scale
//! `s` graded along x. Seeded, so reproducible.

#![allow(dead_code)]

use std::sync::Arc;

use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};
use softbench::rng::Rng;
use softbench::sparse::{SparsityPattern, SymmetricMatrix};

/// A grid graph and its 6-neighbour edges.
pub struct Grid {
    pub nx: usize,
    pub ny: usize,
    pub nz: usize,
}

impl Grid {
    pub fn new(nx: usize, ny: usize, nz: usize) -> Self {
        Self { nx, ny, nz }
    }

    pub fn vertices(&self) -> usize {
        self.nx * self.ny * self.nz
    }

    pub fn dofs(&self) -> usize {
        3 * self.vertices()
    }

    fn id(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.nx * (j + self.ny * k)
    }

    /// Edges `(u, v)` with `u < v`.
    pub fn edges(&self) -> Vec<(usize, usize)> {
        let mut e = Vec::new();
        for k in 0..self.nz {
            for j in 0..self.ny {
                for i in 0..self.nx {
                    let u = self.id(i, j, k);
                    if i + 1 < self.nx {
                        e.push((u, self.id(i + 1, j, k)));
                    }
                    if j + 1 < self.ny {
                        e.push((u, self.id(i, j + 1, k)));
                    }
                    if k + 1 < self.nz {
                        e.push((u, self.id(i, j, k + 1)));
                    }
                }
            }
        }
        e
    }

    /// Both triangles, full 3×3 blocks between a vertex, itself and its neighbours.
    pub fn pattern(&self) -> Arc<SparsityPattern> {
        let nv = self.vertices();
        let mut nbrs: Vec<Vec<usize>> = (0..nv).map(|v| vec![v]).collect();
        for (u, v) in self.edges() {
            nbrs[u].push(v);
            nbrs[v].push(u);
        }
        let mut col_ptr = vec![0];
        let mut row_idx = Vec::new();
        for list in nbrs.iter_mut() {
            list.sort_unstable();
            for _ in 0..3 {
                for &u in list.iter() {
                    row_idx.extend([3 * u, 3 * u + 1, 3 * u + 2]);
                }
                col_ptr.push(row_idx.len());
            }
        }
        Arc::new(SparsityPattern::from_csc(3 * nv, col_ptr, row_idx))
    }

    /// The SPD matrix described in the module docs, over `pattern` (from [`Grid::pattern`]).
    pub fn matrix(
        &self,
        pattern: &Arc<SparsityPattern>,
        seed: u64,
        spec: &Spec,
    ) -> SymmetricMatrix {
        let mut rng = Rng::new(seed);
        let random_rotation = |rng: &mut Rng| {
            let q = Quaternion::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            UnitQuaternion::from_quaternion(q)
                .to_rotation_matrix()
                .into_inner()
        };
        // Per vertex: a stiffness scale and an anisotropic material tensor, both varying
        // smoothly over the grid (plus a little noise), as in a graded, fibred material.
        let mut scale = Vec::with_capacity(self.vertices());
        let mut tensor = Vec::with_capacity(self.vertices());
        let frac = |i: usize, n: usize| {
            if n > 1 {
                i as f64 / (n - 1) as f64
            } else {
                0.0
            }
        };
        for k in 0..self.nz {
            for j in 0..self.ny {
                for i in 0..self.nx {
                    let t = Vector3::new(frac(i, self.nx), frac(j, self.ny), frac(k, self.nz));
                    let omega = std::f64::consts::PI
                        * Vector3::new(t.x, 0.7 * t.y + 0.3 * t.z, t.z)
                        + 0.1
                            * Vector3::new(
                                rng.range(-1.0, 1.0),
                                rng.range(-1.0, 1.0),
                                rng.range(-1.0, 1.0),
                            );
                    let r = Rotation3::new(omega).into_inner();
                    let lambda =
                        Vector3::new(1.0, rng.range(1.0, spec.anisotropy), spec.anisotropy);
                    scale.push(spec.contrast.powf(t.x));
                    tensor.push(r * Matrix3::from_diagonal(&lambda) * r.transpose());
                }
            }
        }
        let mut a = SymmetricMatrix::zeros(pattern.clone());
        for v in 0..self.vertices() {
            add_block(&mut a, v, v, &(spec.mass * Matrix3::identity()));
        }
        for (u, v) in self.edges() {
            let s = (scale[u] * scale[v]).sqrt();
            let r = random_rotation(&mut rng);
            let noise =
                Matrix3::from_diagonal(&Vector3::new(rng.uniform(), rng.uniform(), rng.uniform()));
            let c = s
                * (Matrix3::identity() + 0.5 * (tensor[u] + tensor[v]) + r * noise * r.transpose());
            add_block(&mut a, u, u, &c);
            add_block(&mut a, v, v, &c);
            add_block(&mut a, u, v, &(-c));
            add_block(&mut a, v, u, &(-c));
        }
        a
    }
}

/// Parameters of [`Grid::matrix`].
#[derive(Clone, Copy, Debug)]
pub struct Spec {
    /// Added to every diagonal entry (the mass term; keeps `A` SPD).
    pub mass: f64,
    /// Ratio of the largest to the smallest eigenvalue of a vertex's material tensor.
    pub anisotropy: f64,
    /// Ratio of the stiffness at `x = max` to that at `x = 0` (graded exponentially).
    pub contrast: f64,
}

impl Default for Spec {
    fn default() -> Self {
        Self {
            mass: 1.0,
            anisotropy: 50.0,
            contrast: 100.0,
        }
    }
}

/// `A[3u.., 3v..] += block`.
pub fn add_block(a: &mut SymmetricMatrix, u: usize, v: usize, block: &Matrix3<f64>) {
    for j in 0..3 {
        for i in 0..3 {
            let k = a
                .pattern()
                .find(3 * u + i, 3 * v + j)
                .expect("block in pattern");
            a.values_mut()[k] += block[(i, j)];
        }
    }
}

/// `A[i, i] += d`.
pub fn add_diagonal(a: &mut SymmetricMatrix, i: usize, d: f64) {
    let k = a.pattern().find(i, i).expect("diagonal in pattern");
    a.values_mut()[k] += d;
}

/// A reproducible right-hand side with entries in [-1, 1).
pub fn rhs(n: usize, seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed);
    (0..n).map(|_| rng.range(-1.0, 1.0)).collect()
}

/// `‖b − A x‖ / ‖b‖` computed independently of the solvers (with `SymmetricMatrix::mul_vec`).
pub fn relative_residual(a: &SymmetricMatrix, x: &[f64], b: &[f64]) -> f64 {
    let mut ax = vec![0.0; b.len()];
    a.mul_vec(x, &mut ax);
    let r: f64 = b
        .iter()
        .zip(&ax)
        .map(|(b, a)| (b - a) * (b - a))
        .sum::<f64>()
        .sqrt();
    r / b.iter().map(|b| b * b).sum::<f64>().sqrt()
}
