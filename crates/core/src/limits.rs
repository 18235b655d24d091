//! Size budgets, checked before anything large is allocated, so an absurd number in a scene,
//! study or mesh header is a clear error instead of an abort or a machine brought to a halt.
//!
//! Each budget has a default sized for a workstation and an environment variable that raises
//! (or lowers) it, named in the error:
//!
//! | budget        | default     | variable                 | counts                               |
//! |---------------|-------------|--------------------------|--------------------------------------|
//! | mesh size     | 20,000,000  | `SOFTBENCH_MAX_MESH`     | vertices + tets (+ springs) of a body |
//! | steps         | 100,000,000 | `SOFTBENCH_MAX_STEPS`    | `run.steps` of one run               |
//! | rows          | 10,000,000  | `SOFTBENCH_MAX_ROWS`     | sampled rows of one run              |
//! | study runs    | 10,000      | `SOFTBENCH_MAX_RUNS`     | runs in a study's grid               |
//! | iterations    | 1,000,000   | `SOFTBENCH_MAX_ITERATIONS` | iterations or substeps of one step |
//! | samples       | 10,000      | `SOFTBENCH_MAX_SAMPLES`  | error sample times of a study (each keeps a state) |
//!
//! [`STEPS`] bounds every run a command takes: a scene's `run.steps`, each run of a
//! work-precision study (`horizon / dt`), each trial of a stability study (`max_steps`) and
//! every reference solution (`horizon / reference dt`, twice for the half-step check).

/// One budget: a default and the environment variable that overrides it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Budget {
    /// What is counted, for messages ("mesh size (vertices + tets)").
    pub what: &'static str,
    /// The environment variable that sets the limit.
    pub variable: &'static str,
    /// The limit without the variable.
    pub default: u64,
}

/// Vertices plus tets (plus springs) of one body.
pub const MESH: Budget = Budget {
    what: "mesh size (vertices + tets + springs)",
    variable: "SOFTBENCH_MAX_MESH",
    default: 20_000_000,
};

/// Steps of one run.
pub const STEPS: Budget = Budget {
    what: "steps of a run",
    variable: "SOFTBENCH_MAX_STEPS",
    default: 100_000_000,
};

/// Sampled rows of one run (steps / sample_every).
pub const ROWS: Budget = Budget {
    what: "sampled rows of a run (steps / sample_every)",
    variable: "SOFTBENCH_MAX_ROWS",
    default: 10_000_000,
};

/// Runs in one study's grid.
pub const RUNS: Budget = Budget {
    what: "runs in the study's grid",
    variable: "SOFTBENCH_MAX_RUNS",
    default: 10_000,
};

/// Iterations or substeps of one step: `newton.max_iterations`, `vbd.iterations`,
/// `projective_dynamics.iterations`, `xpbd.substeps` × `xpbd.iterations`,
/// `adaptive.max_substeps`, `static.max_load_steps`, `solver.cg.max_iterations`.
pub const ITERATIONS: Budget = Budget {
    what: "iterations or substeps of one step",
    variable: "SOFTBENCH_MAX_ITERATIONS",
    default: 1_000_000,
};

/// Error sample times of a study (`work-precision.samples`, `stability.error_samples`): each
/// keeps a copy of the state of every run and reference.
pub const SAMPLES: Budget = Budget {
    what: "error sample times (each keeps a copy of the state)",
    variable: "SOFTBENCH_MAX_SAMPLES",
    default: 10_000,
};

/// Steps of `horizon` covered at `dt` (rounded up), as checked against [`STEPS`]: `None` when
/// the count is not a finite number that fits in 64 bits (never a saturating cast).
pub fn steps_of(horizon: f64, dt: f64) -> Option<u64> {
    let steps = (horizon / dt).ceil();
    (steps.is_finite() && steps >= 0.0 && steps < u64::MAX as f64).then_some(steps as u64)
}

/// A count over its budget.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "{what} would be {value}, above the limit of {limit}; if you mean it, raise \
     the limit with the environment variable {variable}=N"
)]
pub struct OverBudget {
    pub what: &'static str,
    /// The requested count ("more than 2^64" when computing it overflowed).
    pub value: String,
    pub limit: u64,
    pub variable: &'static str,
}

impl crate::error_class::Classify for OverBudget {
    /// A size the input asks for that is above its limit (which the user may raise).
    fn class(&self) -> crate::error_class::ErrorClass {
        crate::error_class::ErrorClass::BadInput
    }
}

impl Budget {
    /// The limit in effect: the variable's value if it is a number, else the default.
    pub fn limit(&self) -> u64 {
        std::env::var(self.variable)
            .ok()
            .and_then(|v| v.trim().replace('_', "").parse().ok())
            .unwrap_or(self.default)
    }

    /// Checks a count; `None` means the count overflowed while being computed.
    pub fn check(&self, value: Option<u64>) -> Result<(), OverBudget> {
        let limit = self.limit();
        match value {
            Some(v) if v <= limit => Ok(()),
            _ => Err(OverBudget {
                what: self.what,
                value: value.map_or("more than 2^64".into(), |v| v.to_string()),
                limit,
                variable: self.variable,
            }),
        }
    }

    /// Checks a `usize` count.
    pub fn check_usize(&self, value: Option<usize>) -> Result<(), OverBudget> {
        self.check(value.and_then(|v| u64::try_from(v).ok()))
    }
}

/// Multiplies counts, `None` on overflow.
pub fn product(factors: &[usize]) -> Option<usize> {
    factors
        .iter()
        .try_fold(1usize, |acc, &f| acc.checked_mul(f))
}
