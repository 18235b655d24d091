//! Choosing an integrator by name, with its settings: the `[integrator]` section of a scene.

use super::adaptive::{Adaptive, AdaptiveSettings};
use super::backward_euler::BackwardEuler;
use super::bdf2::Bdf2;
use super::implicit_midpoint::ImplicitMidpoint;
use super::linearly_implicit_euler::LinearlyImplicitEuler;
use super::newton::NewtonSettings;
use super::symplectic_euler::SymplecticEuler;
use super::{Integrator, dopri5, explicit_euler, midpoint, rk4};
use crate::solve::{LinearSolverKind, SolverSettings};
use std::fmt;
use std::str::FromStr;

/// The integration methods, by the names scene files use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "String", into = "String")]
pub enum Method {
    ExplicitEuler,
    SymplecticEuler,
    Midpoint,
    Rk4,
    AdaptiveExplicitEuler,
    AdaptiveSymplecticEuler,
    AdaptiveMidpoint,
    AdaptiveRk4,
    Dopri5,
    LinearlyImplicitEuler,
    BackwardEuler,
    ImplicitMidpoint,
    Bdf2,
}

impl Method {
    /// Every method, in the order `softbench list` shows them.
    pub const ALL: [Method; 13] = [
        Self::ExplicitEuler,
        Self::SymplecticEuler,
        Self::Midpoint,
        Self::Rk4,
        Self::AdaptiveExplicitEuler,
        Self::AdaptiveSymplecticEuler,
        Self::AdaptiveMidpoint,
        Self::AdaptiveRk4,
        Self::Dopri5,
        Self::LinearlyImplicitEuler,
        Self::BackwardEuler,
        Self::ImplicitMidpoint,
        Self::Bdf2,
    ];

    /// The name scene files use.
    pub fn name(self) -> &'static str {
        match self {
            Self::ExplicitEuler => "explicit-euler",
            Self::SymplecticEuler => "symplectic-euler",
            Self::Midpoint => "midpoint",
            Self::Rk4 => "rk4",
            Self::AdaptiveExplicitEuler => "adaptive-explicit-euler",
            Self::AdaptiveSymplecticEuler => "adaptive-symplectic-euler",
            Self::AdaptiveMidpoint => "adaptive-midpoint",
            Self::AdaptiveRk4 => "adaptive-rk4",
            Self::Dopri5 => "dopri5",
            Self::LinearlyImplicitEuler => "linearly-implicit-euler",
            Self::BackwardEuler => "backward-euler",
            Self::ImplicitMidpoint => "implicit-midpoint",
            Self::Bdf2 => "bdf2",
        }
    }

    /// Every name, for messages.
    pub fn names() -> Vec<&'static str> {
        Self::ALL.iter().map(|m| m.name()).collect()
    }

    /// One line on what the method is.
    pub fn description(self) -> &'static str {
        match self {
            Self::ExplicitEuler => "forward Euler, order 1; unstable for undamped oscillation",
            Self::SymplecticEuler => {
                "semi-implicit Euler, order 1, symplectic (bounded energy error)"
            }
            Self::Midpoint => "explicit midpoint (RK2), order 2",
            Self::Rk4 => "classic Runge-Kutta, order 4",
            Self::AdaptiveExplicitEuler => "explicit Euler with step-doubling error control",
            Self::AdaptiveSymplecticEuler => "symplectic Euler with step-doubling error control",
            Self::AdaptiveMidpoint => "explicit midpoint with step-doubling error control",
            Self::AdaptiveRk4 => "RK4 with step-doubling error control",
            Self::Dopri5 => "Dormand-Prince 5(4) with embedded error control",
            Self::LinearlyImplicitEuler => "one Newton step of backward Euler per step, order 1",
            Self::BackwardEuler => {
                "backward Euler by Newton with line search, order 1, dissipative"
            }
            Self::ImplicitMidpoint => "implicit midpoint by Newton, order 2, symplectic",
            Self::Bdf2 => "second-order backward differentiation by Newton, order 2",
        }
    }

    /// Whether the method never solves a linear system (so a linear solver means nothing).
    pub fn is_explicit(self) -> bool {
        !matches!(
            self,
            Self::LinearlyImplicitEuler | Self::BackwardEuler | Self::ImplicitMidpoint | Self::Bdf2
        )
    }

    /// Whether the method solves a nonlinear system by Newton (so Newton's iteration cap and
    /// tolerance can decide its result).
    pub fn uses_newton(self) -> bool {
        matches!(
            self,
            Self::BackwardEuler | Self::ImplicitMidpoint | Self::Bdf2
        )
    }

    /// Formal order of accuracy.
    pub fn order(self) -> u32 {
        match self {
            Self::ExplicitEuler
            | Self::SymplecticEuler
            | Self::AdaptiveExplicitEuler
            | Self::AdaptiveSymplecticEuler
            | Self::LinearlyImplicitEuler
            | Self::BackwardEuler => 1,
            Self::Midpoint | Self::AdaptiveMidpoint | Self::ImplicitMidpoint | Self::Bdf2 => 2,
            Self::Rk4 | Self::AdaptiveRk4 => 4,
            Self::Dopri5 => 5,
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An unknown method name; the message suggests the closest and lists the valid ones.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{}", crate::names::unknown_name_message("integrator", .0, &Method::names()))]
pub struct UnknownMethodError(pub String);

impl FromStr for Method {
    type Err = UnknownMethodError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| UnknownMethodError(s.to_owned()))
    }
}

