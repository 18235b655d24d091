//! The Newton loop's settings (`[integrator.newton]`) and the names of its swappable
//! components: the direction, the globalization, the convergence criterion and L-BFGS's
//! initial Hessian. Each component is a row of a `named_enum!` table (name, description),
//! listed by `softbench list`; adding one is a row here plus its arm where it acts.

use crate::fem::FilterSpace;
use crate::integrate::filter::{FilterSettings, HessianFilter};

crate::named_enum! {
    /// How a Newton iteration picks its direction (`integrator.newton.direction`).
    pub enum Direction: "Newton direction", UnknownDirection {
        /// Solve `H dx = -g` with the system matrix (refactored every `refactor_every`
        /// iterations: 1 is full Newton, more is modified Newton).
        Newton = "newton",
            "solve H dx = -g (refactor_every > 1: modified Newton, a kept factorization)",
        /// Limited-memory BFGS: the two-loop recursion over the last `lbfgs_history` pairs,
        /// started from `lbfgs_initial`.
        Lbfgs = "lbfgs",
            "limited-memory BFGS over lbfgs_history pairs, from the lbfgs_initial Hessian",
        /// `dx = -M_lumped^-1 g`: steepest descent in the mass metric, a baseline.
        GradientDescent = "gradient-descent",
            "steepest descent in the lumped-mass metric, dx = -M^-1 g (a baseline)",
    }
}

crate::named_enum! {
    /// How a step along the direction is made safe (`integrator.newton.globalization`).
    pub enum Globalization: "globalization", UnknownGlobalization {
        /// Backtracking from `initial_step` by `shrink` until the Armijo condition holds.
        Backtracking = "backtracking",
            "Armijo backtracking line search (initial_step, shrink, sufficient_decrease)",
        /// A trust region in the lumped-mass norm, its subproblem solved by Steihaug's
        /// truncated CG on the (filtered, unfactored) system matrix.
        TrustRegion = "trust-region",
            "trust region in the mass norm, subproblem by Steihaug-CG (direction newton only)",
        /// The full step `initial_step * dx`, no check of the energy (fails only when the
        /// step inverts an element).
        FullStep = "none",
            "the full step, unchecked (fails when the step inverts an element)",
    }
}

crate::named_enum! {
    /// When a Newton solve has converged (`integrator.newton.criterion`); `tolerance` means
    /// what the criterion says.
    pub enum Criterion: "convergence criterion", UnknownCriterion {
        /// `‖g‖ <= tol (‖M (x_hat - q)‖ + ‖l‖ + beta ‖grad V(x0)‖)`: relative to the size of
        /// the step's own terms (the default).
        ScaledGradient = "scaled-gradient",
            "||g|| <= tol * (||M (x_hat - q)|| + beta ||grad V(x0)||), the step's own terms",
        /// `‖g‖ <= tol`, in the incremental potential's units (kg·m).
        Gradient = "gradient",
            "||g|| <= tol, absolute (kg m: the incremental potential's gradient)",
        /// `‖g‖ <= tol ‖g(x0)‖`, relative to the first iterate's gradient.
        RelativeGradient = "relative-gradient",
            "||g|| <= tol * ||g(x0)||, relative to the first iterate",
        /// `‖g‖ <= tol beta ‖M a_g‖`, relative to the mass-weighted gravity force (refused for
        /// a model without gravity).
        GravityGradient = "gravity-gradient",
            "||g|| <= tol * beta ||M g_gravity||, relative to the weight of the body",
        /// Half the Newton decrement, `-g·dx / 2 <= tol` (kg·m², the potential's units), with
        /// the iteration's direction (exact for `newton`).
        Decrement = "decrement",
            "-g.dx / 2 <= tol, the Newton decrement (kg m^2, the potential's units)",
        /// The last step's largest displacement, `‖x_k - x_(k-1)‖_inf <= tol` (m).
        Step = "step",
            "||x_k - x_k-1||_inf <= tol (m), the last step's largest displacement",
        /// The last step's decrease of the potential, relative to the magnitude of its terms.
        Energy = "energy",
            "E(x_k-1) - E(x_k) <= tol * (sum of |terms| of E), the last decrease",
    }
}

crate::named_enum! {
    /// L-BFGS's initial inverse Hessian (`integrator.newton.lbfgs_initial`).
    pub enum LbfgsInitial: "L-BFGS initial Hessian", UnknownLbfgsInitial {
        /// `gamma I` with Shanno's scaling `s·y / y·y` (the first iteration: the inverse mean
        /// vertex mass).
        Identity = "identity",
            "scaled identity, gamma = s.y / y.y (Shanno); first iteration 1 / mean mass",
        /// The lumped mass, `M` (the inertial term's Hessian: M/h² in force units).
        Mass = "mass",
            "the lumped mass matrix M (M/h^2 in force units)",
        /// `M + beta K(rest)`, factored once per `beta` for the whole run.
        Rest = "rest",
            "M + beta K at the rest shape, factored once per beta for the run",
        /// `M + beta K(x0)` at the solve's first iterate, factored once per solve.
        StepStart = "step-start",
            "M + beta K at the step's first iterate, factored once per step",
    }
}

