//! Dormand–Prince 5(4): a fifth-order solution with an embedded fourth-order one whose
//! difference estimates the local error, for [`super::adaptive`] step control.

use super::runge_kutta::{ExplicitRungeKutta, Tableau};

/// The Dormand–Prince tableau (Hairer, Nørsett & Wanner, Table II.5.2).
pub const TABLEAU: Tableau = Tableau {
    name: "dopri5",
    order: 5,
    a: &[
        &[],
        &[1.0 / 5.0],
        &[3.0 / 40.0, 9.0 / 40.0],
        &[44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0],
        &[
            19372.0 / 6561.0,
            -25360.0 / 2187.0,
            64448.0 / 6561.0,
            -212.0 / 729.0,
        ],
        &[
            9017.0 / 3168.0,
            -355.0 / 33.0,
            46732.0 / 5247.0,
            49.0 / 176.0,
            -5103.0 / 18656.0,
        ],
        &[
            35.0 / 384.0,
            0.0,
            500.0 / 1113.0,
            125.0 / 192.0,
            -2187.0 / 6784.0,
            11.0 / 84.0,
        ],
    ],
    b: &[
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
        0.0,
    ],
    b_embedded: Some(&[
        5179.0 / 57600.0,
        0.0,
        7571.0 / 16695.0,
        393.0 / 640.0,
        -92097.0 / 339200.0,
        187.0 / 2100.0,
        1.0 / 40.0,
    ]),
};

/// The Dormand–Prince stages (run at a fixed step; wrap in [`super::Adaptive`] for control).
pub fn dopri5() -> ExplicitRungeKutta {
    ExplicitRungeKutta::new(TABLEAU)
}
