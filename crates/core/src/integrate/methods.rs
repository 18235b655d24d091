//! The integration methods and the `[integrator]` section of a scene: one table, one line per
//! method, and the settings every method reads. Parsing, "did you mean",
//! `softbench list`, the README's method table and the checks of the rest of the code all
//! read it. A program that depends on softbench adds its own with [`register_method`].
//!
//! A new built-in method is its file plus one line here: an explicit method builds an
//! [`Integrator`]; an implicit one is usually a [`Scheme`] run by [`NewtonIntegrator`]
//! (see [`newton_scheme`]), which gives it line search, halving retries, damping and
//! constrained contact.

use super::adaptive::Adaptive;
use super::backward_euler::BackwardEuler;
use super::bdf::Bdf;
use super::bdf::BdfSettings;
use super::dirk::{Dirk, DirkTableau};
use super::embedded::{EmbeddedPair, FixedStep};
use super::energy_momentum::EnergyMomentum;
use super::implicit_midpoint::ImplicitMidpoint;
use super::linearly_implicit_euler::LinearlyImplicitEuler;
use super::newmark::{
    GeneralizedAlphaSettings, HhtSettings, Newmark, NewmarkParameters, NewmarkSettings,
};
use super::newton::NewtonContact;
use super::newton::NewtonSettings;
use super::peer::{PeerFacts, PeerSettings};
use super::projective_dynamics::ProjectiveDynamics;
use super::projective_dynamics::ProjectiveDynamicsSettings;
use super::radau_iia::RadauIIA;
use super::rosenbrock::{Rosenbrock, RosenbrockTableau};
use super::scheme::{NewtonIntegrator, Scheme};
use super::static_equilibrium::{Static, StaticSettings};
use super::symplectic_euler::SymplecticEuler;
use super::vbd::Vbd;
use super::vbd::VbdSettings;
use super::verlet::VelocityVerlet;
use super::xpbd::{Xpbd, XpbdSettings};
use super::{
    AdaptiveSettings, Integrator, dopri5, esdirk32, esdirk43, explicit_euler, midpoint, rk4,
    rodas3, ros2, tr_bdf2,
};
use crate::registry::{Entry, Fact, RegisterError, Registry};
use crate::solve::{LinearSolverKind, SolverSettings};

/// How a method is built from its settings; `constraints` is `Some` only for methods whose
/// entry allows constrained contact.
pub type BuildMethod = fn(&IntegratorSettings, Option<NewtonContact>) -> Box<dyn Integrator>;

/// Everything the rest of the code asks about a method.
pub struct MethodEntry {
    /// The name scene files use.
    pub name: &'static str,
    /// One line on what it is.
    pub description: &'static str,
    /// Formal order of accuracy with default settings (0: no time discretization, a static
    /// solve).
    pub order: u32,
    /// Never solves a linear system with the stiffness (a linear solver means nothing).
    pub explicit: bool,
    /// Solves a nonlinear system by Newton (so Newton's cap and tolerance can decide results).
    pub newton: bool,
    /// Solves sparse linear systems with the scene's `linear_solver` (false for explicit
    /// methods and for the local solvers VBD and XPBD, whose 3×3 solves need none).
    pub linear_solver: bool,
    /// Can run the constrained contact response (Newton on the end-of-step positions).
    pub constrained_contact: bool,
    /// Chooses its own internal steps to meet `integrator.adaptive`'s tolerances (the step a
    /// scene gives is an output interval, not a step size).
    pub adaptive: bool,
    /// Builds it.
    pub build: BuildMethod,
    /// Set for a peer method (another package's implementation, registered at run time):
    /// its package, version, twin, materials and settings.
    pub peer: Option<&'static PeerFacts>,
}

impl Entry for MethodEntry {
    fn name(&self) -> &'static str {
        self.name
    }
    fn description(&self) -> &'static str {
        self.description
    }
    fn facts(&self) -> Vec<Fact> {
        let yes_no = |b: bool| if b { "yes" } else { "no" }.to_owned();
        let order = match self.order {
            0 => "-".to_owned(),
            o => o.to_string(),
        };
        let kind = if self.explicit {
            "explicit"
        } else {
            "implicit"
        };
        vec![
            ("order", order),
            ("kind", kind.to_owned()),
            ("newton", yes_no(self.newton)),
            ("linear-solver", yes_no(self.linear_solver)),
            ("constrained-contact", yes_no(self.constrained_contact)),
            ("adaptive", yes_no(self.adaptive)),
            (
                "peer",
                self.peer.map_or("-".to_owned(), |p| {
                    format!(
                        "{} {}",
                        p.package,
                        p.version.as_deref().unwrap_or("(not installed)")
                    )
                }),
            ),
        ]
    }
}

