//! RODAS3 (Sandu, Verwer, Blom, Spee, Carmichael & Potra 1997): a four-stage Rosenbrock
//! method of order 3 with an embedded second-order solution, stiffly accurate and L-stable,
//! `γ = 1/2`; three force evaluations per step (the second stage reuses the first's).

use super::rosenbrock::RosenbrockTableau;

/// The RODAS3 coefficients in the transformed form (as KPP's `Rodas3`).
pub const TABLEAU: RosenbrockTableau = RosenbrockTableau {
    name: "rodas3",
    order: 3,
    embedded_order: 2,
    gamma: 0.5,
    a: &[&[], &[0.0], &[2.0, 0.0], &[2.0, 0.0, 1.0]],
    c: &[&[], &[4.0], &[1.0, -1.0], &[1.0, -1.0, -8.0 / 3.0]],
    m: &[2.0, 0.0, 1.0, 1.0],
    e: &[0.0, 0.0, 0.0, 1.0],
    alpha: &[0.0, 0.0, 1.0, 1.0],
    gamma_sum: &[0.5, 1.5, 0.0, 0.0],
};
