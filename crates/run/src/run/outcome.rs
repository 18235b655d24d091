//! How a run ended, in one vocabulary shared by `summary.json`, `runs.csv` and the reports.

use softbench_core::integrate::StepError;

/// The kind of ending. Every failure is exactly one of these, so a reader can tell a method
/// that lost stability from a solver that gave up or a cap that stopped the run first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum OutcomeKind {
    /// Every requested step was taken and the energy balance held.
    Completed,
    /// The energy balance was violated (energy grew beyond the work done on the body by more
    /// than the limit allows) or the state became non-finite.
    Unstable,
    /// An element inverted where the material is undefined (the course Neo-Hookean at J <= 0).
    LeftMaterialDomain,
    /// Newton did not converge when convergence was required, a line search found no
    /// decrease, a linear solver failed, or adaptive step control gave up.
    SolverFailed,
    /// A cap stopped the run before its horizon: a stability trial's step cap, or the
    /// run's cost budget (`run.budget`).
    HorizonNotReached,
    /// A stop was requested (SIGINT or SIGTERM); the rows so far are valid states.
    Interrupted,
}

impl OutcomeKind {
    /// Every kind, in the order reports list them.
    pub const ALL: [OutcomeKind; 6] = [
        Self::Completed,
        Self::Unstable,
        Self::LeftMaterialDomain,
        Self::SolverFailed,
        Self::HorizonNotReached,
        Self::Interrupted,
    ];

    /// The word written in tables.
    pub fn name(self) -> &'static str {
        match self {
            Self::Completed => "completed",
            Self::Unstable => "unstable",
            Self::LeftMaterialDomain => "left-material-domain",
            Self::SolverFailed => "solver-failed",
            Self::HorizonNotReached => "horizon-not-reached",
            Self::Interrupted => "interrupted",
        }
    }

    /// The kind by its table word.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// The kind of a step that could not be taken.
    pub fn of_step_error(e: &StepError) -> Self {
        match e {
            StepError::NonFinite { .. } => Self::Unstable,
            StepError::InvertedElement { .. } => Self::LeftMaterialDomain,
            StepError::NewtonFailed { .. }
            | StepError::Solver(_)
            | StepError::StepTooSmall { .. }
            | StepError::TooManySubsteps { .. }
            | StepError::Model(_)
            | StepError::Method(_) => Self::SolverFailed,
            StepError::OverBudget { .. } => Self::HorizonNotReached,
            StepError::Interrupted(_) => Self::Interrupted,
        }
    }
}

impl std::fmt::Display for OutcomeKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// How a run ended: the kind, and for any other ending than `completed`, where and why.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Outcome {
    pub status: OutcomeKind,
    /// The step that could not be taken, or after which a check failed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub step: Option<usize>,
    /// The simulated time that step was to reach (s).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub t: Option<f64>,
    /// A short cause ("energy growth", "non-finite state", "newton failure", ...).
    #[serde(skip_serializing_if = "String::is_empty")]
    pub cause: String,
    /// The full message, naming the cap or threshold that decided it.
    #[serde(skip_serializing_if = "String::is_empty")]
    pub message: String,
}

impl Outcome {
    /// Every step taken.
    pub fn completed() -> Self {
        Self {
            status: OutcomeKind::Completed,
            step: None,
            t: None,
            cause: String::new(),
            message: String::new(),
        }
    }

    /// Any other ending.
    pub fn ended(
        status: OutcomeKind,
        step: usize,
        t: f64,
        cause: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        Self {
            status,
            step: Some(step),
            t: Some(t),
            cause: cause.into(),
            message: message.into(),
        }
    }

    /// A step that could not be taken.
    pub fn of_step_error(step: usize, t: f64, e: &StepError) -> Self {
        Self::ended(
            OutcomeKind::of_step_error(e),
            step,
            t,
            e.cause(),
            e.to_string(),
        )
    }

    /// Whether every step was taken.
    pub fn is_completed(&self) -> bool {
        self.status == OutcomeKind::Completed
    }
}