/// An explicit method.
pub const fn explicit(
    name: &'static str,
    order: u32,
    description: &'static str,
    build: BuildMethod,
) -> MethodEntry {
    MethodEntry {
        name,
        description,
        order,
        explicit: true,
        newton: false,
        linear_solver: false,
        constrained_contact: false,
        adaptive: false,
        build,
        peer: None,
    }
}

/// An implicit method solved by Newton; `end_position`: its unknown is the end-of-step
/// position (so it can take constrained contact).
pub const fn implicit(
    name: &'static str,
    order: u32,
    end_position: bool,
    description: &'static str,
    build: BuildMethod,
) -> MethodEntry {
    MethodEntry {
        name,
        description,
        order,
        explicit: false,
        newton: true,
        linear_solver: true,
        constrained_contact: end_position,
        adaptive: false,
        build,
        peer: None,
    }
}

impl MethodEntry {
    /// The same entry, marked as choosing its own steps (see [`MethodEntry::adaptive`]).
    pub const fn with_error_control(mut self) -> Self {
        self.adaptive = true;
        self
    }
}

/// `scheme` on the one Newton loop with the settings' linear solver and Newton settings.
pub fn newton_scheme<S: Scheme + 'static>(
    s: &IntegratorSettings,
    constraints: Option<NewtonContact>,
    scheme: S,
) -> Box<dyn Integrator> {
    let solver = s.linear_solver.build(&s.solver);
    Box::new(NewtonIntegrator::new(scheme, solver, s.newton).constrained(constraints))
}

fn adaptive(
    name: &'static str,
    s: &IntegratorSettings,
    inner: Box<dyn Integrator>,
) -> Box<dyn Integrator> {
    Box::new(Adaptive::step_doubling(name, inner, s.adaptive))
}

/// An embedded pair at fixed steps (its estimate unused), failed steps retried as halves.
fn fixed<P: EmbeddedPair + 'static>(pair: P, s: &IntegratorSettings) -> Box<dyn Integrator> {
    Box::new(FixedStep::new(pair, s.newton.retry_halvings))
}

/// An embedded pair under error control, named `name`.
fn controlled<P: EmbeddedPair + 'static>(
    name: &'static str,
    pair: P,
    s: &IntegratorSettings,
) -> Box<dyn Integrator> {
    Box::new(Adaptive::embedded_named(name, Box::new(pair), s.adaptive))
}

fn dirk(tableau: DirkTableau, s: &IntegratorSettings) -> Dirk {
    Dirk::new(tableau, s.linear_solver.build(&s.solver), s.newton)
}

fn rosenbrock(tableau: RosenbrockTableau, s: &IntegratorSettings) -> Rosenbrock {
    let solver = s.linear_solver.build(&s.solver);
    Rosenbrock::new(tableau, solver, s.newton.filter_settings())
}

fn radau(s: &IntegratorSettings) -> RadauIIA {
    RadauIIA::new(s.linear_solver.build(&s.solver), s.newton)
}

/// A linearly implicit method: a linear solver, no Newton.
const fn linearly_implicit(
    name: &'static str,
    order: u32,
    description: &'static str,
    build: BuildMethod,
) -> MethodEntry {
    MethodEntry {
        name,
        description,
        order,
        explicit: false,
        newton: false,
        linear_solver: true,
        constrained_contact: false,
        adaptive: false,
        build,
        peer: None,
    }
}

fn bdf(
    name: &'static str,
    k: u32,
    s: &IntegratorSettings,
    c: Option<NewtonContact>,
) -> Box<dyn Integrator> {
    let solver = s.linear_solver.build(&s.solver);
    Box::new(Bdf::new(name, k, s.bdf, solver, s.newton, c))
}

