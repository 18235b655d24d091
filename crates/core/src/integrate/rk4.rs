//! The classic fourth-order Runge–Kutta method.

use super::runge_kutta::{ExplicitRungeKutta, Tableau};

/// The classic RK4 tableau.
pub const TABLEAU: Tableau = Tableau {
    name: "rk4",
    order: 4,
    a: &[&[], &[0.5], &[0.0, 0.5], &[0.0, 0.0, 1.0]],
    b: &[1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0],
    b_embedded: None,
};

/// A classic RK4 integrator.
pub fn rk4() -> ExplicitRungeKutta {
    ExplicitRungeKutta::new(TABLEAU)
}
