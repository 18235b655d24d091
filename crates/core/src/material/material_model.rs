//! The choice of material model, read from a name (a config string or a command-line flag).
//!
//! [`material_table!`] is the one table of material models: each line names a model's type
//! (its file in `material/`), the name scene files use and a one-line description. The
//! [`MaterialModel`] enum, [`MaterialKind`] (names, parsing, "did you mean", listing, facts)
//! and every dispatch over the models are generated from it.

use super::{
    ConstraintNeoHookean, Corotated, InvalidDeformation, LameParameters, Material, MaterialError,
    Matrix9, NeoHookean, StVenantKirchhoff, StableNeoHookean,
};
use nalgebra::Matrix3;

/// The table of material models, one line each: `Type = "name", "description";` (`Type`
/// implements [`Material`] and has `Type::new(LameParameters)`). Calls `$callback!` with
/// `($args) lines...`; the generated items below and the element loops' dispatch use it.
macro_rules! material_table {
    ($callback:ident ! ( $($args:tt)* )) => {
        $callback! { ($($args)*)
            /// `"neo-hookean"`: the course Neo-Hookean, [`NeoHookean`].
            NeoHookean = "neo-hookean",
                "the course Neo-Hookean, C (J^-2/3 I1 - 3) + D (J - 1)^2; undefined for J <= 0";
            /// `"stable-neo-hookean"`: [`StableNeoHookean`].
            StableNeoHookean = "stable-neo-hookean",
                "Stable Neo-Hookean (Smith et al. 2018); defined through inversion";
            /// `"stvk"`: [`StVenantKirchhoff`].
            StVenantKirchhoff = "stvk",
                "St. Venant-Kirchhoff; weak against compression and inversion";
            /// `"corotated"`: [`Corotated`].
            Corotated = "corotated",
                "corotated linear elasticity (polar decomposition); defined through inversion";
            /// `"xpbd-neo-hookean"`: [`ConstraintNeoHookean`], the energy `xpbd` converges to.
            ConstraintNeoHookean = "xpbd-neo-hookean",
                "mu/2 |F|^2 + lambda/2 (J - 1 - mu/lambda)^2: the energy of xpbd's constraints";
        }
    };
}
pub(crate) use material_table;

/// `match $model { MaterialModel::X($m) => $body, ... }` over every model of the table: the
/// element loops call a function generic over [`Material`] once per loop.
macro_rules! dispatch_material {
    (($model:expr, |$m:ident| $body:expr) $($(#[$doc:meta])* $v:ident = $name:literal, $desc:literal;)+) => {
        match $model {
            $($crate::material::MaterialModel::$v($m) => $body,)+
        }
    };
}
pub(crate) use dispatch_material;

/// Run `$body` with `$m` bound to the concrete material inside `$model` (a `MaterialModel` or
/// a reference to one).
macro_rules! with_material {
    ($model:expr, |$m:ident| $body:expr) => {{
        #[allow(unused_imports)]
        use $crate::material::dispatch_material;
        $crate::material::material_table!(dispatch_material!($model, |$m| $body))
    }};
}
pub(crate) use with_material;

/// What the code asks of a material model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MaterialFacts {
    /// [`Material::HANDLES_INVERSION`]: the energy is defined for inverted elements.
    pub handles_inversion: bool,
}

impl crate::registry::ListFacts for MaterialFacts {
    fn list(&self) -> Vec<crate::registry::Fact> {
        vec![(
            "inversion",
            if self.handles_inversion { "yes" } else { "no" }.to_owned(),
        )]
    }
}

macro_rules! define_materials {
    (() $($(#[$doc:meta])* $v:ident = $name:literal, $desc:literal;)+) => {
        /// One of the supported material models with its constants.
        ///
        /// This is the place to choose a model once per element loop: `match` on it and call a
        /// function generic over [`Material`], so the kernels inside the loop are monomorphized
        /// and inlined. It deliberately does not implement [`Material`]:
        ///
        /// ```
        /// # use softbench_core::material::{LameParameters, Material, MaterialModel};
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
            $($(#[$doc])* $v($v),)+
        }

        crate::named_enum! {
            /// A material model by name (`model` in `[material]`), without its constants.
            pub enum MaterialKind: "material model", UnknownMaterialKind, MaterialFacts {
                $($(#[$doc])* $v = $name, $desc,
                    MaterialFacts { handles_inversion: <$v as Material>::HANDLES_INVERSION },)+
            }
        }

        impl MaterialKind {
            /// The model of this kind from Lamé parameters, with each model's own mapping (see
            /// the model's `new`).
            pub fn build(self, lame: LameParameters) -> MaterialModel {
                match self {
                    $(Self::$v => MaterialModel::$v($v::new(lame)),)+
                }
            }
        }

        impl MaterialModel {
            /// The accepted names, in table order.
            pub const NAMES: [&'static str; { [$($name),+].len() }] = [$($name),+];

            /// The kind of model (its name, description and facts).
            pub fn kind(&self) -> MaterialKind {
                match self {
                    $(Self::$v(_) => MaterialKind::$v,)+
                }
            }
        }
    };
}

material_table!(define_materials!());

impl MaterialModel {
    /// The model called `name` (a [`MaterialKind`] name, exactly), built from Lamé parameters
    /// with each model's own mapping (see the model's `new`). An unknown name is
    /// [`MaterialError::UnknownModel`], whose message lists the valid names.
    pub fn from_name(name: &str, lame: LameParameters) -> Result<Self, MaterialError> {
        let kind: MaterialKind = name
            .parse()
            .map_err(|_| MaterialError::UnknownModel(name.to_owned()))?;
        Ok(kind.build(lame))
    }

    /// The model's name, as accepted by [`Self::from_name`].
    pub fn name(&self) -> &'static str {
        self.kind().name()
    }

    /// [`Material::lame`] of the model: the Lamé parameters it was built from.
    pub fn lame(&self) -> LameParameters {
        with_material!(self, |m| m.lame())
    }

    /// [`Material::HANDLES_INVERSION`] of the model.
    pub fn handles_inversion(&self) -> bool {
        self.kind().facts().handles_inversion
    }

    /// psi(F), dispatching per call: for tests and one-off evaluations, not element loops.
    pub fn energy_density(&self, f: &Matrix3<f64>) -> Result<f64, InvalidDeformation> {
        with_material!(self, |m| m.energy_density(f))
    }

    /// P(F), dispatching per call: for tests and one-off evaluations, not element loops.
    pub fn first_piola(&self, f: &Matrix3<f64>) -> Result<Matrix3<f64>, InvalidDeformation> {
        with_material!(self, |m| m.first_piola(f))
    }

    /// dP/dF, dispatching per call: for tests and one-off evaluations, not element loops.
    pub fn first_piola_derivative(&self, f: &Matrix3<f64>) -> Result<Matrix9, InvalidDeformation> {
        with_material!(self, |m| m.first_piola_derivative(f))
    }

    /// [`Material::vertex_terms`], dispatching per call: for tests and one-off evaluations.
    pub fn vertex_terms(
        &self,
        f: &Matrix3<f64>,
        n: &nalgebra::Vector3<f64>,
    ) -> Result<(nalgebra::Vector3<f64>, Matrix3<f64>), InvalidDeformation> {
        with_material!(self, |m| m.vertex_terms(f, n))
    }
}
