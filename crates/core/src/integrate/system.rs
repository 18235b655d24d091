//! The linear system of implicit methods, `H = M + beta K(x)`: assembled into the model's
//! fixed pattern, factored by any [`LinearSolver`] (symbolic analysis once), solved per
//! right-hand side. Element Hessians go through the Hessian filter of the settings
//! ([`super::filter`]). If `H` turns out indefinite (a failed Cholesky pivot, CG meeting
//! negative curvature, or negative pivots counted by LDLᵀ, which factors indefinite matrices
//! without failing) and the filter has a fallback (`none`, `on-demand`), it is reassembled
//! with the fallback's PSD element matrices — which makes `H` positive definite — and the
//! fallback is counted in the step report. Every caller needs a positive definite `H`
//! (Newton's direction must descend), so a matrix still indefinite after filtering is an
//! error, never a solution. Element matrices the filter changed are counted
//! (`projected_elements`) at every assembly.

use super::filter::FilterSettings;
use super::pattern_extension::PatternExtension;
use super::{StepError, StepReport};
use crate::fem::ElementFilter;
use crate::model::{HessianOptions, Model};
use crate::solve::{LinearSolver, SolveError};
use crate::sparse::{SparsityPattern, SymmetricMatrix};
use std::sync::Arc;
use std::time::Instant;

/// `M + beta K(x)` with its solver.
pub struct ImplicitSystem {
    solver: Box<dyn LinearSolver>,
    /// The matrix over the model's (element) pattern.
    matrix: Option<SymmetricMatrix>,
    /// The matrix over the element pattern extended by contact blocks, when the last
    /// assembly had any outside it ([`crate::model::Model::off_pattern_blocks`]).
    extension: Option<PatternExtension>,
    extended: bool,
    /// The pattern the solver last analyzed.
    analyzed: Option<Arc<SparsityPattern>>,
    /// The Hessian filter.
    filter: FilterSettings,
    /// Assemblies since [`Self::begin_solve`]: the Newton iteration of `progressive`.
    iteration: u32,
    /// Whether the current matrix is PSD by construction (no fallback left).
    projected: bool,
    /// Last (x, beta) assembled, so the fallback can reassemble the same matrix.
    beta: f64,
    rhs_copy: Vec<f64>,
    /// The damping matrix D(q_t) of the current step and its weight gamma, if the model damps.
    damping: Option<SymmetricMatrix>,
    gamma: f64,
    damping_active: bool,
    /// Whether the matrix has the mass term (false for a static solve: `beta K` alone).
    mass_term: bool,
    /// Solves since the current factorization, and whether it may be reused (modified
    /// Newton); `beta` of that factorization.
    uses: u32,
    reusable: bool,
    factored_beta: f64,
}

fn is_indefinite(e: &SolveError) -> bool {
    matches!(
        e,
        SolveError::NotPositiveDefinite { .. }
            | SolveError::NegativeCurvature { .. }
            | SolveError::Indefinite { .. }
    )
}

/// What the solver's current analysis is, into the step report.
fn record_solver(stats: &crate::solve::SolverStats, report: &mut StepReport) {
    report.factor_nnz = report.factor_nnz.max(stats.factor_nnz);
    report.factor_flops = report.factor_flops.max(stats.factor_flops);
    report.amg_operator_complexity = report
        .amg_operator_complexity
        .max(stats.amg.operator_complexity);
    report.amg_grid_complexity = report.amg_grid_complexity.max(stats.amg.grid_complexity);
    report.linear_solver = stats.chosen;
    report.ordering = stats.ordering;
    report.factor_scheduler = stats.factor_scheduler;
    report.factor_threads = if stats.parallel_factor {
        rayon::current_num_threads() as u32
    } else {
        1
    };
}

impl ImplicitSystem {
    /// A system whose element Hessians go through `filter`.
    pub fn new(solver: Box<dyn LinearSolver>, filter: FilterSettings) -> Self {
        Self {
            solver,
            matrix: None,
            extension: None,
            extended: false,
            analyzed: None,
            filter,
            iteration: 0,
            projected: false,
            beta: 0.0,
            rhs_copy: Vec::new(),
            damping: None,
            gamma: 0.0,
            damping_active: false,
            mass_term: true,
            uses: 0,
            reusable: false,
            factored_beta: 0.0,
        }
    }

    /// A new nonlinear solve starts: the next assembly is its iteration 0 (for filters that
    /// change with the iteration).
    pub fn begin_solve(&mut self) {
        self.iteration = 0;
    }