/// Newton and line-search settings. Defaults follow the course handout (initial step 1,
/// shrink 0.5, sufficient decrease 1e-8, at most 5 iterations).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NewtonSettings {
    /// Newton iterations per solve. Default 5.
    pub max_iterations: u32,
    /// The convergence tolerance; its meaning is the criterion's. Default 1e-8.
    pub tolerance: f64,
    /// When a solve has converged. Default `scaled-gradient`.
    pub criterion: Criterion,
    /// How the direction is chosen. Default `newton`.
    pub direction: Direction,
    /// How the step along it is made safe. Default `backtracking`.
    pub globalization: Globalization,
    /// First line-search step length (the full step of `none`). Default 1.
    pub initial_step: f64,
    /// Step-length factor per backtrack, in (0, 1). Default 0.5.
    pub shrink: f64,
    /// Armijo constant c in `E(x + a dx) <= E(x) + c a g.dx`. Default 1e-8.
    pub sufficient_decrease: f64,
    /// Backtracks per line search (rejected trust-region steps per iteration) before Newton
    /// fails. Default 40.
    pub max_backtracks: u32,
    /// The old switch for `filter = "clamp"`: true projects every element Hessian to PSD.
    /// Kept as an alias; it contradicts any filter other than `none` and `clamp`.
    /// Default false.
    pub project_hessian: bool,
    /// The Hessian filter (see [`crate::integrate::filter`]): `none` (the default: exact
    /// Hessians, clamped only when the system is indefinite), `clamp`, `abs`, `on-demand`,
    /// `progressive`.
    pub filter: HessianFilter,
    /// `ε` of the filter, >= 0: every filtered eigenvalue is at least this. Default 0.
    pub filter_epsilon: f64,
    /// Where the filter decomposes: `element` (the 12×12 element Hessian, the default) or
    /// `stress` (the material's 9×9 dP/dF).
    pub filter_space: FilterSpace,
    /// Fail the step when the tolerance is not met within `max_iterations` (otherwise the last
    /// iterate is used, as in the course, and counted as unconverged). Default false.
    pub require_convergence: bool,
    /// On failure, retry the step as two steps of dt/2, at most this many times nested.
    /// Default 0 (off).
    pub retry_halvings: u32,
    /// Newton iterations, counted across steps, that share one factorization of the system
    /// matrix. 1 (the default) is full Newton; k > 1 is modified Newton: the matrix is
    /// refactored every k-th iteration, and also when β (the time step) changes or when the
    /// kept factorization does not give a descent direction. Fewer factorizations for more,
    /// linearly converging, iterations.
    pub refactor_every: u32,
    /// Pairs `(s, y)` L-BFGS keeps. Default 10.
    pub lbfgs_history: u32,
    /// L-BFGS's initial Hessian. Default `rest`.
    pub lbfgs_initial: LbfgsInitial,
    /// The trust region's first radius in the lumped-mass norm `sqrt(dx^T M dx)` (kg^½ m);
    /// 0 (the default) is `0.1 sqrt(total free mass) L`, L the rest shape's bounding-box
    /// diagonal: a tenth of the body's size.
    pub trust_radius: f64,
    /// Steihaug-CG iterations per trust-region subproblem; a subproblem that reaches the cap
    /// takes its last iterate and is counted. Default 500.
    pub trust_region_cg_iterations: u32,
    /// Keep a record of every iteration (written to `iterations.csv` by `simulate`).
    /// Default false.
    pub log_iterations: bool,
    /// End the solve where the predicted decrease falls below the energy's round-off (the
    /// `roundoff` stop; the default, true). False goes on past it with full steps judged by
    /// the criterion alone, until the criterion, the cap, or a full step that does not lower
    /// the gradient norm (then the `roundoff` stop): a gradient criterion can then be met
    /// below the ~1e-7 the energy can resolve.
    pub roundoff_stop: bool,
    /// The largest relative residual at which an iterative linear solve (CG, or `auto` when it
    /// chose CG) may stop: each Newton direction is solved to `min(forcing_max,
    /// sqrt(‖g‖/‖g₀‖))` (the inexact-Newton forcing term, g₀ the solve's first gradient) or
    /// the solver's own tolerance, whichever is larger. Direct solvers solve exactly whatever
    /// it says. A solve that stops at `max_iterations` unconverged after inexact directions is
    /// redone with exact ones (its end would otherwise depend on the linear solver). 0 solves
    /// every direction to the solver's tolerance. Default 0.1.
    pub forcing_max: f64,
}

