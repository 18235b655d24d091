//! Explicit midpoint (the seeds' RK2): a half step to the midpoint, derivatives there, and a
//! full step from the start with those derivatives. Second order.

use super::runge_kutta::{ExplicitRungeKutta, Tableau};

/// The two-stage midpoint tableau.
pub const TABLEAU: Tableau = Tableau {
    name: "midpoint",
    order: 2,
    a: &[&[], &[0.5]],
    b: &[0.0, 1.0],
    b_embedded: None,
};

/// An explicit midpoint integrator.
pub fn midpoint() -> ExplicitRungeKutta {
    ExplicitRungeKutta::new(TABLEAU)
}