/// The built-in methods, in the order `softbench list` shows them: one line each.
#[rustfmt::skip]
static BUILTIN: &[MethodEntry] = &[
    explicit("explicit-euler", 1, "forward Euler; unstable for undamped oscillation", |_, _| Box::new(explicit_euler::explicit_euler())),
    explicit("symplectic-euler", 1, "semi-implicit Euler, symplectic (bounded energy error)", |_, _| Box::new(SymplecticEuler::new())),
    explicit("velocity-verlet", 2, "central differences / Störmer-Verlet, symplectic, momentum-conserving", |_, _| Box::new(VelocityVerlet::new())),
    explicit("midpoint", 2, "explicit midpoint (RK2)", |_, _| Box::new(midpoint::midpoint())),
    explicit("rk4", 4, "classic Runge-Kutta", |_, _| Box::new(rk4::rk4())),
    explicit("adaptive-explicit-euler", 1, "explicit Euler with step-doubling error control", |s, _| adaptive("adaptive-explicit-euler", s, Box::new(explicit_euler::explicit_euler()))).with_error_control(),
    explicit("adaptive-symplectic-euler", 1, "symplectic Euler with step-doubling error control", |s, _| adaptive("adaptive-symplectic-euler", s, Box::new(SymplecticEuler::new()))).with_error_control(),
    explicit("adaptive-midpoint", 2, "explicit midpoint with step-doubling error control", |s, _| adaptive("adaptive-midpoint", s, Box::new(midpoint::midpoint()))).with_error_control(),
    explicit("adaptive-rk4", 4, "RK4 with step-doubling error control", |s, _| adaptive("adaptive-rk4", s, Box::new(rk4::rk4()))).with_error_control(),
    explicit("dopri5", 5, "Dormand-Prince 5(4) with embedded error control", |s, _| Box::new(Adaptive::embedded(Box::new(dopri5::dopri5()), s.adaptive))).with_error_control(),
    MethodEntry { name: "linearly-implicit-euler", description: "one Newton step of backward Euler per step", order: 1, explicit: false, newton: false, linear_solver: true, constrained_contact: false, adaptive: false, build: |s, _| Box::new(LinearlyImplicitEuler::new(s.linear_solver.build(&s.solver), s.newton.filter_settings())), peer: None },
    linearly_implicit("ros2", 2, "Rosenbrock-W ROS2: 2 solves with one factorization per step, L-stable", |s, _| fixed(rosenbrock(ros2::TABLEAU, s), s)),
    linearly_implicit("rodas3", 3, "Rosenbrock RODAS3: 4 solves with one factorization per step, stiffly accurate, L-stable", |s, _| fixed(rosenbrock(rodas3::TABLEAU, s), s)),
    linearly_implicit("adaptive-ros2", 2, "ROS2 with its embedded first-order error estimate (adaptive = {..})", |s, _| controlled("adaptive-ros2", rosenbrock(ros2::TABLEAU, s), s)).with_error_control(),
    linearly_implicit("adaptive-rodas3", 3, "RODAS3 with its embedded second-order error estimate", |s, _| controlled("adaptive-rodas3", rosenbrock(rodas3::TABLEAU, s), s)).with_error_control(),
    implicit("backward-euler", 1, true, "Newton with line search; unconditionally stable, dissipative", |s, c| newton_scheme(s, c, BackwardEuler)),
    implicit("implicit-midpoint", 2, false, "Newton on the midpoint; symplectic, no numerical damping", |s, c| newton_scheme(s, c, ImplicitMidpoint)),
    implicit("bdf1", 1, true, "BDF order 1 (= backward Euler)", |s, c| bdf("bdf1", 1, s, c)),
    implicit("bdf2", 2, true, "BDF order 2, A-stable", |s, c| bdf("bdf2", 2, s, c)),
    implicit("bdf3", 3, true, "BDF order 3, A(86°)-stable; extrapolated-midpoint start-up", |s, c| bdf("bdf3", 3, s, c)),
    implicit("bdf4", 4, true, "BDF order 4, A(73°)-stable; can amplify lightly damped modes", |s, c| bdf("bdf4", 4, s, c)),
    implicit("bdf5", 5, true, "BDF order 5, A(52°)-stable; can amplify lightly damped modes", |s, c| bdf("bdf5", 5, s, c)),
    implicit("bdf6", 6, true, "BDF order 6, A(18°)-stable; can amplify lightly damped modes", |s, c| bdf("bdf6", 6, s, c)),
    implicit("newmark", 2, true, "Newmark(β, γ); default trapezoidal (1/4, 1/2), order 1 if γ ≠ 1/2", |s, c| newton_scheme(s, c, Newmark::new("newmark", NewmarkParameters::newmark(s.newmark)))),
    implicit("generalized-alpha", 2, true, "generalized-α (Chung-Hulbert), high frequencies damped to ρ∞", |s, c| newton_scheme(s, c, Newmark::new("generalized-alpha", NewmarkParameters::generalized_alpha(s.generalized_alpha)))),
    implicit("hht-alpha", 2, true, "Hilber-Hughes-Taylor α, high-frequency dissipation", |s, c| newton_scheme(s, c, Newmark::new("hht-alpha", NewmarkParameters::hht(s.hht)))),
    MethodEntry { name: "vbd", description: "vertex block descent: colored Gauss-Seidel 3x3 Newton steps; converges to the backward Euler step (any material)", order: 1, explicit: false, newton: false, linear_solver: false, constrained_contact: false, adaptive: false, build: |s, _| Box::new(Vbd::new(s.vbd)), peer: None },
    MethodEntry { name: "projective-dynamics", description: "local/global iterations, prefactored global matrix; converges to backward Euler on its projective energy (corotated)", order: 1, explicit: false, newton: false, linear_solver: true, constrained_contact: false, adaptive: false, build: |s, _| Box::new(ProjectiveDynamics::new(s.projective_dynamics, s.linear_solver.build(&s.solver))), peer: None },
    MethodEntry { name: "xpbd", description: "XPBD with Neo-Hookean constraints, substepped; converges to the dynamics of its constraint energy (xpbd-neo-hookean)", order: 1, explicit: false, newton: false, linear_solver: false, constrained_contact: false, adaptive: false, build: |s, _| Box::new(Xpbd::new(s.xpbd)), peer: None },
    implicit("tr-bdf2", 2, false, "TR-BDF2: trapezoidal then BDF2 stage, L-stable, stiffly accurate (ESDIRK, 2 Newton solves per step)", |s, _| fixed(dirk(tr_bdf2::TABLEAU, s), s)),
    implicit("esdirk32", 3, false, "ESDIRK3(2)4L[2]SA (Kennedy-Carpenter), L-stable, stiffly accurate, 3 Newton solves per step", |s, _| fixed(dirk(esdirk32::TABLEAU, s), s)),
    implicit("esdirk43", 4, false, "ESDIRK4(3)6L[2]SA (Kennedy-Carpenter), L-stable, stiffly accurate, 5 Newton solves per step", |s, _| fixed(dirk(esdirk43::TABLEAU, s), s)),
    implicit("adaptive-tr-bdf2", 2, false, "TR-BDF2 with its embedded third-order error estimate (adaptive = {..})", |s, _| controlled("adaptive-tr-bdf2", dirk(tr_bdf2::TABLEAU, s), s)).with_error_control(),
    implicit("adaptive-esdirk32", 3, false, "ESDIRK3(2) with its embedded second-order error estimate", |s, _| controlled("adaptive-esdirk32", dirk(esdirk32::TABLEAU, s), s)).with_error_control(),
    implicit("adaptive-esdirk43", 4, false, "ESDIRK4(3) with its embedded third-order error estimate", |s, _| controlled("adaptive-esdirk43", dirk(esdirk43::TABLEAU, s), s)).with_error_control(),
    implicit("radau-iia", 5, false, "Radau IIA (3 stages, collocation): L-stable, stiffly accurate; simplified Newton on the coupled stages, a real and a complex factorization per step", |s, _| fixed(radau(s), s)),
    implicit("adaptive-radau-iia", 5, false, "Radau IIA with its embedded third-order error estimate (RADAU5's)", |s, _| controlled("adaptive-radau-iia", radau(s), s)).with_error_control(),
    implicit("energy-momentum", 2, false, "implicit midpoint on Gonzalez's discrete gradient: energy to the Newton tolerance, momenta to round-off on free bodies", |s, _| Box::new(EnergyMomentum::new(s.linear_solver.build(&s.solver), s.newton))),
    implicit("static", 0, true, "equilibrium under each time's loads (no inertia); gravity ramped if Newton fails", |s, c| Box::new(Static::new(s.static_solve, s.linear_solver.build(&s.solver), s.newton, c))),
];

