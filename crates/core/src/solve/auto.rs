//! `linear_solver = "auto"`: sparse Cholesky or AMG-preconditioned CG, whichever is predicted
//! to be cheaper per Newton iteration from the ordering's exact factorization cost.
//!
//! The direct solver's cost grows like n² on 3D meshes (its factorization flops), CG with
//! AMG's like n (a fixed number of V-cycles of O(nnz(A)) work), so large meshes go to CG.
//! The rule compares predicted seconds per Newton iteration:
//! - Cholesky: `factor_flops / DIRECT_FLOPS_PER_SECOND` (dense supernodal kernels) plus two
//!   triangular solves (`4 nnz(L)` flops), divided by the factorization's parallel speed-up
//!   when it will run on more than one thread (`DIRECT_PARALLEL_EFFICIENCY`: without it the
//!   rule, calibrated on one thread, sent the 48k ball to CG + AMG at 1.40 s per step where
//!   two-thread Cholesky took 1.06 s);
//! - CG with AMG: mat-vecs of `2 nnz(A)` flops at `SPARSE_FLOPS_PER_SECOND`: the setup
//!   amortized over the hierarchy's reuse (one build of `AMG_BUILD_MATVECS` per
//!   `rebuild_every` setups, value-only refreshes of `AMG_REFRESH_MATVECS` every
//!   `galerkin_every`, lagged ones of `AMG_LAGGED_MATVECS` in between) plus `CG_ITERATIONS`
//!   iterations of `MATVECS_PER_ITERATION`, times `INEXACT_NEWTON_ITERATIONS` (inexact
//!   directions take more Newton iterations than exact ones), divided by its parallel
//!   speed-up (`ITERATIVE_PARALLEL_EFFICIENCY`) when AMG's levels will run on more than one
//!   thread.
//!
//! The constants were measured with `cargo run --release --example auto_calibrate` (boxes
//! and balls of 1.5k–96k tets, one thread, medians of 3, the machine loaded: load average
//! ~4 on 2 cores, late 2026): faer factorized at 1.05–1.78e10 flop/s from 12k tets up
//! (7.6e9 at 1.5k), a mat-vec ran at 2.2–3.0e9 flop/s, an AMG build cost 350–520 mat-vecs and a
//! refresh 57–183, an iteration 10–14, and CG took 20–24 iterations on a smooth load (21–33 per
//! Newton solve in `experiments/solver_scaling.toml`). The rates enter only as their ratio.
//! With them the rule picked the measured faster solver on all six meshes of that run
//! (Cholesky up to the 12k box and 10k ball, CG+AMG from 48k tets).
//!
//! Since then CG solves Newton directions inexactly (`newton.forcing_max`: 5–6 CG iterations
//! per solve instead of 20–33, for about 1.5× the Newton iterations) and AMG runs on every
//! thread with lagged coarse operators; the iterative side's constants were refitted from the
//! solver-scaling study and step_49k at d15dfe3 (rates and build/refresh costs kept), where
//! CG + AMG on two threads was faster than Cholesky from the 48k ball and the 49k box up
//! (0.43 against 0.52 s and 0.27 against 0.47 s per steady step) and slower on the 10k ball
//! and the smaller meshes; the 12k box was a tie within the noise (45–104 ms against 54–64 ms
//! in two runs). The prediction needs only
//! the ordering and L's column counts (`OrderingChoice`), so choosing CG costs no symbolic
//! factorization; when Cholesky wins, the ordering is handed to it and symbolically factored
//! once. The choice is reported per run (`SolverStats::chosen`, the `linear_solver_used`
//! column).

use std::sync::Arc;

use super::Scheduler;
use super::faer_common::{OrderingChoice, SymbolicAnalysis, factor_threads};
use super::{
    AmgSettings, CgSettings, CgSolver, CholeskySolver, FactorReport, LinearSolver, Preconditioner,
    SolveError, SolveReport, SolverSettings, SolverStats,
};
use crate::parallel::Parallelism;
use crate::sparse::{SparsityPattern, SymmetricMatrix};

