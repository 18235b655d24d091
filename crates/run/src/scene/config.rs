//! The scene file schema (TOML): what body, which material, what is fixed, which forces,
//! which integrator, how long. Unknown keys are errors that list the valid ones.

use crate::scene::springs::{DragConfig, JelloConfig, SpringsConfig};
use softbench_core::contact::{ContactConfig, ObstacleConfig};
use softbench_core::integrate::IntegratorSettings;
use softbench_core::model::{MassKind, Side};

/// A scene: everything `softbench simulate` needs.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneConfig {
    /// A name for reports (default: the file name).
    #[serde(default)]
    pub name: Option<String>,
    /// The tet mesh (absent when the body is a `[jello]`).
    #[serde(default)]
    pub mesh: Option<MeshConfig>,
    /// Springs along the mesh's tet edges (a mass-spring body).
    #[serde(default)]
    pub springs: Option<SpringsConfig>,
    /// A generated mass-spring body instead of `[mesh]`.
    #[serde(default)]
    pub jello: Option<JelloConfig>,
    /// Scripted drags (`[[drag]]`).
    #[serde(default)]
    pub drag: Vec<DragConfig>,
    /// The elastic material of the tets.
    #[serde(default)]
    pub material: Option<MaterialConfig>,
    /// Fixed vertices.
    #[serde(default)]
    pub fixed: FixedConfig,
    /// External forces.
    #[serde(default)]
    pub forces: ForcesConfig,
    /// Damping (none by default, so energy studies stay conservative).
    #[serde(default)]
    pub damping: DampingConfig,
    /// The time integrator and its solvers.
    #[serde(default)]
    pub integrator: IntegratorSettings,
    /// Time step, length and output sampling.
    pub run: RunConfig,
    /// A display mesh that OBJ frames show instead of the tet mesh's boundary.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub display: Option<DisplayConfig>,
    /// Obstacles (`[[obstacles]]`); none means no contact code runs.
    #[serde(default)]
    pub obstacles: Vec<ObstacleConfig>,
    /// How contact with the obstacles is resolved.
    #[serde(default)]
    pub contact: ContactConfig,
    /// The initial state (default: at rest).
    #[serde(default)]
    pub initial: InitialConfig,
    /// What the benchmark suite needs to judge runs of this scene (strata, accuracy,
    /// reference); `simulate` ignores it. Default: none (the scene is no suite problem).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub problem: Option<super::problem::ProblemConfig>,
}

/// `[initial]`: a deformed and moving start instead of rest, for studies of free bodies.
/// Applied to the free vertices about the centroid `c` of the rest positions:
/// `x = c + R_twist (stretch (X - c))`, `v = velocity + angular_velocity x (X - c)`, where
/// `R_twist` turns a vertex about the line through `c` along `twist.axis` by
/// `twist.rate (X - c)_axis` radians. A negative stretch factor mirrors the body along that
/// axis, which inverts every element (an inverted start).
/// Or `from = "frame.vtu"`: the positions, `velocity` and time of an exported VTU frame of the
/// same mesh (looked up like the mesh file).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialConfig {
    /// A VTU frame (written by `--export vtu`) to start from, instead of the fields below.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub from: Option<String>,
    /// Scale factor per axis (default 1: undeformed); nonzero, negative mirrors.
    #[serde(default)]
    pub stretch: Option<[f64; 3]>,
    /// A twist about an axis through the centroid (default none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub twist: Option<TwistConfig>,
    /// Rigid velocity (m/s).
    #[serde(default)]
    pub velocity: [f64; 3],
    /// Rigid angular velocity about the centroid (rad/s).
    #[serde(default)]
    pub angular_velocity: [f64; 3],
}