/// Every method: the built-in ones and those a program registered.
pub static METHODS: Registry<MethodEntry> = Registry::new("integrator", BUILTIN);

crate::registry_handle! {
    /// An integration method, by the name scene files use.
    pub struct Method(MethodEntry) in METHODS;
}

impl Method {
    /// Formal order of accuracy with default settings.
    pub fn order(self) -> u32 {
        self.entry().order
    }

    /// Whether the method never solves a linear system (so a linear solver means nothing).
    pub fn is_explicit(self) -> bool {
        self.entry().explicit
    }

    /// Whether the method solves a nonlinear system by Newton (so Newton's iteration cap and
    /// tolerance can decide its result).
    pub fn uses_newton(self) -> bool {
        self.entry().newton
    }

    /// Whether the method chooses its own internal steps under `integrator.adaptive`'s
    /// tolerances (so `dt` is an output interval and the tolerance sets its accuracy).
    pub fn is_adaptive(self) -> bool {
        self.entry().adaptive
    }

    /// Whether the method solves sparse linear systems with the scene's linear solver.
    pub fn uses_linear_solver(self) -> bool {
        self.entry().linear_solver
    }
}

/// Register a method of a program's own under `entry.name`, for scenes and studies to use
/// like the built-in ones. Call it before loading scenes.
pub fn register_method(entry: MethodEntry) -> Result<Method, RegisterError> {
    METHODS.register(entry).map(Method)
}

