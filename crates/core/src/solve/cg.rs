//! Preconditioned conjugate gradient for SPD systems.
//!
//! Our own loop over [`symmetric_mul_vec`] rather than faer's `conjugate_gradient`: the
//! matrix is already ours (both triangles, a gather mat-vec), the loop is twenty lines, and
//! owning it gives a stopping test on the *true* relative residual (a recurrence residual that
//! claims convergence is checked against `b − A x` and replaced if it has drifted), a typed
//! error for `pᵀAp ≤ 0`, and no `LinOp`/`Precond` boilerplate or faer 0.24.4's
//! `InitialGuessStatus::Zero` pitfall.
//!
//! `analyze` allocates the six work vectors and the preconditioner's storage; `factor` copies
//! `A`'s values and sets up the preconditioner; `solve` allocates nothing.
//!
//! Warm start: with [`CgSettings::warm_start`], `solve` takes `b` as usual and starts from the
//! solution of the previous successful solve, which the solver keeps (reset by a new pattern
//! or a failed solve). [`LinearSolver::solve_with_guess`] takes an explicit guess instead.

use std::sync::Arc;
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use super::amg::AmgSettings;
use super::precond::PrecondState;
pub use super::precond::Preconditioner;
use super::{
    Analyzed, FactorReport, LinearSolver, SolveError, SolveReport, SolverStats, check_rhs, dot,
    norm, symmetric_mul_vec,
};
use crate::parallel::Parallelism;
use crate::sparse::{SparsityPattern, SymmetricMatrix};

/// CG settings; the defaults suit Newton steps of FEM bodies (3 DOFs per vertex).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CgSettings {
    /// Stop when `‖b − A x‖ / ‖b‖ ≤ tolerance`. Default: 1e-8.
    pub tolerance: f64,
    /// Iteration cap; reaching it is `NotConverged`. Default: 2000.
    pub max_iterations: usize,
    /// Default: 3×3 block-Jacobi (one block per vertex), which captures the coupling of a
    /// vertex's x, y, z that plain Jacobi misses, at the same cost per iteration.
    pub preconditioner: Preconditioner,
    /// Start from the previous solution instead of zero. Default: false.
    pub warm_start: bool,
    /// The AMG preconditioner's settings (strength threshold, hierarchy reuse); read only
    /// with `preconditioner = "amg"`.
    pub amg: AmgSettings,
    /// Threads for the mat-vec (results are bitwise identical either way). Default:
    /// sequential. A run setting, not part of a config file.
    #[serde(skip)]
    pub parallelism: Parallelism,
}

impl Default for CgSettings {
    fn default() -> Self {
        Self {
            tolerance: 1e-8,
            max_iterations: 2000,
            preconditioner: Preconditioner::BlockJacobi3,
            warm_start: false,
            amg: AmgSettings::default(),
            parallelism: Parallelism::Sequential,
        }
    }
}

/// Preconditioned CG. Non-convergence is `NotConverged` (the buffer then holds the last
/// iterate); `pᵀAp ≤ 0` is `NegativeCurvature`.
pub struct CgSolver {
    settings: CgSettings,
    analyzed: Analyzed,
    precond: PrecondState,
    w: Work,
    /// `w.x` holds the previous solution.
    has_previous: bool,
    /// The caller's looser stopping residual, if any ([`LinearSolver::set_forcing`]).
    forcing: Option<f64>,
    stats: SolverStats,
}

/// CG's work vectors, allocated by `analyze`.
#[derive(Default)]
struct Work {
    b: Vec<f64>,
    x: Vec<f64>,
    r: Vec<f64>,
    z: Vec<f64>,
    p: Vec<f64>,
    q: Vec<f64>,
}

impl CgSolver {
    /// A solver with the given settings; nothing is allocated before `analyze`.
    pub fn new(settings: CgSettings) -> Self {
        Self {
            settings,
            analyzed: Analyzed::default(),
            precond: PrecondState::Identity,
            w: Work::default(),
            has_previous: false,
            forcing: None,
            stats: SolverStats::default(),
        }
    }

