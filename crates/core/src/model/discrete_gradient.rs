//! The discrete gradient of the potential between two states: `ḡ(q₀, q₁)` with
//! `ḡ · (q₁ − q₀) = V(q₁) − V(q₀)` to round-off, which an energy–momentum scheme
//! ([`crate::integrate::energy_momentum`]) uses in place of the gradient.
//!
//! - Tets: Gonzalez's algorithmic stress (*J. Nonlinear Sci.* 1996; *CMAME* 2000). With
//!   `C = FᵀF` and `W(C)` the energy density, `F_m = (F₀ + F₁)/2`, `C_m = (C₀ + C₁)/2` and
//!   `ΔC = C₁ − C₀`, the element force uses `P = F_m S̄` with
//!   `S̄ = 2 W'(C_m) + 2 [W(C₁) − W(C₀) − W'(C_m) : ΔC] ΔC / |ΔC|²`. Since
//!   `P : ΔF = S̄ : ΔC / 2 = W(C₁) − W(C₀)` the energy is exact; since `S̄` is symmetric and
//!   `F_m` is the midpoint's deformation gradient, the forces have no net force or moment
//!   about the midpoint positions, so the implicit midpoint rule built on them conserves
//!   linear and angular momentum. `2 W'(C_m) = F̂⁻¹ P(F̂)` with `F̂ = C_m^(1/2)` (any material
//!   that depends on `F` only through `C` for `det F > 0`, which every one here does; an
//!   inverted element is refused). The correction's numerator
//!   `N = W(C₁) − W(C₀) − W'(C_m) : ΔC` is `O(|ΔC|³)`: as a difference of energies its
//!   round-off, divided by `|ΔC|`, would make the forces noisy for small changes (Newton then
//!   stalls above its tolerance), so below `|ΔC| = 1e-3 |C_m|` it comes from Simpson's rule on
//!   the segment `C₀ → C₁`, `N ≈ (S₀ − 2 S_m + S₁) : ΔC / 12` (error `O(|ΔC|⁵)`, below `1e-15`
//!   of the energy density's scale there).
//! - Springs: the same construction on `s = |x_i − x_j|²`: the force along the midpoint's
//!   spring `2 (E(s₁) − E(s₀))/(s₁ − s₀) d_m` (for `|Δs| < 1e-3 s_m`, Simpson's rule on
//!   `dE/ds` in place of the quotient).
//! - Gravity is linear: its gradient is exact.
//! - Vertex potentials (anchors, drags) depend on time: their gradient at the midpoint
//!   positions (second order, not exactly conservative — they do work on the body anyway).

use super::elastic::{CHUNK, ElasticBody, ElementFailure, GRADIENT_MIN_CHUNKS};
use super::{Model, ModelError};
use crate::material::{InvalidDeformation, Material, with_material};
use crate::parallel::{Parallelism, for_each_chunk_from};
use nalgebra::{Matrix3, SymmetricEigen, Vector3};

/// Below this relative size of `ΔC` the correction's numerator comes from Simpson's rule on
/// stresses instead of a difference of energies (whose round-off grows like `1/|ΔC|`).
const SIMPSON_BELOW: f64 = 1e-3;

/// `dE/ds` of a spring at squared length `s`: `k (√s − L) / (2 √s)` (`k/2` for `L = 0`; 0 at
/// `s = 0`, where the direction is undefined).
fn spring_slope(spring: &super::Spring, s: f64) -> f64 {
    if spring.rest_length == 0.0 {
        0.5 * spring.stiffness
    } else if s > 0.0 {
        0.5 * spring.stiffness * (s.sqrt() - spring.rest_length) / s.sqrt()
    } else {
        0.0
    }
}

/// `S = F⁻¹ P(F)`, symmetrized.
fn second_piola<M: Material>(
    material: &M,
    f: &Matrix3<f64>,
) -> Result<Matrix3<f64>, InvalidDeformation> {
    let p = material.first_piola(f)?;
    let inverse = f.try_inverse().ok_or(InvalidDeformation {
        det_f: f.determinant(),
    })?;
    let s = inverse * p;
    Ok((s + s.transpose()) * 0.5)
}

/// Gonzalez's algorithmic first Piola–Kirchhoff stress between `f0` and `f1` (see the
/// module docs): `P̄` with `P̄ : (F₁ − F₀) = ψ(F₁) − ψ(F₀)`, `P̄ = F_m S̄`, `S̄` symmetric.
pub fn algorithmic_stress<M: Material>(
    material: &M,
    f0: &Matrix3<f64>,
    f1: &Matrix3<f64>,
) -> Result<Matrix3<f64>, InvalidDeformation> {
    for f in [f0, f1] {
        let det_f = f.determinant();
        if det_f <= 0.0 || !det_f.is_finite() {
            return Err(InvalidDeformation { det_f });
        }
    }
    let fm = (f0 + f1) * 0.5;
    let (c0, c1) = (f0.transpose() * f0, f1.transpose() * f1);
    let cm = (c0 + c1) * 0.5;
    let dc = c1 - c0;
    // 2 W'(C_m) = F̂⁻¹ P(F̂) with F̂ the symmetric square root of C_m (positive definite).
    let eig = SymmetricEigen::new(cm);
    let roots = eig.eigenvalues.map(f64::sqrt);
    let v = eig.eigenvectors;
    let f_hat = v * Matrix3::from_diagonal(&roots) * v.transpose();
    let f_hat_inv = v * Matrix3::from_diagonal(&roots.map(|r| 1.0 / r)) * v.transpose();
    let p_hat = material.first_piola(&f_hat)?;
    let s = f_hat_inv * p_hat;
    let mut s = (s + s.transpose()) * 0.5;
    let dc2 = dc.norm_squared();
    if dc2 > 0.0 {
        // N = W(C₁) − W(C₀) − W'(C_m) : ΔC, which is O(|ΔC|³).
        let n = if dc2.sqrt() < SIMPSON_BELOW * cm.norm() {
            // Simpson's rule on the segment C₀ → C₁ (error O(|ΔC|⁵)), from stresses: no
            // cancellation of energies.
            let s0 = second_piola(material, f0)?;
            let s1 = second_piola(material, f1)?;
            (s0 - s * 2.0 + s1).dot(&dc) / 12.0
        } else {
            let (w0, w1) = (material.energy_density(f0)?, material.energy_density(f1)?);
            w1 - w0 - 0.5 * s.dot(&dc)
        };
        s += dc * (2.0 * n / dc2);
    }
    Ok(fm * s)
}