    /// The filter settings.
    pub fn filter(&self) -> &FilterSettings {
        &self.filter
    }

    /// Assemble `M + beta K` (the default) or, without the mass term, `beta K` (a static
    /// solve, whose matrix is singular unless something holds the body).
    pub fn set_mass_term(&mut self, on: bool) {
        self.mass_term = on;
    }

    fn assemble(
        &mut self,
        model: &mut Model,
        x: &[f64],
        filter: Option<ElementFilter>,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let start = Instant::now();
        let h = self.matrix.get_or_insert_with(|| model.new_hessian());
        model.hessian(x, h, HessianOptions { filter })?;
        report.projected_elements += model.filtered_elements() as u64;
        if self.mass_term {
            model.mass().scale_and_add_to(self.beta, h);
        } else {
            let beta = self.beta;
            h.values_mut().iter_mut().for_each(|v| *v *= beta);
        }
        if self.damping_active {
            h.axpby(
                1.0,
                self.gamma,
                self.damping.as_ref().expect("assembled with the step"),
            );
        }
        self.extend(model);
        self.projected = match (filter, self.filter.fallback()) {
            (None, _) => false,
            (Some(_), None) => true,
            (Some(f), Some(fallback)) => f == fallback,
        };
        report.times.assemble += start.elapsed().as_secs_f64();
        Ok(())
    }

    /// Carry the contact blocks the element pattern lacks (if any) into the extended matrix.
    fn extend(&mut self, model: &Model) {
        let off = model.off_pattern_blocks();
        self.extended = !off.is_empty();
        if !self.extended {
            return;
        }
        let base = self.matrix.as_ref().expect("assembled");
        if !self
            .extension
            .as_ref()
            .is_some_and(|e| e.covers(base.pattern(), off))
        {
            self.extension = Some(PatternExtension::new(
                base.pattern(),
                off,
                self.extension.as_ref(),
            ));
        }
        // The base holds `M + beta K` (or `beta K`): the contact blocks take the same weight.
        self.extension
            .as_mut()
            .expect("built above")
            .fill(base, off, self.beta);
    }

    /// The assembled matrix the solver sees: the extended one when contact needs it.
    fn active(&self) -> Option<&SymmetricMatrix> {
        if self.extended {
            self.extension.as_ref().map(PatternExtension::matrix)
        } else {
            self.matrix.as_ref()
        }
    }

    /// Assemble `M + beta K(x)` without factoring it, element Hessians through a PSD filter
    /// when `project` (the settings' filter if it is PSD by construction, else its fallback),
    /// for a caller that hands the matrix to another solver (the contact QP).
    pub fn assemble_matrix(
        &mut self,
        model: &mut Model,
        x: &[f64],
        beta: f64,
        project: bool,
        report: &mut StepReport,
    ) -> Result<&SymmetricMatrix, StepError> {
        self.beta = beta;
        let filter = project.then(|| self.filter.psd(self.iteration));
        self.assemble(model, x, filter, report)?;
        Ok(self.active().expect("assembled"))
    }

    /// The last assembled matrix (None before the first assembly), on the extended pattern
    /// when contact blocks needed one.
    pub fn matrix(&self) -> Option<&SymmetricMatrix> {
        self.active()
    }

    /// Factor the assembled matrix. A factorization that reports negative pivots (LDLᵀ) is
    /// counted as done but returned as `Indefinite`: the matrix is not positive definite.
    fn factor_current(&mut self, x: &[f64], report: &mut StepReport) -> Result<(), SolveError> {
        let start = Instant::now();
        let pattern = self.active().expect("assembled").pattern().clone();
        if !self
            .analyzed
            .as_ref()
            .is_some_and(|a| Arc::ptr_eq(a, &pattern))
        {
            self.solver.analyze(&pattern)?;
            report.symbolic_analyses += 1;
            self.analyzed = Some(pattern);
        }
        self.solver.set_coordinates(x);
        let amg_before = self.solver.stats().amg;
        let matrix = if self.extended {
            self.extension.as_ref().map(PatternExtension::matrix)
        } else {
            self.matrix.as_ref()
        };
        let result = self.solver.factor(matrix.expect("assembled"));
        report.times.factor += start.elapsed().as_secs_f64();
        let amg = self.solver.stats().amg;
        report.amg_builds += amg.builds.saturating_sub(amg_before.builds) as u32;
        report.amg_reuses += amg.reuses.saturating_sub(amg_before.reuses) as u32;
        report.amg_lagged += amg.lagged.saturating_sub(amg_before.lagged) as u32;
        let factored = result?;
        report.factorizations += 1;
        record_solver(self.solver.stats(), report);
        match factored.negative_pivots {
            Some(negative_pivots) if negative_pivots > 0 => {
                Err(SolveError::Indefinite { negative_pivots })
            }
            _ => Ok(()),
        }
    }