/// Flops per second of faer's supernodal factorization (one thread, 3D FEM systems).
pub const DIRECT_FLOPS_PER_SECOND: f64 = 1.5e10;
/// Speed-up of a parallel factorization per thread beyond the first. The subtree-scheduled
/// factorization ran 1.78–1.89× faster on two threads than on one on the 49k box and the 83k
/// ball (`results/cholmod`, 5c6955b). CG with AMG is left at one thread in the rule: it
/// gained 1.07× on the 49k box's step when that value was set, and about 1.4× since AMG runs
/// on every thread (step_49k, see the module docs for why the rule was not refitted). Only
/// two-thread runs back the value.
pub const DIRECT_PARALLEL_EFFICIENCY: f64 = 0.8;
/// Flops per second of a sparse mat-vec (`2 nnz(A)` flops).
pub const SPARSE_FLOPS_PER_SECOND: f64 = 2.6e9;
/// Mat-vec equivalents of a full AMG build (strength, aggregation, prolongators, Galerkin).
pub const AMG_BUILD_MATVECS: f64 = 450.0;
/// Mat-vec equivalents of a value-only AMG refresh (Galerkin values, coarse factor).
pub const AMG_REFRESH_MATVECS: f64 = 140.0;
/// Mat-vec equivalents of a lagged refresh (the finest level's values and diagonal only,
/// [`AmgSettings::galerkin_every`]): a gather of the matrix's values.
pub const AMG_LAGGED_MATVECS: f64 = 2.0;
/// Mat-vec equivalents per AMG-preconditioned CG iteration (V-cycle plus CG's own).
pub const MATVECS_PER_ITERATION: f64 = 12.0;
/// CG iterations expected per Newton solve with AMG and inexact Newton directions
/// (`newton.forcing_max = 0.1`): 5.0–6.0 per solve on the boxes and balls of 12k–236k tets of
/// the solver-scaling study and 5.2 on step_49k (d15dfe3).
pub const CG_ITERATIONS: f64 = 6.0;
/// Newton iterations of a solve with inexact (CG) directions per iteration of one with exact
/// (Cholesky) ones: 4.0 against 2.6 per step on step_49k, 8 against 5 (two steps) on the 49k
/// box of the solver-scaling study (d15dfe3).
pub const INEXACT_NEWTON_ITERATIONS: f64 = 1.5;
/// Speed-up of CG + AMG per thread beyond the first, on a system of at least
/// [`AmgSettings::parallel_min_rows`] rows: its steady step ran 1.62× faster on two threads
/// than on one on the 49k box (step_49k, d15dfe3), assembly included.
pub const ITERATIVE_PARALLEL_EFFICIENCY: f64 = 0.5;

/// What the rule predicts for one pattern (seconds per Newton iteration).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AutoPrediction {
    pub direct_seconds: f64,
    pub iterative_seconds: f64,
}

impl AutoPrediction {
    /// The prediction from the factor's cost and `nnz(A)` (both triangles), with AMG's
    /// default hierarchy reuse, on one thread.
    pub fn new(factor_nnz: usize, factor_flops: f64, matrix_nnz: usize) -> Self {
        Self::with_amg(
            factor_nnz,
            factor_flops,
            matrix_nnz,
            &AmgSettings::default(),
        )
    }

    /// As [`AutoPrediction::new`] with AMG rebuilding its hierarchy every `rebuild_every`
    /// setups (0: once per pattern, counted as every 100) and recomputing its coarse
    /// operators every `galerkin_every` setups in between (lagged refreshes otherwise).
    pub fn with_amg(
        factor_nnz: usize,
        factor_flops: f64,
        matrix_nnz: usize,
        amg: &AmgSettings,
    ) -> Self {
        let direct = (factor_flops + 4.0 * factor_nnz as f64) / DIRECT_FLOPS_PER_SECOND;
        let matvec = 2.0 * matrix_nnz as f64 / SPARSE_FLOPS_PER_SECOND;
        let k = if amg.rebuild_every == 0 {
            100
        } else {
            amg.rebuild_every
        };
        let galerkin = (k - 1) / amg.galerkin_every.max(1);
        let lagged = k - 1 - galerkin;
        let setup = (AMG_BUILD_MATVECS
            + galerkin as f64 * AMG_REFRESH_MATVECS
            + lagged as f64 * AMG_LAGGED_MATVECS)
            / k as f64;
        let iterative =
            INEXACT_NEWTON_ITERATIONS * matvec * (setup + CG_ITERATIONS * MATVECS_PER_ITERATION);
        Self {
            direct_seconds: direct,
            iterative_seconds: iterative,
        }
    }

    /// The prediction when the factorization runs on `threads` threads (see
    /// [`DIRECT_PARALLEL_EFFICIENCY`]); one thread leaves it unchanged.
    pub fn with_factor_threads(mut self, threads: usize) -> Self {
        let extra = threads.saturating_sub(1) as f64;
        self.direct_seconds /= 1.0 + DIRECT_PARALLEL_EFFICIENCY * extra;
        self
    }

    /// The prediction when CG + AMG runs on `threads` threads (see
    /// [`ITERATIVE_PARALLEL_EFFICIENCY`]); one thread leaves it unchanged.
    pub fn with_iterative_threads(mut self, threads: usize) -> Self {
        let extra = threads.saturating_sub(1) as f64;
        self.iterative_seconds /= 1.0 + ITERATIVE_PARALLEL_EFFICIENCY * extra;
        self
    }