    /// The settings.
    pub fn settings(&self) -> &CgSettings {
        &self.settings
    }

    /// Runs CG from `w.x` (zero if `x_is_zero`) on `w.b`; counts stats.
    fn run(&mut self, x_is_zero: bool, start: Instant) -> Result<SolveReport, SolveError> {
        let a = self.analyzed.factored_matrix()?;
        let mut residual_time = Duration::ZERO;
        let tolerance = self.settings.tolerance.max(self.forcing.unwrap_or(0.0));
        let result = pcg(
            a,
            &mut self.precond,
            &mut self.w,
            &self.settings,
            tolerance,
            x_is_zero,
            &mut residual_time,
        );
        let (iterations, relative_residual) = match result {
            Ok(v) => v,
            Err(e) => {
                self.has_previous = false;
                if let SolveError::NotConverged { iterations, .. } = e {
                    self.stats.linear_iterations += iterations;
                }
                return Err(e);
            }
        };
        self.has_previous = true;
        let report = SolveReport {
            iterations,
            relative_residual,
            time: start.elapsed(),
            residual_time,
        };
        self.stats.solves += 1;
        self.stats.linear_iterations += iterations;
        self.stats.solve_time += report.time;
        Ok(report)
    }
}

/// PCG on `A x = w.b` starting from `w.x`, to relative residual `tolerance`. Returns
/// (iterations, true relative residual).
fn pcg(
    a: &SymmetricMatrix,
    m: &mut PrecondState,
    w: &mut Work,
    s: &CgSettings,
    tolerance: f64,
    x_is_zero: bool,
    residual_time: &mut Duration,
) -> Result<(usize, f64), SolveError> {
    let Work { b, x, r, z, p, q } = w;
    let bnorm = norm(b);
    if bnorm == 0.0 {
        x.fill(0.0);
        return Ok((0, 0.0));
    }
    let tol = tolerance * bnorm;
    // r = b − A x, exactly (not by recurrence).
    let mut true_residual = |x: &[f64], r: &mut [f64], q: &mut [f64]| -> f64 {
        let t = Instant::now();
        symmetric_mul_vec(a, x, q, s.parallelism);
        for ((ri, bi), qi) in r.iter_mut().zip(b.iter()).zip(q.iter()) {
            *ri = bi - qi;
        }
        *residual_time += t.elapsed();
        norm(r)
    };
    let mut rnorm = if x_is_zero {
        r.copy_from_slice(b);
        bnorm
    } else {
        true_residual(x, r, q)
    };
    let (mut r_is_true, mut restart) = (true, true);
    let mut rz = 0.0;
    let mut it = 0;
    loop {
        if rnorm <= tol {
            if r_is_true {
                return Ok((it, rnorm / bnorm));
            }
            // The recurrence claims convergence: check it, and continue from the true
            // residual if it has drifted.
            rnorm = true_residual(x, r, q);
            (r_is_true, restart) = (true, true);
            continue;
        }
        if it >= s.max_iterations {
            if !r_is_true {
                rnorm = true_residual(x, r, q);
            }
            return Err(SolveError::NotConverged {
                iterations: it,
                relative_residual: rnorm / bnorm,
            });
        }
        m.apply(r, z);
        let rz_new = dot(r, z);
        if restart {
            p.copy_from_slice(z);
            restart = false;
        } else {
            let beta = rz_new / rz;
            for (pi, zi) in p.iter_mut().zip(z.iter()) {
                *pi = zi + beta * *pi;
            }
        }
        rz = rz_new;
        symmetric_mul_vec(a, p, q, s.parallelism);
        let pq = dot(p, q);
        if !(pq > 0.0 && pq.is_finite()) {
            return Err(SolveError::NegativeCurvature {
                iteration: it + 1,
                curvature: pq,
            });
        }
        let alpha = rz / pq;
        for ((xi, ri), (pi, qi)) in x.iter_mut().zip(r.iter_mut()).zip(p.iter().zip(q.iter())) {
            *xi += alpha * pi;
            *ri -= alpha * qi;
        }
        rnorm = norm(r);
        it += 1;
        r_is_true = false;
    }
}

