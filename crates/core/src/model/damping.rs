//! Damping: forces linear in the velocity, `f = -D(q) v`, with `D` symmetric positive
//! semi-definite so that damping only removes energy.
//!
//! - Rayleigh: `D = alpha M + beta K(q)`, with element Hessians projected to PSD in K (an
//!   indefinite K would pump energy in under compression).
//! - Strain rate (the Brown course; O'Brien & Hodgins): viscous second Piola–Kirchhoff stress
//!   `S_v = phi tr(Edot) I + 2 psi Edot` on the Green strain rate `Edot = sym(F^T Fdot)`, i.e. the
//!   dissipation potential `R = vol (phi/2 tr(Edot)^2 + psi |Edot|^2)`; its first Piola–Kirchhoff
//!   stress `F S_v` enters the element like an elastic stress, and its 9×9 derivative with
//!   respect to `Fdot` like dP/dF. It vanishes for rigid motions.
//! - Springs: a dashpot `c` along each spring (`Spring::damping`).

use super::{HessianOptions, Model, ModelError};
use crate::material::Matrix9;
use crate::sparse::SymmetricMatrix;
use nalgebra::{Matrix3, Vector3};
use std::sync::Arc;

/// Which damping a model applies (all off by default).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Damping {
    /// Rayleigh `(alpha, beta)`: `D = alpha M + beta K`.
    pub rayleigh: Option<(f64, f64)>,
    /// Strain-rate viscosity `(phi, psi)` (Pa s).
    pub strain_rate: Option<(f64, f64)>,
}

impl Damping {
    /// Whether any tet-based damping is on (spring dashpots are per spring).
    pub fn is_on(&self) -> bool {
        self.rayleigh.is_some() || self.strain_rate.is_some()
    }
}

/// The viscous first Piola–Kirchhoff stress `F S_v` at deformation gradient `f` and its rate
/// `fdot`.
#[inline]
pub(crate) fn viscous_stress(
    phi: f64,
    psi: f64,
    f: &Matrix3<f64>,
    fdot: &Matrix3<f64>,
) -> Matrix3<f64> {
    let ftf = f.transpose() * fdot;
    let edot = (ftf + ftf.transpose()) * 0.5;
    let s = Matrix3::identity() * (phi * edot.trace()) + edot * (2.0 * psi);
    f * s
}

/// `d(F S_v)/d(Fdot)` as a 9×9 matrix over column-major `vec(Fdot)` (independent of `Fdot`,
/// symmetric positive semi-definite).
#[inline]
pub(crate) fn viscous_stress_derivative(phi: f64, psi: f64, f: &Matrix3<f64>) -> Matrix9 {
    let mut d = Matrix9::zeros();
    for k in 0..9 {
        let mut e = Matrix3::zeros();
        e[(k % 3, k / 3)] = 1.0;
        let column = viscous_stress(phi, psi, f, &e);
        d.column_mut(k).copy_from_slice(column.as_slice());
    }
    d
}

impl Model {
    /// Whether any damping acts (Rayleigh, strain rate, or a spring dashpot).
    pub fn has_damping(&self) -> bool {
        self.damping.is_on() || self.springs.iter().any(|s| s.damping > 0.0)
    }

    /// The damping settings.
    pub fn damping(&self) -> Damping {
        self.damping
    }

    /// An energy (J) whose round-off is the round-off of the potential: the elastic stiffness
    /// times the volume plus `k L^2` of the springs — the sizes of the terms that cancel when
    /// the energy is small. Newton uses it to tell a real decrease from noise.
    pub fn energy_roundoff_scale(&self) -> f64 {
        self.energy_roundoff_scale
    }

    fn load_velocities(&mut self, v: &[f64]) {
        self.velocities
            .iter_mut()
            .for_each(|x| *x = Vector3::zeros());
        self.dofs.scatter(v, &mut self.velocities);
    }

