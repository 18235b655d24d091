//! Lamé parameters from engineering constants, with validation.

/// An invalid material description: bad constants or an unknown model name.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MaterialError {
    #[error("{}", crate::names::unknown_name_message("material model", .0, &super::MaterialKind::names()))]
    UnknownModel(String),
    #[error("youngs_modulus must be positive and finite (got {0})")]
    YoungsModulus(f64),
    #[error(
        "poisson_ratio must lie in (-1, 0.5) (got {0}); 0.5 is incompressible and has no finite Lamé lambda"
    )]
    PoissonRatio(f64),
    #[error("{name} must be finite and non-negative (got {value})")]
    Parameter { name: &'static str, value: f64 },
}

impl crate::error_class::Classify for MaterialError {
    fn class(&self) -> crate::error_class::ErrorClass {
        crate::error_class::ErrorClass::BadInput
    }
}

/// Lamé parameters mu (shear modulus) and lambda, in Pa.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LameParameters {
    pub mu: f64,
    pub lambda: f64,
}

impl LameParameters {
    /// From Young's modulus `e` (Pa) and Poisson ratio `nu` in (-1, 0.5):
    /// mu = E / (2(1+nu)), lambda = E nu / ((1+nu)(1-2nu)).
    pub fn from_youngs_poisson(e: f64, nu: f64) -> Result<Self, MaterialError> {
        if !(e.is_finite() && e > 0.0) {
            return Err(MaterialError::YoungsModulus(e));
        }
        if !(nu.is_finite() && nu > -1.0 && nu < 0.5) {
            return Err(MaterialError::PoissonRatio(nu));
        }
        Ok(Self {
            mu: e / (2.0 * (1.0 + nu)),
            lambda: e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
        })
    }

    /// Directly from mu and lambda (both finite and non-negative).
    pub fn new(mu: f64, lambda: f64) -> Result<Self, MaterialError> {
        for (name, value) in [("mu", mu), ("lambda", lambda)] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(MaterialError::Parameter { name, value });
            }
        }
        Ok(Self { mu, lambda })
    }
}
