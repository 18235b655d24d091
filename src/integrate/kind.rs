//! The `[integrator]` section of a scene: the method and every knob it may read.

use super::bdf::BdfSettings;
use super::methods::Method;
use super::newmark::{GeneralizedAlphaSettings, HhtSettings, NewmarkSettings};
use super::newton::{NewtonSettings, StepConstraints};
use super::projective_dynamics::ProjectiveDynamicsSettings;
use super::static_equilibrium::StaticSettings;
use super::vbd::VbdSettings;
use super::xpbd::XpbdSettings;
use super::{AdaptiveSettings, Integrator};
use crate::solve::{LinearSolverKind, SolverSettings};

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
}

impl Default for IntegratorSettings {
    fn default() -> Self {
        Self {
            method: Method::from_name("backward-euler").expect("a built-in method"),
            linear_solver: LinearSolverKind::Cholesky,
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
        if self.static_solve.max_load_steps == 0 {
            return Err("static.max_load_steps must be >= 1".into());
        }
        Ok(())
    }

    /// Build the integrator these settings describe.
    pub fn build(&self) -> Box<dyn Integrator> {
        (self.method.entry().build)(self, None)
    }

    /// Build the integrator with every Newton iterate kept feasible for `constraints`; `None`
    /// if the method cannot take constraints (see [`super::MethodEntry::constrained_contact`]).
    pub fn build_constrained(
        &self,
        constraints: Box<dyn StepConstraints>,
    ) -> Option<Box<dyn Integrator>> {
        let entry = self.method.entry();
        entry
            .constrained_contact
            .then(|| (entry.build)(self, Some(constraints)))
    }
}