impl LinearSolver for CgSolver {
    fn name(&self) -> &'static str {
        "cg"
    }

    fn analyze(&mut self, pattern: &Arc<SparsityPattern>) -> Result<(), SolveError> {
        let start = Instant::now();
        if self.analyzed.is_current(pattern) {
            self.stats.analyses_reused += 1;
        } else {
            let n = pattern.dim();
            self.precond = PrecondState::analyze(
                self.settings.preconditioner,
                self.settings.amg,
                self.settings.parallelism,
                pattern,
            );
            let v = || vec![0.0; n];
            self.w = Work {
                b: v(),
                x: v(),
                r: v(),
                z: v(),
                p: v(),
                q: v(),
            };
            self.has_previous = false;
            self.analyzed.set(pattern);
            self.stats.factor_nnz = self.precond.factor_nnz();
            self.stats.factor_storage = self.precond.factor_nnz();
            self.stats.ordering = self.settings.preconditioner.name();
            self.stats.chosen = "cg";
            self.stats.analyses += 1;
        }
        self.stats.analyze_time += start.elapsed();
        Ok(())
    }

    fn factor(&mut self, a: &SymmetricMatrix) -> Result<FactorReport, SolveError> {
        let start = Instant::now();
        let mut report = FactorReport::default();
        let result = match self.analyzed.load(a) {
            Ok(a) => self.precond.setup(a, &mut report),
            Err(e) => Err(e),
        };
        report.time = start.elapsed();
        self.stats.factor_time += report.time;
        if let Some(amg) = self.precond.amg_stats() {
            self.stats.amg = amg;
        }
        match result {
            Ok(()) => {
                self.analyzed.factored = true;
                self.stats.factorizations += 1;
                Ok(report)
            }
            Err(e) => {
                self.stats.failed_factorizations += 1;
                Err(e)
            }
        }
    }

    /// With `warm_start`, starts from the previous solution; otherwise from zero.
    fn solve(&mut self, rhs_and_solution: &mut [f64]) -> Result<SolveReport, SolveError> {
        let start = Instant::now();
        let n = self.analyzed.factored_matrix()?.dim();
        check_rhs(rhs_and_solution, n)?;
        self.w.b.copy_from_slice(rhs_and_solution);
        let warm = self.settings.warm_start && self.has_previous;
        if !warm {
            self.w.x.fill(0.0);
        }
        let result = self.run(!warm, start);
        if matches!(result, Ok(_) | Err(SolveError::NotConverged { .. })) {
            rhs_and_solution.copy_from_slice(&self.w.x);
        }
        result
    }

    fn solve_with_guess(&mut self, rhs: &[f64], x: &mut [f64]) -> Result<SolveReport, SolveError> {
        let start = Instant::now();
        let n = self.analyzed.factored_matrix()?.dim();
        check_rhs(rhs, n)?;
        check_rhs(x, n).map_err(|e| match e {
            SolveError::NonFiniteInput { index, .. } => SolveError::NonFiniteInput {
                input: "initial guess",
                index,
            },
            e => e,
        })?;
        self.w.b.copy_from_slice(rhs);
        self.w.x.copy_from_slice(x);
        let result = self.run(false, start);
        if matches!(result, Ok(_) | Err(SolveError::NotConverged { .. })) {
            x.copy_from_slice(&self.w.x);
        }
        result
    }

    fn set_forcing(&mut self, forcing: Option<f64>) {
        self.forcing = forcing;
    }

    fn honours_forcing(&self) -> bool {
        true
    }

    fn set_coordinates(&mut self, positions: &[f64]) {
        self.precond.set_coordinates(positions);
    }

    fn stats(&self) -> &SolverStats {
        &self.stats
    }
}
