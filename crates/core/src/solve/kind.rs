//! Choosing a solver: [`LinearSolverKind`] by name (as written in a config), and the settings
//! each backend reads.

use serde::{Deserialize, Serialize};

use super::auto::AutoSolver;
use super::ordering::Ordering;
use super::{CgSettings, CgSolver, CholeskySolver, DenseCholeskySolver, LdltSolver, LinearSolver};
use super::{FAER_LOOP_PARALLEL_MIN_FLOPS, PARALLEL_MIN_FLOPS};
use crate::parallel::Parallelism;
use crate::registry::{Entry, Fact, Registry};

/// Settings for faer's sparse direct solvers (Cholesky and LDLᵀ).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DirectSettings {
    /// Fill-reducing ordering: `amd`, `metis` (nested dissection) or `auto` (the one with
    /// fewer predicted flops, from both symbolic analyses). Default: AMD.
    pub ordering: Ordering,
    /// Supernodal or simplicial factorization. Default: `Auto` (faer's flop-ratio
    /// threshold; in 3D supernodal wins by ~20×).
    pub supernodal: Supernodal,
    /// Threads for the numeric factorization and solves: with `Rayon`, the factorization runs
    /// on rayon's pool when the predicted factorization flops reach `parallel_min_flops`
    /// (subtree scheduler) or `faer_parallel_min_flops` (faer's loop; smaller factorizations
    /// ran slower on two threads). Set from the run's parallelism (the CLI's
    /// `--threads`) when a scene builds its integrator; not part of a config file.
    #[serde(skip)]
    pub parallelism: Parallelism,
    /// Predicted factorization flops (Σ c_j²) from which the subtree-scheduled LLᵀ runs on
    /// threads. Default: [`PARALLEL_MIN_FLOPS`].
    pub parallel_min_flops: f64,
    /// The same for a factorization in faer's own loop (LDLᵀ, simplicial, `scheduler =
    /// "faer"`), which is parallel only inside large dense kernels. Default:
    /// [`FAER_LOOP_PARALLEL_MIN_FLOPS`].
    pub faer_parallel_min_flops: f64,
    /// Who schedules a parallel Cholesky factorization: `subtrees` (independent subtrees of
    /// the elimination tree concurrently, the separators near the root with parallel dense
    /// kernels) or `faer` (faer's sequential loop over supernodes, parallel only inside each
    /// supernode's kernels). LDLᵀ always uses faer's. Default: `subtrees`.
    pub scheduler: Scheduler,
}

/// Who schedules the parallel numeric LLᵀ (see [`DirectSettings::scheduler`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Scheduler {
    /// Subtree-parallel supernodal LLᵀ (`supernodal_tree.rs`).
    #[default]
    Subtrees,
    /// faer's own supernodal loop.
    Faer,
}

impl Scheduler {
    /// The name as written in a config file.
    pub fn name(self) -> &'static str {
        match self {
            Self::Subtrees => "subtrees",
            Self::Faer => "faer",
        }
    }
}

impl Default for DirectSettings {
    fn default() -> Self {
        Self {
            ordering: Ordering::Auto,
            supernodal: Supernodal::Auto,
            parallelism: Parallelism::Sequential,
            parallel_min_flops: PARALLEL_MIN_FLOPS,
            faer_parallel_min_flops: FAER_LOOP_PARALLEL_MIN_FLOPS,
            scheduler: Scheduler::default(),
        }
    }
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

/// A linear solver in the registry: its name, what it is, the facts the rest of the code asks
/// and how to build it.
pub struct SolverEntry {
    /// The name scene files use (`integrator.linear_solver`).
    pub name: &'static str,
    /// One line on the solver (for `softbench list`).
    pub description: &'static str,
    /// A direct factorization (exact up to round-off) rather than an iterative method.
    pub direct: bool,
    /// Whether `factor` reports the inertia ([`super::FactorReport::negative_pivots`]) of an
    /// indefinite matrix instead of failing on it.
    pub reports_inertia: bool,
    /// A new solver, configured by its part of the settings.
    pub build: fn(&SolverSettings) -> Box<dyn LinearSolver>,
}

impl Entry for SolverEntry {
    fn name(&self) -> &'static str {
        self.name
    }
    fn description(&self) -> &'static str {
        self.description
    }
    fn facts(&self) -> Vec<Fact> {
        let yes_no = |b: bool| if b { "yes" } else { "no" }.to_owned();
        vec![
            (
                "kind",
                if self.direct { "direct" } else { "iterative" }.to_owned(),
            ),
            ("inertia", yes_no(self.reports_inertia)),
        ]
    }
}

/// The built-in linear solvers, one line each. A new backend adds its line here; a program
/// that depends on softbench can instead [`Registry::register`] its own in [`LINEAR_SOLVERS`].
static BUILTIN: &[SolverEntry] = &[
    SolverEntry {
        name: "cholesky",
        description: "sparse LL^T (faer, supernodal), symbolic analysis reused; SPD systems",
        direct: true,
        reports_inertia: false,
        build: |s| Box::new(CholeskySolver::new(s.direct)),
    },
    SolverEntry {
        name: "ldlt",
        description: "sparse LDL^T (faer); symmetric systems, reports the inertia",
        direct: true,
        reports_inertia: true,
        build: |s| Box::new(LdltSolver::new(s.direct)),
    },
    SolverEntry {
        name: "cg",
        description: "preconditioned conjugate gradient (block-Jacobi by default); SPD systems",
        direct: false,
        reports_inertia: false,
        build: |s| Box::new(CgSolver::new(s.cg)),
    },
    SolverEntry {
        name: "auto",
        description: "cholesky or cg with AMG, whichever the symbolic analysis predicts cheaper",
        direct: false,
        reports_inertia: false,
        build: |s| Box::new(AutoSolver::new(*s)),
    },
    SolverEntry {
        name: "dense",
        description: "dense LL^T, for tiny systems and tests",
        direct: true,
        reports_inertia: false,
        build: |_| Box::new(DenseCholeskySolver::new()),
    },
];

/// Every linear solver: the built-in ones, then those a program registered.
pub static LINEAR_SOLVERS: Registry<SolverEntry> = Registry::new("linear solver", BUILTIN);

crate::registry_handle! {
    /// A linear solver by name (`"cholesky" | "ldlt" | "cg" | "auto" | "dense"`, or a registered
    /// one).
    pub struct LinearSolverKind(SolverEntry) in LINEAR_SOLVERS;
}

impl LinearSolverKind {
    /// Sparse Cholesky, the integrator settings' default.
    pub fn cholesky() -> Self {
        Self(&BUILTIN[0])
    }

    /// A new solver of this kind, configured by its part of `settings`.
    pub fn build(self, settings: &SolverSettings) -> Box<dyn LinearSolver> {
        (self.entry().build)(settings)
    }
}
