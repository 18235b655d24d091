//! `[contact.ipc]`: the settings of incremental potential contact, with their defaults and
//! validation.
//!
//! ```toml
//! [contact]
//! response = "ipc"
//! [contact.ipc]
//! dhat = 1e-3          # barrier activation distance d̂ (m)
//! barrier = "clamped-log"   # or "distance-log"
//! kappa = "auto"       # or a number (J): a fixed, declared barrier stiffness
//! self_contact = true
//! mu = 0.3             # friction coefficient (0: frictionless)
//! epsilon_v = 1e-3     # slip speed below which friction is mollified (m/s)
//! friction_iterations = 1
//! min_separation = 0.0 # CCD's minimum separation ξ (m)
//! ```

use super::barrier::BarrierKind;

/// The barrier stiffness κ: adaptive (IPC's rule) or fixed.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Stiffness {
    /// IPC's adaptive κ (see the module docs of [`super`]).
    #[default]
    Auto,
    /// A fixed κ (J).
    Fixed(f64),
}

impl serde::Serialize for Stiffness {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Self::Auto => s.serialize_str("auto"),
            Self::Fixed(k) => s.serialize_f64(*k),
        }
    }
}

impl<'de> serde::Deserialize<'de> for Stiffness {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(serde::Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Name(String),
            Value(f64),
        }
        match Raw::deserialize(d)? {
            Raw::Name(n) if n == "auto" => Ok(Self::Auto),
            Raw::Name(n) => Err(serde::de::Error::custom(format!(
                "kappa must be \"auto\" or a number (J), got \"{n}\""
            ))),
            Raw::Value(v) => Ok(Self::Fixed(v)),
        }
    }
}

/// `[contact.ipc]` (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IpcConfig {
    /// Barrier activation distance d̂ (m), > 0. Default 1e-3.
    pub dhat: f64,
    /// The barrier function. Default `clamped-log`.
    pub barrier: BarrierKind,
    /// The barrier stiffness: `"auto"` (default) or a fixed value (J).
    pub kappa: Stiffness,
    /// Contact between parts of the body's own surface (and between disconnected pieces of
    /// one mesh). Default true.
    pub self_contact: bool,
    /// Friction coefficient μ ≥ 0 (0: frictionless). Default 0.
    pub mu: f64,
    /// Slip speed ε_v (m/s) below which friction is smoothly static, > 0. Default 1e-3.
    pub epsilon_v: f64,
    /// Solves per step with the friction's normal forces and bases lagged at the previous
    /// solve's result, ≥ 1. Default 1 (lagged at the start of the step).
    pub friction_iterations: u32,
    /// Minimum separation ξ (m) continuous collision detection keeps, in [0, d̂). Default 0.
    pub min_separation: f64,
}

impl Default for IpcConfig {
    fn default() -> Self {
        Self {
            dhat: 1e-3,
            barrier: BarrierKind::ClampedLog,
            kappa: Stiffness::Auto,
            self_contact: true,
            mu: 0.0,
            epsilon_v: 1e-3,
            friction_iterations: 1,
            min_separation: 0.0,
        }
    }
}

impl IpcConfig {
    /// Check ranges: `Err((key, message))` for the first bad value.
    pub fn validate(&self) -> Result<(), (String, String)> {
        let bad = |key: &str, message: String| Err((format!("contact.ipc.{key}"), message));
        if !(self.dhat.is_finite() && self.dhat > 0.0) {
            return bad("dhat", format!("must be > 0 (m; got {})", self.dhat));
        }
        if let Stiffness::Fixed(k) = self.kappa
            && !(k.is_finite() && k > 0.0)
        {
            return bad("kappa", format!("must be \"auto\" or > 0 (J; got {k})"));
        }
        if !(self.mu.is_finite() && self.mu >= 0.0) {
            return bad("mu", format!("must be >= 0 (got {})", self.mu));
        }
        if !(self.epsilon_v.is_finite() && self.epsilon_v > 0.0) {
            return bad(
                "epsilon_v",
                format!("must be > 0 (m/s; got {})", self.epsilon_v),
            );
        }
        if self.friction_iterations == 0 {
            return bad("friction_iterations", "must be >= 1".into());
        }
        if !(self.min_separation.is_finite()
            && self.min_separation >= 0.0
            && self.min_separation < self.dhat)
        {
            return bad(
                "min_separation",
                format!(
                    "must lie in [0, dhat = {}) (m; got {})",
                    self.dhat, self.min_separation
                ),
            );
        }
        Ok(())
    }
}
