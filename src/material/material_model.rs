//! The choice of material model, read from a name (a config string or a command-line flag).

use super::{
    ConstraintNeoHookean, Corotated, InvalidDeformation, LameParameters, Material, MaterialError,
    Matrix9, NeoHookean, StVenantKirchhoff, StableNeoHookean,
};
use nalgebra::Matrix3;

/// One of the supported material models with its constants.
///
/// This is the place to choose a model once per element loop: `match` on it and call a
/// function generic over [`Material`], so the kernels inside the loop are monomorphized and
/// inlined. It deliberately does not implement [`Material`]:
///
/// ```
/// # use softbench::material::{LameParameters, Material, MaterialModel};
/// # use nalgebra::Matrix3;
/// fn total_energy<M: Material>(m: M, fs: &[Matrix3<f64>]) -> f64 {
///     fs.iter().map(|f| m.energy_density(f).unwrap()).sum()
/// }
/// let lame = LameParameters::from_youngs_poisson(1e5, 0.3).unwrap();
/// let model = MaterialModel::from_name("stable-neo-hookean", lame).unwrap();
/// let fs = [Matrix3::identity(); 4];
/// let e = match model {
///     MaterialModel::NeoHookean(m) => total_energy(m, &fs),
///     MaterialModel::StableNeoHookean(m) => total_energy(m, &fs),
///     MaterialModel::StVenantKirchhoff(m) => total_energy(m, &fs),
///     MaterialModel::Corotated(m) => total_energy(m, &fs),
///     MaterialModel::ConstraintNeoHookean(m) => total_energy(m, &fs),
/// };
/// assert!(e.abs() < 1e-9);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MaterialModel {
    /// `"neo-hookean"`: the course Neo-Hookean, [`NeoHookean`].
    NeoHookean(NeoHookean),
    /// `"stable-neo-hookean"`: [`StableNeoHookean`].
    StableNeoHookean(StableNeoHookean),
    /// `"stvk"`: [`StVenantKirchhoff`].
    StVenantKirchhoff(StVenantKirchhoff),
    /// `"corotated"`: [`Corotated`].
    Corotated(Corotated),
    /// `"xpbd-neo-hookean"`: [`ConstraintNeoHookean`], the energy `xpbd` converges to.
    ConstraintNeoHookean(ConstraintNeoHookean),
}

impl MaterialModel {
    /// The accepted names, in the order of the variants.
    pub const NAMES: [&'static str; 5] = [
        "neo-hookean",
        "stable-neo-hookean",
        "stvk",
        "corotated",
        "xpbd-neo-hookean",
    ];

    /// The model called `name` (one of [`Self::NAMES`], exactly), built from Lamé parameters
    /// with each model's own mapping (see the model's `new`). An unknown name is
    /// [`MaterialError::UnknownModel`], whose message lists the valid names.
    pub fn from_name(name: &str, lame: LameParameters) -> Result<Self, MaterialError> {
        Ok(match name {
            "neo-hookean" => Self::NeoHookean(NeoHookean::new(lame)),
            "stable-neo-hookean" => Self::StableNeoHookean(StableNeoHookean::new(lame)),
            "stvk" => Self::StVenantKirchhoff(StVenantKirchhoff::new(lame)),
            "corotated" => Self::Corotated(Corotated::new(lame)),
            "xpbd-neo-hookean" => Self::ConstraintNeoHookean(ConstraintNeoHookean::new(lame)),
            _ => return Err(MaterialError::UnknownModel(name.to_owned())),
        })
    }

    /// One line on the model named `name` (for `softbench list`); empty for an unknown name.
    pub fn description_of(name: &str) -> &'static str {
        match name {
            "neo-hookean" => {
                "the course Neo-Hookean, C (J^-2/3 I1 - 3) + D (J - 1)^2; undefined for J <= 0"
            }
            "stable-neo-hookean" => {
                "Stable Neo-Hookean (Smith et al. 2018); defined through inversion"
            }
            "stvk" => "St. Venant-Kirchhoff; weak against compression and inversion",
            "corotated" => {
                "corotated linear elasticity (polar decomposition); defined through inversion"
            }
            "xpbd-neo-hookean" => {
                "mu/2 |F|^2 + lambda/2 (J - 1 - mu/lambda)^2: the energy of xpbd's constraints"
            }
            _ => "",
        }
    }

    /// The model's name, as accepted by [`Self::from_name`].
    pub fn name(&self) -> &'static str {
        match self {
            Self::NeoHookean(_) => Self::NAMES[0],
            Self::StableNeoHookean(_) => Self::NAMES[1],
            Self::StVenantKirchhoff(_) => Self::NAMES[2],
            Self::Corotated(_) => Self::NAMES[3],
            Self::ConstraintNeoHookean(_) => Self::NAMES[4],
        }
    }

    /// [`Material::HANDLES_INVERSION`] of the model.
    pub fn handles_inversion(&self) -> bool {
        match self {
            Self::NeoHookean(_) => NeoHookean::HANDLES_INVERSION,
            Self::StableNeoHookean(_) => StableNeoHookean::HANDLES_INVERSION,
            Self::StVenantKirchhoff(_) => StVenantKirchhoff::HANDLES_INVERSION,
            Self::Corotated(_) => Corotated::HANDLES_INVERSION,
            Self::ConstraintNeoHookean(_) => ConstraintNeoHookean::HANDLES_INVERSION,
        }
    }

    /// psi(F), dispatching per call: for tests and one-off evaluations, not element loops.
    pub fn energy_density(&self, f: &Matrix3<f64>) -> Result<f64, InvalidDeformation> {
        match self {
            Self::NeoHookean(m) => m.energy_density(f),
            Self::StableNeoHookean(m) => m.energy_density(f),
            Self::StVenantKirchhoff(m) => m.energy_density(f),
            Self::Corotated(m) => m.energy_density(f),
            Self::ConstraintNeoHookean(m) => m.energy_density(f),
        }
    }

    /// P(F), dispatching per call: for tests and one-off evaluations, not element loops.
    pub fn first_piola(&self, f: &Matrix3<f64>) -> Result<Matrix3<f64>, InvalidDeformation> {
        match self {
            Self::NeoHookean(m) => m.first_piola(f),
            Self::StableNeoHookean(m) => m.first_piola(f),
            Self::StVenantKirchhoff(m) => m.first_piola(f),
            Self::Corotated(m) => m.first_piola(f),
            Self::ConstraintNeoHookean(m) => m.first_piola(f),
        }
    }

    /// dP/dF, dispatching per call: for tests and one-off evaluations, not element loops.
    pub fn first_piola_derivative(&self, f: &Matrix3<f64>) -> Result<Matrix9, InvalidDeformation> {
        match self {
            Self::NeoHookean(m) => m.first_piola_derivative(f),
            Self::StableNeoHookean(m) => m.first_piola_derivative(f),
            Self::StVenantKirchhoff(m) => m.first_piola_derivative(f),
            Self::Corotated(m) => m.first_piola_derivative(f),
            Self::ConstraintNeoHookean(m) => m.first_piola_derivative(f),
        }
    }
}