/// `[mesh]`: a file (found next to the scene file, then in `SOFTBENCH_DATA`) or a generator.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshConfig {
    /// Mesh file: MEDIT or plain `.mesh`, TetGen `.node`/`.ele`.
    #[serde(default)]
    pub file: Option<String>,
    /// A generated mesh instead of a file.
    #[serde(default)]
    pub generate: Option<GenerateConfig>,
    /// Swap two vertices of inverted tets instead of refusing the mesh.
    #[serde(default)]
    pub reorient: bool,
}

/// `mesh.generate`: `{ box = [nx, ny, nz], size = [sx, sy, sz] }` (6 tets per cell, min
/// corner at `origin`, default 0) or `{ ball = n, radius = r }` (48 n^3 tets, centred at
/// `origin`).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GenerateConfig {
    /// Cells per axis of a box.
    #[serde(default, rename = "box")]
    pub box_cells: Option<[usize; 3]>,
    /// Box size (m).
    #[serde(default)]
    pub size: Option<[f64; 3]>,
    /// Resolution of a ball.
    #[serde(default)]
    pub ball: Option<usize>,
    /// Ball radius (m).
    #[serde(default)]
    pub radius: Option<f64>,
    /// Translation of the generated mesh (m).
    #[serde(default)]
    pub origin: Option<[f64; 3]>,
}

/// `[material]`: model, elastic constants (E and nu, or mu and lambda, or for the course
/// Neo-Hookean C and D), density and mass discretization.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialConfig {
    /// `neo-hookean`, `stable-neo-hookean`, `stvk` or `corotated`.
    #[serde(default = "default_model")]
    pub model: String,
    /// Young's modulus (Pa).
    #[serde(default)]
    pub youngs_modulus: Option<f64>,
    /// Poisson ratio, in (-1, 0.5).
    #[serde(default)]
    pub poisson_ratio: Option<f64>,
    /// Lamé mu (Pa), instead of E and nu.
    #[serde(default)]
    pub mu: Option<f64>,
    /// Lamé lambda (Pa), instead of E and nu.
    #[serde(default)]
    pub lambda: Option<f64>,
    /// Course Neo-Hookean C (Pa), with `d`, instead of E and nu.
    #[serde(default)]
    pub c: Option<f64>,
    /// Course Neo-Hookean D (Pa), with `c`.
    #[serde(default)]
    pub d: Option<f64>,
    /// Density (kg/m^3).
    pub density: f64,
    /// `consistent` or `lumped`.
    #[serde(default)]
    pub mass: MassKind,
}

fn default_model() -> String {
    softbench_core::material::MaterialKind::NeoHookean
        .name()
        .into()
}

/// `[fixed]`: the union of explicit vertex indices, an axis rule and a box.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FixedConfig {
    /// 0-based vertex indices.
    #[serde(default)]
    pub indices: Vec<usize>,
    /// The course rule: vertices within `tolerance` of the extreme coordinate along `axis`.
    #[serde(default)]
    pub rule: Option<RuleConfig>,
    /// Vertices inside an axis-aligned box.
    #[serde(default, rename = "box")]
    pub fixed_box: Option<BoxConfig>,
}

/// An axis rule, e.g. `{ axis = "y", side = "min", tolerance = 0.1 }`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RuleConfig {
    pub axis: Axis,
    #[serde(default = "default_side")]
    pub side: Side,
    pub tolerance: f64,
}

fn default_side() -> Side {
    Side::Min
}

/// `initial.twist`: `{ axis = "x", rate = 3.0 }`, a turn of `rate` radians per metre along
/// `axis` about the line through the rest centroid along it.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TwistConfig {
    pub axis: Axis,
    /// Radians per metre along the axis.
    pub rate: f64,
}

/// A coordinate axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    /// 0, 1 or 2.
    pub fn index(self) -> usize {
        self as usize
    }
}

/// An axis-aligned box `{ min = [..], max = [..] }`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxConfig {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

/// `[forces]`.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForcesConfig {
    /// Gravitational acceleration (m/s^2). Default: none.
    #[serde(default)]
    pub gravity: [f64; 3],
}

