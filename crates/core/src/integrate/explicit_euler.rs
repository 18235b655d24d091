//! Explicit (forward) Euler: `q += dt v`, `v += dt a(q)`, both from the start of the step.
//! First order; unconditionally unstable for undamped oscillation, kept as the baseline.

use super::runge_kutta::{ExplicitRungeKutta, Tableau};

/// The one-stage tableau.
pub const TABLEAU: Tableau = Tableau {
    name: "explicit-euler",
    order: 1,
    a: &[&[]],
    b: &[1.0],
    b_embedded: None,
};

/// An explicit Euler integrator.
pub fn explicit_euler() -> ExplicitRungeKutta {
    ExplicitRungeKutta::new(TABLEAU)
}