/// The `[integrator]` section of a scene: the method and every knob it may read.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IntegratorSettings {
    /// The method. Default: backward Euler.
    pub method: Method,
    /// Linear solver of implicit methods (and of explicit ones for a consistent mass
    /// matrix, which is always factored by Cholesky). Default: Cholesky.
    pub linear_solver: LinearSolverKind,
    /// Newton and line search (every method that uses Newton).
    pub newton: NewtonSettings,
    /// Adaptive step control (adaptive-* methods and dopri5).
    pub adaptive: AdaptiveSettings,
    /// Settings of the linear solvers.
    pub solver: SolverSettings,
    /// β and γ of `newmark`.
    pub newmark: NewmarkSettings,
    /// ρ∞ of `generalized-alpha`.
    pub generalized_alpha: GeneralizedAlphaSettings,
    /// α of `hht-alpha`.
    pub hht: HhtSettings,
    /// Start-up of `bdf1`…`bdf6`.
    pub bdf: BdfSettings,
    /// Load stepping of `static`.
    #[serde(rename = "static")]
    pub static_solve: StaticSettings,
    /// Iterations, initialization and acceleration of `vbd`.
    pub vbd: VbdSettings,
    /// Iterations of `projective-dynamics`.
    pub projective_dynamics: ProjectiveDynamicsSettings,
    /// Substeps and iterations of `xpbd`.
    pub xpbd: XpbdSettings,
    /// A peer method's own settings (see [`super::peer`]); empty for softbench's methods.
    #[serde(skip_serializing_if = "PeerSettings::is_empty")]
    pub peer: PeerSettings,
}

impl Default for IntegratorSettings {
    fn default() -> Self {
        Self {
            method: Method::from_name("backward-euler").expect("a built-in method"),
            linear_solver: LinearSolverKind::cholesky(),
            newton: NewtonSettings::default(),
            adaptive: AdaptiveSettings::default(),
            solver: SolverSettings::default(),
            newmark: NewmarkSettings::default(),
            generalized_alpha: GeneralizedAlphaSettings::default(),
            hht: HhtSettings::default(),
            bdf: BdfSettings::default(),
            static_solve: StaticSettings::default(),
            vbd: VbdSettings::default(),
            projective_dynamics: ProjectiveDynamicsSettings::default(),
            xpbd: XpbdSettings::default(),
            peer: PeerSettings::default(),
        }
    }
}

impl IntegratorSettings {
    /// Check every field's range; the message names the field and the valid range.
    pub fn validate(&self) -> Result<(), String> {
        self.newton.validate()?;
        self.newmark.validate()?;
        self.generalized_alpha.validate()?;
        self.hht.validate()?;
        self.vbd.validate()?;
        self.projective_dynamics.validate()?;
        self.xpbd.validate()?;
        self.solver.cg.amg.validate()?;
        self.adaptive.validate()?;
        if self.static_solve.max_load_steps == 0 {
            return Err("static.max_load_steps must be >= 1".into());
        }
        Ok(())
    }

    /// These settings with the linear solvers running at `parallelism` (a run setting, never
    /// read from a scene file).
    pub fn with_parallelism(mut self, parallelism: crate::parallel::Parallelism) -> Self {
        self.solver.direct.parallelism = parallelism;
        self.solver.cg.parallelism = parallelism;
        self
    }

    /// Build the integrator these settings describe.
    pub fn build(&self) -> Box<dyn Integrator> {
        (self.method.entry().build)(self, None)
    }

    /// Build the integrator with a contact response inside its Newton loop (`contact`); `None`
    /// if the method has no such loop (see [`super::MethodEntry::constrained_contact`]).
    pub fn build_constrained(&self, contact: NewtonContact) -> Option<Box<dyn Integrator>> {
        let entry = self.method.entry();
        entry
            .constrained_contact
            .then(|| (entry.build)(self, Some(contact)))
    }
}