/// `[run]`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    /// Time step (s), > 0.
    pub dt: f64,
    /// Number of steps, >= 1.
    pub steps: usize,
    /// Write a row every this many steps (the first and last are always written). Default 1.
    #[serde(default = "one")]
    pub sample_every: usize,
    /// A run is a blow-up when the energy it gained beyond the work done on the body
    /// (time-dependent potentials, less damping) passes this many times the energy the body
    /// holds or exchanges while still growing (a level alone decides nothing); or when that
    /// gain grew exponentially over the run's last half (see `run::balance`). 0 turns the
    /// check off. Default 1.
    #[serde(default = "default_energy_limit")]
    pub energy_limit: f64,
    /// A cost budget: the run stops before its horizon (`horizon-not-reached`, cause
    /// `budget`) after the first step that leaves its cost above any of these. A run that
    /// reaches its horizon is never stopped by it; whether it stayed within the budget is the
    /// reader's test (a benchmark suite's success needs it). Default: none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub budget: Option<CostBudget>,
}

/// `run.budget`: the most a run may spend, in wall time and in counts that do not depend on
/// the machine. Every field is optional; an absent one does not limit.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CostBudget {
    /// Wall time of the steps (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wall_seconds: Option<f64>,
    /// Force (gradient) plus Hessian evaluations: the hardware-independent cost that
    /// work-precision studies and profiles report.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub evaluations: Option<f64>,
    /// Sparse factorizations.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub factorizations: Option<f64>,
    /// Iterations of iterative linear solvers (CG).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub linear_iterations: Option<f64>,
}

impl CostBudget {
    /// The budget's fields as (key, limit), the absent ones left out.
    pub fn limits(&self) -> impl Iterator<Item = (&'static str, f64)> {
        [
            ("wall_seconds", self.wall_seconds),
            ("evaluations", self.evaluations),
            ("factorizations", self.factorizations),
            ("linear_iterations", self.linear_iterations),
        ]
        .into_iter()
        .filter_map(|(k, v)| v.map(|v| (k, v)))
    }

    /// The first limit that `spent` (per key, as [`CostBudget::limits`] names them) passes,
    /// with what was spent.
    pub fn exceeded(&self, spent: impl Fn(&str) -> f64) -> Option<(&'static str, f64, f64)> {
        self.limits()
            .map(|(key, limit)| (key, limit, spent(key)))
            .find(|(_, limit, used)| used > limit)
    }
}

fn one() -> usize {
    1
}

fn default_energy_limit() -> f64 {
    1.0
}

/// `[damping]`: `rayleigh = { alpha = .., beta = .. }` (D = alpha M + beta K) and/or
/// `strain_rate = { phi = .., psi = .. }` (viscous stress on the Green strain rate, Pa s).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DampingConfig {
    #[serde(default)]
    pub rayleigh: Option<RayleighConfig>,
    #[serde(default)]
    pub strain_rate: Option<StrainRateConfig>,
}

/// Rayleigh damping coefficients.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RayleighConfig {
    /// Mass-proportional coefficient (1/s).
    #[serde(default)]
    pub alpha: f64,
    /// Stiffness-proportional coefficient (s).
    #[serde(default)]
    pub beta: f64,
}

/// Strain-rate viscosity (the Brown course's phi and psi).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StrainRateConfig {
    pub phi: f64,
    pub psi: f64,
}

impl DampingConfig {
    /// The model's damping settings.
    pub fn to_model(&self) -> softbench_core::model::Damping {
        softbench_core::model::Damping {
            rayleigh: self.rayleigh.map(|r| (r.alpha, r.beta)),
            strain_rate: self.strain_rate.map(|s| (s.phi, s.psi)),
        }
    }
}

/// `[display]`: the display mesh file (a triangle surface that follows the body in exported
/// frames; `export::load_display` reads it).
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DisplayConfig {
    /// A triangle surface (OBJ), in the same frame and units as the tet mesh at rest.
    pub file: String,
}