    /// Whether the direct solver is predicted to be cheaper.
    pub fn direct(&self) -> bool {
        self.direct_seconds <= self.iterative_seconds
    }
}

/// Cholesky or CG with AMG, chosen per pattern by [`AutoPrediction`].
pub struct AutoSolver {
    settings: SolverSettings,
    inner: Option<Box<dyn LinearSolver>>,
    pattern: Option<Arc<SparsityPattern>>,
    prediction: Option<AutoPrediction>,
    /// The caller's forcing term, kept for a solver built after it was set (Newton sets it
    /// before the first factorization, which is when the choice is made).
    forcing: Option<f64>,
    empty: SolverStats,
}

impl AutoSolver {
    /// The direct part reads `settings.direct`, the iterative part `settings.cg` with the AMG
    /// preconditioner.
    pub fn new(settings: SolverSettings) -> Self {
        Self {
            settings,
            inner: None,
            pattern: None,
            prediction: None,
            forcing: None,
            empty: SolverStats::default(),
        }
    }

    /// The last prediction, if a pattern was analyzed.
    pub fn prediction(&self) -> Option<AutoPrediction> {
        self.prediction
    }

    fn inner(&mut self, call: &'static str) -> Result<&mut Box<dyn LinearSolver>, SolveError> {
        self.inner.as_mut().ok_or(SolveError::OutOfOrder {
            call,
            missing: "analyze",
        })
    }
}

impl LinearSolver for AutoSolver {
    fn name(&self) -> &'static str {
        "auto"
    }

    fn analyze(&mut self, pattern: &Arc<SparsityPattern>) -> Result<(), SolveError> {
        let same = self
            .pattern
            .as_ref()
            .is_some_and(|p| Arc::ptr_eq(p, pattern) || **p == **pattern);
        if same {
            return self.inner("analyze")?.analyze(pattern);
        }
        let choice = OrderingChoice::new(pattern, &self.settings.direct)?;
        let iterative_threads = match self.settings.cg.parallelism {
            Parallelism::Rayon if pattern.dim() >= self.settings.cg.amg.parallel_min_rows => {
                rayon::current_num_threads()
            }
            _ => 1,
        };
        let prediction = AutoPrediction::with_amg(
            choice.cost.nnz,
            choice.cost.flops,
            pattern.nnz(),
            &self.settings.cg.amg,
        )
        .with_factor_threads(factor_threads(
            &self.settings.direct,
            choice.cost.flops,
            self.settings.direct.scheduler == Scheduler::Faer,
        ))
        .with_iterative_threads(iterative_threads);
        let mut solver: Box<dyn LinearSolver> = if prediction.direct() {
            let analysis = SymbolicAnalysis::from_choice(pattern, &self.settings.direct, choice)?;
            let mut s = CholeskySolver::new(self.settings.direct);
            s.analyze_with(pattern, Some(analysis))?;
            Box::new(s)
        } else {
            let mut s = CgSolver::new(CgSettings {
                preconditioner: Preconditioner::Amg,
                ..self.settings.cg
            });
            s.analyze(pattern)?;
            Box::new(s)
        };
        solver.set_forcing(self.forcing);
        self.inner = Some(solver);
        self.pattern = Some(pattern.clone());
        self.prediction = Some(prediction);
        Ok(())
    }

    fn factor(&mut self, a: &SymmetricMatrix) -> Result<FactorReport, SolveError> {
        self.inner("factor")?.factor(a)
    }

    fn solve(&mut self, x: &mut [f64]) -> Result<SolveReport, SolveError> {
        self.inner("solve")?.solve(x)
    }

    fn solve_with_guess(&mut self, rhs: &[f64], x: &mut [f64]) -> Result<SolveReport, SolveError> {
        self.inner("solve")?.solve_with_guess(rhs, x)
    }

    fn set_forcing(&mut self, forcing: Option<f64>) {
        self.forcing = forcing;
        if let Some(s) = self.inner.as_mut() {
            s.set_forcing(forcing);
        }
    }

    fn honours_forcing(&self) -> bool {
        self.inner.as_ref().is_some_and(|s| s.honours_forcing())
    }

    fn set_coordinates(&mut self, positions: &[f64]) {
        if let Some(s) = self.inner.as_mut() {
            s.set_coordinates(positions);
        }
    }

    /// The chosen solver's statistics (reset when a new pattern makes a new choice).
    fn stats(&self) -> &SolverStats {
        self.inner.as_ref().map_or(&self.empty, |s| s.stats())
    }
}
