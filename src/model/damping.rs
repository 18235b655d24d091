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

use crate::material::Matrix9;
use nalgebra::Matrix3;

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
