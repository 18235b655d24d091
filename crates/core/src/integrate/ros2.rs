//! ROS2 (Verwer, Spee, Blom & Hundsdorfer 1999): a two-stage Rosenbrock-W method of order 2,
//! L-stable, with `γ = 1 + 1/√2`; order 2 with any approximation of the Jacobian (a
//! W-method). Its embedded solution is first order (linearly implicit Euler).

use super::rosenbrock::RosenbrockTableau;

/// `γ = 1 + 1/√2`.
const G: f64 = 1.707_106_781_186_547_5;

/// The ROS2 coefficients in the transformed form (as KPP's `Ros2`).
pub const TABLEAU: RosenbrockTableau = RosenbrockTableau {
    name: "ros2",
    order: 2,
    embedded_order: 1,
    gamma: G,
    a: &[&[], &[1.0 / G]],
    c: &[&[], &[-2.0 / G]],
    m: &[3.0 / (2.0 * G), 1.0 / (2.0 * G)],
    e: &[1.0 / (2.0 * G), 1.0 / (2.0 * G)],
    alpha: &[0.0, 1.0],
    gamma_sum: &[G, -G],
};
