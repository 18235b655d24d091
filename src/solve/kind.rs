//! Choosing a solver: [`LinearSolverKind`] by name (as written in a config), and the settings
//! each backend reads.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::{CgSettings, CgSolver, CholeskySolver, DenseCholeskySolver, LdltSolver, LinearSolver};
use crate::parallel::Parallelism;

/// Settings for faer's sparse direct solvers (Cholesky and LDLᵀ).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DirectSettings {
    /// Fill-reducing ordering. Default: AMD.
    pub ordering: Ordering,
    /// Supernodal or simplicial factorization. Default: `Auto` (faer's flop-ratio
    /// threshold; in 3D supernodal wins by ~20×).
    pub supernodal: Supernodal,
    /// Threads for the numeric factorization. Default: sequential (two threads give only
    /// ~1.2× on the factorization, and runs stay reproducible). A run setting, not part of a
    /// config file.
    #[serde(skip)]
    pub parallelism: Parallelism,
}

impl Default for DirectSettings {
    fn default() -> Self {
        Self {
            ordering: Ordering::Amd,
            supernodal: Supernodal::Auto,
            parallelism: Parallelism::Sequential,
        }
    }
}

/// Fill-reducing ordering for the direct solvers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Ordering {
    /// Approximate minimum degree.
    #[default]
    Amd,
    /// The caller's ordering (for tests and comparisons).
    Identity,
}

/// Choice between faer's simplicial and supernodal factorizations.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Supernodal {
    /// faer decides from the flop count per nonzero.
    #[default]
    Auto,
    Simplicial,
    Supernodal,
}

/// Settings for every backend; each solver reads its own part.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SolverSettings {
    pub direct: DirectSettings,
    pub cg: CgSettings,
}

/// The linear solvers, by name: `"cholesky" | "ldlt" | "cg" | "dense"`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub enum LinearSolverKind {
    /// Sparse LLᵀ (faer, supernodal): SPD systems.
    Cholesky,
    /// Sparse LDLᵀ (faer): symmetric systems, reports the inertia.
    Ldlt,
    /// Preconditioned conjugate gradient: SPD systems.
    Cg,
    /// Dense LLᵀ: tiny SPD systems and tests.
    Dense,
}

impl LinearSolverKind {
    /// Every kind, in the order of the valid-names list.
    pub const ALL: [LinearSolverKind; 4] = [Self::Cholesky, Self::Ldlt, Self::Cg, Self::Dense];

    /// The name accepted by `from_str`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Cholesky => "cholesky",
            Self::Ldlt => "ldlt",
            Self::Cg => "cg",
            Self::Dense => "dense",
        }
    }

    /// One line on the solver (for `softbench list`).
    pub fn description(self) -> &'static str {
        match self {
            Self::Cholesky => {
                "sparse LL^T (faer, supernodal), symbolic analysis reused; SPD systems"
            }
            Self::Ldlt => "sparse LDL^T (faer); symmetric systems, reports the inertia",
            Self::Cg => "preconditioned conjugate gradient (block-Jacobi by default); SPD systems",
            Self::Dense => "dense LL^T, for tiny systems and tests",
        }
    }

    /// A new solver of this kind, configured by its part of `settings`.
    pub fn build(self, settings: &SolverSettings) -> Box<dyn LinearSolver> {
        match self {
            Self::Cholesky => Box::new(CholeskySolver::new(settings.direct)),
            Self::Ldlt => Box::new(LdltSolver::new(settings.direct)),
            Self::Cg => Box::new(CgSolver::new(settings.cg)),
            Self::Dense => Box::new(DenseCholeskySolver::new()),
        }
    }
}

impl fmt::Display for LinearSolverKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An unknown linear solver name.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{}", crate::names::unknown_name_message("linear solver", .0, &["cholesky", "ldlt", "cg", "dense"]))]
pub struct UnknownSolverError(pub String);

impl FromStr for LinearSolverKind {
    type Err = UnknownSolverError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| UnknownSolverError(s.to_owned()))
    }
}

impl TryFrom<String> for LinearSolverKind {
    type Error = UnknownSolverError;
    fn try_from(s: String) -> Result<Self, Self::Error> {
        s.parse()
    }
}

impl From<LinearSolverKind> for String {
    fn from(k: LinearSolverKind) -> String {
        k.name().to_owned()
    }
}
