//! The acceleration family: [`Acceleration`], one table line per entry (name, description,
//! builder), and the settings every entry is built from.

use super::accelerate::Accelerate;
use super::anderson::Anderson;
use super::chebyshev::Chebyshev;

/// What an acceleration needs from its section's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AccelerationSettings {
    /// Which one.
    pub acceleration: Acceleration,
    /// Chebyshev's spectral radius ρ in [0, 1); 0 = estimate it per step.
    pub chebyshev_rho: f64,
    /// Anderson's history m (differences kept), >= 1.
    pub anderson_history: u32,
}

/// Largest accepted Anderson history.
pub const MAX_ANDERSON_HISTORY: u32 = 50;

impl AccelerationSettings {
    /// Check the fields' ranges; `section` names the settings table in messages
    /// (`vbd`, `projective_dynamics`).
    pub fn validate(&self, section: &str) -> Result<(), String> {
        if !(0.0..1.0).contains(&self.chebyshev_rho) {
            return Err(format!(
                "{section}.chebyshev_rho must be in [0, 1) (0 = estimate it each step), got {}",
                self.chebyshev_rho
            ));
        }
        if self.chebyshev_rho != 0.0 && self.acceleration != Acceleration::Chebyshev {
            return Err(format!(
                "{section}.chebyshev_rho = {} is set but {section}.acceleration is `{}`: \
                 chebyshev_rho no longer turns Chebyshev acceleration on by itself; set \
                 {section}.acceleration = \"chebyshev\" (valid: {})",
                self.chebyshev_rho,
                self.acceleration,
                Acceleration::names().join(", ")
            ));
        }
        if !(1..=MAX_ANDERSON_HISTORY).contains(&self.anderson_history) {
            return Err(format!(
                "{section}.anderson_history must be in 1..={MAX_ANDERSON_HISTORY}, got {}",
                self.anderson_history
            ));
        }
        Ok(())
    }

    /// The accelerator these settings ask for (`None` for `none`).
    pub fn build(&self) -> Option<Box<dyn Accelerate>> {
        (self.acceleration.facts().build)(self)
    }
}

/// What the code asks of an acceleration.
#[derive(Clone, Copy)]
pub struct AccelerationFacts {
    /// Its accelerator (`None`: the plain iteration).
    pub build: fn(&AccelerationSettings) -> Option<Box<dyn Accelerate>>,
    /// It evaluates the incremental potential (a safeguard), which costs energy evaluations.
    pub uses_energy: bool,
}

impl crate::registry::ListFacts for AccelerationFacts {
    fn list(&self) -> Vec<crate::registry::Fact> {
        let safeguard = if self.uses_energy { "energy" } else { "none" };
        vec![("safeguard", safeguard.to_owned())]
    }
}

crate::named_enum! {
    /// How a local solver's iterations are accelerated (`acceleration` in `[integrator.vbd]`
    /// and `[integrator.projective_dynamics]`).
    pub enum Acceleration: "acceleration", UnknownAcceleration, AccelerationFacts {
        /// The plain iteration.
        None = "none", "plain iterations, no acceleration",
            AccelerationFacts { build: |_| None, uses_energy: false },
        /// Chebyshev semi-iteration (Wang 2015), ρ given (`chebyshev_rho`) or estimated.
        Chebyshev = "chebyshev",
            "Chebyshev semi-iteration (Wang 2015); rho = chebyshev_rho, or estimated when 0",
            AccelerationFacts {
                build: |s| Some(Box::new(Chebyshev::new(s.chebyshev_rho))),
                uses_energy: false,
            },
        /// Type-II Anderson acceleration with history `anderson_history`, energy-safeguarded.
        Anderson = "anderson",
            "type-II Anderson, history anderson_history; falls back when the energy rises",
            AccelerationFacts {
                build: |s| Some(Box::new(Anderson::new(s.anderson_history))),
                uses_energy: true,
            },
    }
}

impl std::fmt::Debug for AccelerationFacts {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AccelerationFacts")
            .field("uses_energy", &self.uses_energy)
            .finish()
    }
}

// named_enum! fixes the derive list, so the default is written out.
#[allow(clippy::derivable_impls)]
impl Default for Acceleration {
    fn default() -> Self {
        Self::None
    }
}
