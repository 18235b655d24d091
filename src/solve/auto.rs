//! `linear_solver = "auto"`: sparse Cholesky or AMG-preconditioned CG, whichever the
//! symbolic analysis predicts to be cheaper per Newton iteration.
//!
//! The direct solver's cost grows like n² on 3D meshes (its factorization flops), CG with
//! AMG's like n (a fixed number of V-cycles of O(nnz(A)) work), so large meshes go to CG.
//! The rule compares predicted seconds:
//! - Cholesky: `factor_flops / DIRECT_FLOPS_PER_SECOND` (dense supernodal kernels) plus two
//!   triangular solves;
//! - CG: `(AMG_SETUP_MATVECS + CG_ITERATIONS · MATVECS_PER_ITERATION)` mat-vecs of
//!   `2 nnz(A)` flops at `SPARSE_FLOPS_PER_SECOND`.
//!
//! The constants are measured on this project's machine (see DESIGN.md, "linear_solver =
//! auto"); the rates cancel to a ratio, so a faster machine moves both alike. The symbolic
//! analysis is done once (and handed to Cholesky when it wins); the choice is reported per
//! run (`SolverStats::chosen`, the `linear_solver_used` column).

use std::sync::Arc;

use super::faer_common::SymbolicAnalysis;
use super::{
    CgSettings, CgSolver, CholeskySolver, FactorReport, LinearSolver, Preconditioner, SolveError,
    SolveReport, SolverSettings, SolverStats,
};
use crate::sparse::{SparsityPattern, SymmetricMatrix};

/// Flops per second of faer's supernodal factorization (one thread, 3D FEM systems).
pub const DIRECT_FLOPS_PER_SECOND: f64 = 8.0e9;
/// Flops per second of a sparse mat-vec or a Gauss–Seidel sweep.
pub const SPARSE_FLOPS_PER_SECOND: f64 = 1.0e9;
/// Mat-vec equivalents of one AMG setup (Galerkin products, smoothing the prolongator).
pub const AMG_SETUP_MATVECS: f64 = 30.0;
/// Mat-vec equivalents per AMG-preconditioned CG iteration (V-cycle plus CG's own).
pub const MATVECS_PER_ITERATION: f64 = 5.0;
/// CG iterations expected per solve at the default tolerance with AMG.
pub const CG_ITERATIONS: f64 = 40.0;

/// What the rule predicts for one pattern (seconds per Newton iteration).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AutoPrediction {
    pub direct_seconds: f64,
    pub iterative_seconds: f64,
}

impl AutoPrediction {
    /// The prediction from the factor's cost and `nnz(A)` (both triangles).
    pub fn new(factor_nnz: usize, factor_flops: f64, matrix_nnz: usize) -> Self {
        let direct = (factor_flops + 4.0 * factor_nnz as f64) / DIRECT_FLOPS_PER_SECOND;
        let matvec = 2.0 * matrix_nnz as f64 / SPARSE_FLOPS_PER_SECOND;
        let iterative = matvec * (AMG_SETUP_MATVECS + CG_ITERATIONS * MATVECS_PER_ITERATION);
        Self {
            direct_seconds: direct,
            iterative_seconds: iterative,
        }
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
        let analysis = SymbolicAnalysis::new(pattern, &self.settings.direct)?;
        let prediction = AutoPrediction::new(analysis.cost.nnz, analysis.cost.flops, pattern.nnz());
        let solver: Box<dyn LinearSolver> = if prediction.direct() {
            let mut s = CholeskySolver::new(self.settings.direct);
            s.analyze_with(pattern, Some(analysis))?;
            Box::new(s)
        } else {
            drop(analysis);
            let mut s = CgSolver::new(CgSettings {
                preconditioner: Preconditioner::Amg,
                ..self.settings.cg
            });
            s.analyze(pattern)?;
            Box::new(s)
        };
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