    /// `f = D(q) v` over free DOFs (the damping force is `-f`); zero without damping.
    /// Strain-rate and spring dashpots are evaluated element by element; Rayleigh's
    /// `beta K(q) v` assembles the projected stiffness matrix (as costly as a Hessian).
    pub fn damping_force(&mut self, q: &[f64], v: &[f64], f: &mut [f64]) -> Result<(), ModelError> {
        self.timed_force(|m| m.damping_force_untimed(q, v, f))
    }

    fn damping_force_untimed(
        &mut self,
        q: &[f64],
        v: &[f64],
        f: &mut [f64],
    ) -> Result<(), ModelError> {
        self.load_state(q)?;
        self.load_velocities(v);
        let par = self.parallelism;
        let b = &mut self.buffers;
        b.tet_vectors
            .resize(12 * self.elastic.as_ref().map_or(0, |e| e.tets.len()), 0.0);
        match (&self.elastic, self.damping.strain_rate) {
            (Some(body), Some(viscosity)) => body.viscous_forces(
                par,
                viscosity,
                &self.positions,
                &self.velocities,
                &mut b.tet_vectors,
            ),
            _ => b.tet_vectors.fill(0.0),
        }
        b.spring_vectors.resize(6 * self.springs.len(), 0.0);
        let (x, vel) = (&self.positions, &self.velocities);
        for (s, out) in self
            .springs
            .iter()
            .zip(b.spring_vectors.chunks_exact_mut(6))
        {
            s.damping_force(&x[s.i], &x[s.j], &vel[s.i], &vel[s.j], out);
        }
        self.gather_element_vectors(f);
        if let Some((alpha, beta)) = self.damping.rayleigh {
            let n = f.len();
            let mut extra = std::mem::take(&mut self.buffers.partial);
            extra.resize(n, 0.0);
            if alpha != 0.0 {
                self.mass.mul_vec(v, &mut extra);
                f.iter_mut()
                    .zip(&extra)
                    .for_each(|(fi, e)| *fi += alpha * e);
            }
            if beta != 0.0 {
                let mut k = self
                    .stiffness_scratch
                    .take()
                    .unwrap_or_else(|| self.new_hessian());
                let result = self.hessian(q, &mut k, HessianOptions::projected());
                if result.is_ok() {
                    k.mul_vec(v, &mut extra);
                    f.iter_mut().zip(&extra).for_each(|(fi, e)| *fi += beta * e);
                }
                self.stiffness_scratch = Some(k);
                result?;
            }
            self.buffers.partial = extra;
        }
        Ok(())
    }

    /// The damping matrix `D(q)` over the Hessian pattern: Rayleigh `alpha M + beta K(q)`
    /// (projected), the strain-rate viscous matrices and the spring dashpots.
    pub fn damping_matrix(&mut self, q: &[f64], d: &mut SymmetricMatrix) -> Result<(), ModelError> {
        self.load_state(q)?;
        assert!(
            Arc::ptr_eq(d.pattern(), self.pattern.scalar()),
            "the damping matrix must be created by Model::new_hessian"
        );
        let par = self.parallelism;
        let (alpha, beta) = self.damping.rayleigh.unwrap_or((0.0, 0.0));
        let b = &mut self.buffers;
        if let Some(body) = &self.elastic {
            b.tet_matrices.resize(144 * body.tets.len(), 0.0);
            let res = body.damping_matrices(
                par,
                &self.positions,
                beta,
                self.damping.strain_rate,
                &mut b.tet_matrices,
            );
            if let Err(f) = res {
                return Err(self.element_error(f));
            }
        }
        b.spring_matrices.resize(36 * self.springs.len(), 0.0);
        for (s, out) in self
            .springs
            .iter()
            .zip(b.spring_matrices.chunks_exact_mut(36))
        {
            s.damping_matrix(&self.positions[s.i], &self.positions[s.j], beta, out);
        }
        self.gather_element_matrices(d.values_mut());
        if alpha != 0.0 {
            self.mass.add_scaled_to(alpha, d);
        }
        Ok(())
    }
}