fn tet_discrete_gradients<M: Material>(
    m: &M,
    body: &ElasticBody,
    par: Parallelism,
    x0: &[Vector3<f64>],
    x1: &[Vector3<f64>],
    buf: &mut [f64],
) -> Result<(), ElementFailure> {
    for_each_chunk_from(par, buf, 12 * CHUNK, GRADIENT_MIN_CHUNKS, |ci, out| {
        for (k, g) in out.chunks_exact_mut(12).enumerate() {
            let e = ci * CHUNK + k;
            let rest = &body.rest[e];
            let t = &body.tets[e];
            let f0 = rest.deformation_gradient(&[x0[t[0]], x0[t[1]], x0[t[2]], x0[t[3]]]);
            let f1 = rest.deformation_gradient(&[x1[t[0]], x1[t[1]], x1[t[2]], x1[t[3]]]);
            let p = algorithmic_stress(m, &f0, &f1).map_err(|err| ElementFailure {
                tet: e,
                det_f: err.det_f,
            })?;
            rest.gradient_from_stress(&p, g);
        }
        Ok(())
    })
}

impl Model {
    /// The discrete gradient `ḡ(q0, q1)` into `g` (see the module docs): exact energy
    /// differences for tets, springs and gravity, vertex potentials at the midpoint and the
    /// model's time.
    pub fn discrete_gradient(
        &mut self,
        q0: &[f64],
        q1: &[f64],
        g: &mut [f64],
    ) -> Result<(), ModelError> {
        self.timed_force(|m| m.discrete_gradient_untimed(q0, q1, g))
    }

    fn discrete_gradient_untimed(
        &mut self,
        q0: &[f64],
        q1: &[f64],
        g: &mut [f64],
    ) -> Result<(), ModelError> {
        self.load_state(q0)?;
        let mut x0 = std::mem::take(&mut self.buffers.start_positions);
        x0.clone_from(&self.positions);
        let result = self.discrete_gradient_from(&x0, q1, g);
        self.buffers.start_positions = x0;
        result
    }

    fn discrete_gradient_from(
        &mut self,
        x0: &[Vector3<f64>],
        q1: &[f64],
        g: &mut [f64],
    ) -> Result<(), ModelError> {
        self.load_state(q1)?;
        assert_eq!(
            g.len(),
            self.num_dofs(),
            "gradient output has the wrong length"
        );
        self.counters.gradient += 1;
        let par = self.parallelism;
        let b = &mut self.buffers;
        if let Some(body) = &self.elastic {
            b.tet_vectors.resize(12 * body.tets.len(), 0.0);
            let res = with_material!(&body.material, |m| tet_discrete_gradients(
                m,
                body,
                par,
                x0,
                &self.positions,
                &mut b.tet_vectors
            ));
            if let Err(f) = res {
                return Err(self.element_error(f));
            }
        }
        b.spring_vectors.resize(6 * self.springs.len(), 0.0);
        let x1 = &self.positions;
        for (s, out) in self
            .springs
            .iter()
            .zip(b.spring_vectors.chunks_exact_mut(6))
        {
            let (d0, d1) = (x0[s.i] - x0[s.j], x1[s.i] - x1[s.j]);
            let (s0, s1) = (d0.norm_squared(), d1.norm_squared());
            let dm = (d0 + d1) * 0.5;
            let sm = 0.5 * (s0 + s1);
            // dE/ds: the difference quotient, or Simpson's rule on dE/ds for a small change
            // (the quotient's round-off grows like 1/|Δs|).
            let slope = if (s1 - s0).abs() >= SIMPSON_BELOW * sm {
                (s.energy(&x1[s.i], &x1[s.j]) - s.energy(&x0[s.i], &x0[s.j])) / (s1 - s0)
            } else {
                (spring_slope(s, s0) + 4.0 * spring_slope(s, sm) + spring_slope(s, s1)) / 6.0
            };
            let f = dm * (2.0 * slope);
            out[0..3].copy_from_slice(f.as_slice());
            out[3..6].copy_from_slice((-f).as_slice());
        }
        self.gather_element_vectors(g);
        // Gravity's gradient is constant; the vertex potentials' is taken at the midpoint.
        if !self.vertex_potentials.is_empty() {
            for (x, y) in self.positions.iter_mut().zip(x0) {
                *x = (*x + y) * 0.5;
            }
        }
        self.add_load_gradients(g);
        Ok(())
    }
}