impl Default for NewtonSettings {
    fn default() -> Self {
        Self {
            max_iterations: 5,
            tolerance: 1e-8,
            criterion: Criterion::ScaledGradient,
            direction: Direction::Newton,
            globalization: Globalization::Backtracking,
            initial_step: 1.0,
            shrink: 0.5,
            sufficient_decrease: 1e-8,
            max_backtracks: 40,
            project_hessian: false,
            filter: HessianFilter::None,
            filter_epsilon: 0.0,
            filter_space: FilterSpace::Element,
            require_convergence: false,
            retry_halvings: 0,
            refactor_every: 1,
            lbfgs_history: 10,
            lbfgs_initial: LbfgsInitial::Rest,
            trust_radius: 0.0,
            trust_region_cg_iterations: 500,
            log_iterations: false,
            roundoff_stop: true,
            forcing_max: Self::DEFAULT_FORCING_MAX,
        }
    }
}

impl NewtonSettings {
    /// See [`NewtonSettings::forcing_max`] and DESIGN.md for the measurement behind it.
    pub const DEFAULT_FORCING_MAX: f64 = 0.1;

    /// The filter the system matrix uses (`project_hessian = true` is `filter = "clamp"`).
    pub fn filter_settings(&self) -> FilterSettings {
        let filter = match (self.project_hessian, self.filter) {
            (true, HessianFilter::None) => HessianFilter::Clamp,
            (_, f) => f,
        };
        FilterSettings {
            filter,
            epsilon: self.filter_epsilon,
            space: self.filter_space,
        }
    }

    /// Check every field's range and the components' combination; the message names the
    /// field and what is valid.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.filter_epsilon.is_finite() && self.filter_epsilon >= 0.0) {
            return Err(format!(
                "newton.filter_epsilon must be finite and >= 0 (got {})",
                self.filter_epsilon
            ));
        }
        if self.project_hessian
            && !matches!(self.filter, HessianFilter::None | HessianFilter::Clamp)
        {
            return Err(format!(
                "newton.project_hessian = true means newton.filter = \"clamp\", which contradicts \
                 newton.filter = \"{}\"; set only newton.filter",
                self.filter
            ));
        }
        let checks = [
            (
                self.max_iterations >= 1,
                "newton.max_iterations must be >= 1",
            ),
            (
                self.refactor_every >= 1,
                "newton.refactor_every must be >= 1 (1 = full Newton)",
            ),
            (
                self.tolerance.is_finite() && self.tolerance >= 0.0,
                "newton.tolerance must be >= 0",
            ),
            (
                self.initial_step.is_finite() && self.initial_step > 0.0,
                "newton.initial_step must be > 0",
            ),
            (
                self.shrink > 0.0 && self.shrink < 1.0,
                "newton.shrink must lie in (0, 1)",
            ),
            (
                self.sufficient_decrease >= 0.0 && self.sufficient_decrease < 1.0,
                "newton.sufficient_decrease must lie in [0, 1)",
            ),
            (
                self.lbfgs_history >= 1 && self.lbfgs_history <= 1000,
                "newton.lbfgs_history must lie in [1, 1000]",
            ),
            (
                self.trust_radius.is_finite() && self.trust_radius >= 0.0,
                "newton.trust_radius must be >= 0 (0 = a tenth of the body's size)",
            ),
            (
                self.trust_region_cg_iterations >= 1,
                "newton.trust_region_cg_iterations must be >= 1",
            ),
            (
                (0.0..1.0).contains(&self.forcing_max),
                "newton.forcing_max must lie in [0, 1) (0 = solve to the linear solver's tolerance)",
            ),
            (
                self.globalization != Globalization::TrustRegion
                    || self.direction == Direction::Newton,
                "newton.globalization = \"trust-region\" takes its step from the system matrix: \
                 it needs newton.direction = \"newton\"",
            ),
            (
                self.globalization != Globalization::TrustRegion || self.refactor_every == 1,
                "newton.globalization = \"trust-region\" assembles the matrix every iteration: \
                 newton.refactor_every must be 1",
            ),
            (
                self.direction == Direction::Newton || self.refactor_every == 1,
                "newton.refactor_every applies to direction = \"newton\" only",
            ),
        ];
        match checks.iter().find(|(ok, _)| !ok) {
            Some((_, msg)) => Err((*msg).to_string()),
            None => Ok(()),
        }
    }
}