    /// Assemble the damping matrix `D(q)` for this step, to be added with weight `gamma` to
    /// every system matrix (`M + beta K + gamma D`). Does nothing when the model does not damp.
    pub fn set_damping(
        &mut self,
        model: &mut Model,
        q: &[f64],
        gamma: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        self.damping_active = model.has_damping();
        if !self.damping_active {
            return Ok(());
        }
        let start = Instant::now();
        let d = self.damping.get_or_insert_with(|| model.new_hessian());
        model.damping_matrix(q, d)?;
        self.gamma = gamma;
        report.times.assemble += start.elapsed().as_secs_f64();
        Ok(())
    }

    /// No damping term for this step (a scheme without one, e.g. a static solve).
    pub fn clear_damping(&mut self) {
        self.damping_active = false;
    }

    /// The current step's damping matrix and weight, if any.
    pub fn damping(&self) -> Option<(&SymmetricMatrix, f64)> {
        if self.damping_active {
            self.damping.as_ref().map(|d| (d, self.gamma))
        } else {
            None
        }
    }

    /// Assemble and factor `M + beta K(x)` (plus `gamma D`), falling back to the projected matrix if it is
    /// indefinite.
    pub fn factor(
        &mut self,
        model: &mut Model,
        x: &[f64],
        beta: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        self.beta = beta;
        self.reusable = false;
        let first = self.filter.first(self.iteration);
        self.iteration = self.iteration.saturating_add(1);
        self.assemble(model, x, first, report)?;
        match self.factor_current(x, report) {
            Err(e) if is_indefinite(&e) && !self.projected => {
                report.indefinite_fallbacks += 1;
                self.assemble(model, x, self.filter.fallback(), report)?;
                self.factor_current(x, report)?;
            }
            other => other?,
        }
        Ok(())
    }

    /// Modified Newton: keep the current factorization when it has served fewer than
    /// `refactor_every` iterations and was made with the same `beta`; otherwise
    /// [`Self::factor`]. Returns whether the kept factorization is used.
    pub fn factor_or_reuse(
        &mut self,
        model: &mut Model,
        x: &[f64],
        beta: f64,
        refactor_every: u32,
        report: &mut StepReport,
    ) -> Result<bool, StepError> {
        if self.reusable && self.uses < refactor_every && self.factored_beta == beta {
            self.uses += 1;
            return Ok(true);
        }
        self.factor(model, x, beta, report)?;
        self.uses = 1;
        self.reusable = true;
        self.factored_beta = beta;
        Ok(false)
    }

    /// The next [`Self::factor_or_reuse`] refactors.
    pub fn invalidate(&mut self) {
        self.reusable = false;
    }

    /// Solve `H x = b` in place for the last factored `H`. If CG finds the matrix indefinite,
    /// refactor the projected matrix at `x_assembled` and solve again.
    /// The relative residual the next iterative solves may stop at (see
    /// [`crate::solve::LinearSolver::set_forcing`]).
    pub fn set_forcing(&mut self, forcing: Option<f64>) {
        self.solver.set_forcing(forcing);
    }

    /// Whether the solver loosens its solves to a forcing term (an iterative solver).
    pub fn honours_forcing(&self) -> bool {
        self.solver.honours_forcing()
    }

    pub fn solve(
        &mut self,
        model: &mut Model,
        x_assembled: &[f64],
        rhs: &mut [f64],
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        self.rhs_copy.clear();
        self.rhs_copy.extend_from_slice(rhs);
        let start = Instant::now();
        let mut result = self.solver.solve(rhs);
        report.times.solve += start.elapsed().as_secs_f64();
        if let Err(e) = &result
            && is_indefinite(e)
            && !self.projected
        {
            report.indefinite_fallbacks += 1;
            self.assemble(model, x_assembled, self.filter.fallback(), report)?;
            self.factor_current(x_assembled, report)?;
            rhs.copy_from_slice(&self.rhs_copy);
            let start = Instant::now();
            result = self.solver.solve(rhs);
            report.times.solve += start.elapsed().as_secs_f64();
        }
        let solved = result?;
        report.linear_solves += 1;
        report.linear_iterations += solved.iterations as u64;
        report.max_relative_residual = report.max_relative_residual.max(solved.relative_residual);
        Ok(())
    }
}