impl TryFrom<String> for Method {
    type Error = UnknownMethodError;
    fn try_from(s: String) -> Result<Self, Self::Error> {
        s.parse()
    }
}

impl From<Method> for String {
    fn from(m: Method) -> String {
        m.name().to_owned()
    }
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
    /// Newton and line search (backward Euler, implicit midpoint, BDF2).
    pub newton: NewtonSettings,
    /// Adaptive step control (adaptive-* methods and dopri5).
    pub adaptive: AdaptiveSettings,
    /// Settings of the linear solvers.
    pub solver: SolverSettings,
}

impl Default for IntegratorSettings {
    fn default() -> Self {
        Self {
            method: Method::BackwardEuler,
            linear_solver: LinearSolverKind::Cholesky,
            newton: NewtonSettings::default(),
            adaptive: AdaptiveSettings::default(),
            solver: SolverSettings::default(),
        }
    }
}

impl IntegratorSettings {
    /// Build the integrator these settings describe.
    pub fn build(&self) -> Box<dyn Integrator> {
        let solver = || self.linear_solver.build(&self.solver);
        let adaptive = |name, inner: Box<dyn Integrator>| -> Box<dyn Integrator> {
            Box::new(Adaptive::step_doubling(name, inner, self.adaptive))
        };
        match self.method {
            Method::ExplicitEuler => Box::new(explicit_euler::explicit_euler()),
            Method::SymplecticEuler => Box::new(SymplecticEuler::new()),
            Method::Midpoint => Box::new(midpoint::midpoint()),
            Method::Rk4 => Box::new(rk4::rk4()),
            Method::AdaptiveExplicitEuler => adaptive(
                self.method.name(),
                Box::new(explicit_euler::explicit_euler()),
            ),
            Method::AdaptiveSymplecticEuler => {
                adaptive(self.method.name(), Box::new(SymplecticEuler::new()))
            }
            Method::AdaptiveMidpoint => {
                adaptive(self.method.name(), Box::new(midpoint::midpoint()))
            }
            Method::AdaptiveRk4 => adaptive(self.method.name(), Box::new(rk4::rk4())),
            Method::Dopri5 => Box::new(Adaptive::embedded(dopri5::dopri5(), self.adaptive)),
            Method::LinearlyImplicitEuler => Box::new(LinearlyImplicitEuler::new(
                solver(),
                self.newton.project_hessian,
            )),
            Method::BackwardEuler => Box::new(BackwardEuler::new(solver(), self.newton)),
            Method::ImplicitMidpoint => Box::new(ImplicitMidpoint::new(solver(), self.newton)),
            Method::Bdf2 => Box::new(Bdf2::new(solver(), self.newton)),
        }
    }
}
