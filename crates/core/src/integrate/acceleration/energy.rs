//! The backward Euler incremental potential the local solvers minimize, read-only on the model:
//!
//! `E(x) = 1/2 (x − x̂)ᵀ M (x − x̂) + dt² V(x) + dt/2 (x − q)ᵀ D (x − q)`,
//!
//! `V` the elastic, spring, gravity and vertex potentials (at the model's time). Anderson's
//! safeguard compares it between iterates. The elastic sum runs over chunks of tets in
//! parallel and adds the chunks' partial sums in order, so the value is the same for any
//! thread count; the scratch is sized once.

use crate::integrate::StepError;
use crate::model::Model;
use crate::parallel::for_each_chunk;
use crate::sparse::SymmetricMatrix;
use nalgebra::Vector3;

/// Tets per partial sum.
const CHUNK: usize = 512;

/// Scratch of [`IncrementalPotential::value`], sized on first use.
#[derive(Debug, Default)]
pub struct PotentialScratch {
    positions: Vec<Vector3<f64>>,
    difference: Vec<f64>,
    product: Vec<f64>,
    partial: Vec<f64>,
}

/// `E` of one step: what it depends on besides `x`.
pub struct IncrementalPotential<'a> {
    /// The model (its time set to the step's end).
    pub model: &'a Model,
    /// `x̂ = q + dt v` and `q` over the free DOFs.
    pub x_hat: &'a [f64],
    pub q: &'a [f64],
    /// `D` at `x̂`, if the model has damping.
    pub damping: Option<&'a SymmetricMatrix>,
    pub dt: f64,
}

impl IncrementalPotential<'_> {
    /// `E` at the free DOFs `x` (J).
    pub fn value(&self, x: &[f64], s: &mut PotentialScratch) -> Result<f64, StepError> {
        let model = self.model;
        let n = x.len();
        if s.positions.len() != model.dofs().num_vertices() {
            s.positions = model.full_positions(x);
        } else {
            model.dofs().scatter(x, &mut s.positions);
        }
        s.difference.resize(n, 0.0);
        s.product.resize(n, 0.0);
        for ((d, a), b) in s.difference.iter_mut().zip(x).zip(self.x_hat) {
            *d = a - b;
        }
        model.mass().mul_vec(&s.difference, &mut s.product);
        let inertia = 0.5 * dot(&s.difference, &s.product);
        let damping = match self.damping {
            Some(d) => {
                for ((y, a), b) in s.difference.iter_mut().zip(x).zip(self.q) {
                    *y = a - b;
                }
                d.mul_vec(&s.difference, &mut s.product);
                0.5 * self.dt * dot(&s.difference, &s.product)
            }
            None => 0.0,
        };
        let xs = &s.positions;
        let elastic = match model.elastic_elements() {
            Some(e) => {
                let (material, tets, rest) = (e.material, e.tets, e.rest);
                s.partial.resize(tets.len().div_ceil(CHUNK), 0.0);
                for_each_chunk(model.parallelism(), &mut s.partial, 1, |ci, out| {
                    let mut sum = 0.0;
                    for k in ci * CHUNK..((ci + 1) * CHUNK).min(tets.len()) {
                        let t = &tets[k];
                        let f =
                            rest[k].deformation_gradient(&[xs[t[0]], xs[t[1]], xs[t[2]], xs[t[3]]]);
                        let psi = material.energy_density(&f).map_err(|err| {
                            StepError::InvertedElement {
                                tet: k,
                                det_f: err.det_f,
                                material: material.name(),
                            }
                        })?;
                        sum += rest[k].volume * psi;
                    }
                    out[0] = sum;
                    Ok::<(), StepError>(())
                })?;
                s.partial.iter().sum()
            }
            None => 0.0,
        };
        let springs: f64 = model
            .springs()
            .iter()
            .map(|sp| sp.energy(&xs[sp.i], &xs[sp.j]))
            .sum();
        let gravity = model.gravity().map_or(0.0, |g| {
            -xs.iter()
                .zip(model.vertex_masses())
                .map(|(p, m)| m * g.dot(p))
                .sum::<f64>()
        });
        let vertex: f64 = model
            .vertex_potentials()
            .iter()
            .map(|p| p.energy(model.time(), xs))
            .sum();
        let dt2 = self.dt * self.dt;
        Ok(inertia + damping + dt2 * (elastic + springs + gravity + vertex))
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
