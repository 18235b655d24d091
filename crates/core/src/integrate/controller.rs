//! Step-size controllers of adaptive stepping (`integrator.adaptive.controller`), as swappable
//! components: each is a row of one table with its gains, so adding one is one line.
//!
//! Every controller proposes the next step from the scaled error norms `e_n` of the last
//! accepted steps (`e <= 1` is accepted) as
//!
//! `h_(n+1) = h_n · safety · e_n^(-k1/k) · e_(n-1)^(k2/k) · e_(n-2)^(-k3/k)`,
//!
//! with `k` one more than the order of the error estimate (the local error is `O(h^k)`). The
//! elementary controller (`i`) has `k1 = 1`; the PI controller (Gustafsson) adds the previous
//! error, the PID controller (Söderlind) the one before; their default gains are SUNDIALS
//! ARKODE's (`SUNAdaptController_PI`: 0.8, 0.31; `SUNAdaptController_PID`: 0.58, 0.21, 0.1).
//! Until enough steps were accepted the missing errors count as 1 (no influence). After a
//! rejection the retry uses the elementary rule with the rejected error and never grows; the
//! next accepted step does not grow either (Hairer, Nørsett & Wanner, II.4). A controller's
//! memory is cleared when the integrator is reset.

crate::named_enum! {
    /// An adaptive step-size controller (`integrator.adaptive.controller`), with its default
    /// gains `[k1, k2, k3]`.
    pub enum Controller: "step-size controller", UnknownController, ControllerGains {
        /// The elementary (integral) controller, `h e^(-1/k)`.
        I = "i", "elementary: h e_n^(-1/k) (gains 1, 0, 0)", ControllerGains([1.0, 0.0, 0.0]),
        /// Gustafsson's PI controller with ARKODE's gains.
        Pi = "pi", "PI (Gustafsson): e_n^(-k1/k) e_(n-1)^(k2/k) (gains 0.8, 0.31; ARKODE)", ControllerGains([0.8, 0.31, 0.0]),
        /// Söderlind's PID controller with ARKODE's gains.
        Pid = "pid", "PID (Söderlind): also e_(n-2)^(-k3/k) (gains 0.58, 0.21, 0.1; ARKODE)", ControllerGains([0.58, 0.21, 0.1]),
    }
}

/// A controller's default gains `[k1, k2, k3]` (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControllerGains(pub [f64; 3]);

impl crate::registry::ListFacts for ControllerGains {
    fn list(&self) -> Vec<crate::registry::Fact> {
        let [k1, k2, k3] = self.0;
        vec![
            ("k1", k1.to_string()),
            ("k2", k2.to_string()),
            ("k3", k3.to_string()),
        ]
    }
}

/// A controller's state over a run: its gains and the errors of the last accepted steps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepController {
    gains: [f64; 3],
    /// `e_(n-1)` and `e_(n-2)` (1 until known).
    previous: [f64; 2],
    /// The last attempt was rejected: the next accepted step may not grow.
    after_rejection: bool,
}

/// Errors are floored here before their powers are taken (an exact step proposes the largest
/// growth, not an infinite one).
const ERROR_FLOOR: f64 = 1e-10;

impl StepController {
    /// A controller with `gains` (`[k1, k2, k3]`).
    pub fn new(gains: [f64; 3]) -> Self {
        Self {
            gains,
            previous: [1.0, 1.0],
            after_rejection: false,
        }
    }

    /// The gains.
    pub fn gains(&self) -> [f64; 3] {
        self.gains
    }

    /// Forget the error history.
    pub fn reset(&mut self) {
        self.previous = [1.0, 1.0];
        self.after_rejection = false;
    }

    /// The factor `h_new / h` (before the safety factor and the clamps) after an accepted
    /// step with scaled error `error` and error order `k`; records the error.
    pub fn accepted(&mut self, error: f64, k: f64) -> f64 {
        let e = error.max(ERROR_FLOOR);
        let [k1, k2, k3] = self.gains;
        let [e1, e2] = self.previous;
        let factor = e.powf(-k1 / k) * e1.powf(k2 / k) * e2.powf(-k3 / k);
        self.previous = [e, e1];
        if std::mem::take(&mut self.after_rejection) {
            factor.min(1.0)
        } else {
            factor
        }
    }

    /// The factor for the retry after a step rejected with scaled error `error` (> 1): the
    /// elementary rule, never above 1.
    pub fn rejected(&mut self, error: f64, k: f64) -> f64 {
        self.after_rejection = true;
        error.max(ERROR_FLOOR).powf(-1.0 / k).min(1.0)
    }

    /// Note a failed attempt (Newton failure, inverted element): the next accepted step may
    /// not grow.
    pub fn failed(&mut self) {
        self.after_rejection = true;
    }
}
