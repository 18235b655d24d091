//! Scenes: a TOML file plus `--set` overrides becomes a validated [`SceneConfig`], which
//! [`build`] turns into a [`Scene`]: the model, its initial state and the run settings.
//!
//! Errors name the file and, where the TOML parser knows it, the line; semantic errors name
//! the key (`run.dt`, `material.poisson_ratio`) and what would be valid.

mod budget;
mod config;
mod fixed;
mod overrides;
mod peer;
mod problem;
mod springs;

pub use budget::{MAX_DENSITY, MAX_GRAVITY, MAX_LENGTH};
pub use config::{
    Axis, BoxConfig, CostBudget, DampingConfig, DisplayConfig, FixedConfig, ForcesConfig,
    GenerateConfig, InitialConfig, MaterialConfig, MeshConfig, RayleighConfig, RuleConfig,
    RunConfig, SceneConfig, StrainRateConfig, TwistConfig,
};
pub use overrides::{OverrideError, apply as apply_override, set_value};
pub use problem::{DIFFICULTIES, IndependentSolution, ProblemConfig, ProblemReference};
pub use springs::{DragConfig, JelloConfig, JelloShape, KindTable, SpringsConfig, WaypointConfig};

use crate::data::{DataError, DataPaths};
use nalgebra::Vector3;
use softbench_core::contact::{Contact, ContactResponse, ContactSetup, ipc::MeshObstacle};
use softbench_core::integrate::{Integrator, State};
use softbench_core::material::{
    LameParameters, MaterialError, MaterialKind, MaterialModel, NeoHookean,
};
use softbench_core::mesh::{MeshError, TetMesh, generate};
use softbench_core::model::{InvertedTets, MassKind, Model, ModelError, ModelSpec};
use softbench_core::parallel::Parallelism;
use std::path::{Path, PathBuf};

/// Why a scene could not be loaded or built.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{path}: cannot read: {error}")]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    /// Malformed TOML, an unknown key or a wrong type (the message has line and column).
    #[error("{path}: {message}")]
    Parse { path: PathBuf, message: String },
    /// A value out of its valid range.
    #[error("{path}: {key}: {}", softbench_core::quote::clip_message(.message))]
    Invalid {
        path: PathBuf,
        key: String,
        message: String,
    },
    #[error(transparent)]
    Override(#[from] OverrideError),
    #[error("{path}: mesh.file: {error}")]
    Data { path: PathBuf, error: DataError },
    /// The `[initial] from` frame is not found.
    #[error("{path}: initial.from: {error}")]
    InitialData { path: PathBuf, error: DataError },
    #[error("{path}: {error}")]
    Mesh { path: PathBuf, error: MeshError },
    #[error("{path}: material: {error}")]
    Material { path: PathBuf, error: MaterialError },
    #[error("{path}: {error}")]
    Model { path: PathBuf, error: ModelError },
}

impl softbench_core::error_class::Classify for SceneError {
    /// Everything wrong with a scene is found before it runs, and is the scene's.
    fn class(&self) -> softbench_core::error_class::ErrorClass {
        softbench_core::error_class::ErrorClass::BadInput
    }
}

/// A scene file read and validated, with where it came from.
#[derive(Clone, Debug)]
pub struct LoadedScene {
    /// The scene file.
    pub path: PathBuf,
    /// The resolved configuration (file plus overrides).
    pub config: SceneConfig,
}

impl LoadedScene {
    /// The scene's name: `name` from the file, else the file stem.
    pub fn name(&self) -> String {
        self.config.name.clone().unwrap_or_else(|| {
            self.path
                .file_stem()
                .map_or("scene".into(), |s| s.to_string_lossy().into_owned())
        })
    }

    /// The folder relative paths in the scene are resolved against.
    pub fn base_dir(&self) -> &Path {
        self.path.parent().unwrap_or(Path::new("."))
    }
}

/// Largest scene or study file (bytes): a configuration is a few kilobytes; this stops
/// `/dev/zero` or a mistaken multi-gigabyte file from being read whole.
pub const MAX_CONFIG_BYTES: u64 = 16 << 20;

/// Reads a scene or study file as UTF-8 text, refusing folders and files over
/// [`MAX_CONFIG_BYTES`].
pub fn read_config_text(path: &Path) -> std::io::Result<String> {
    use std::io::Read;
    // Opening a folder succeeds and reading it fails with an OS error ("Is a directory")
    // that does not say a TOML file was expected.
    if path.is_dir() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "it is a folder (directory), not a scene or study file (a .toml file)",
        ));
    }
    let mut bytes = Vec::new();
    std::fs::File::open(path)?
        .take(MAX_CONFIG_BYTES + 1)
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > MAX_CONFIG_BYTES {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!(
                "larger than {} MiB: not a configuration file",
                MAX_CONFIG_BYTES >> 20
            ),
        ));
    }
    String::from_utf8(bytes).map_err(|e| {
        let line = 1 + e.as_bytes()[..e.utf8_error().valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("line {line}: not UTF-8 text"),
        )
    })
}

/// Read `path`, apply `overrides` (`key=value`), and validate.
pub fn load(path: &Path, overrides: &[String]) -> Result<LoadedScene, SceneError> {
    let text = read_config_text(path).map_err(|error| SceneError::Io {
        path: path.to_owned(),
        error,
    })?;
    let config = parse(&text, path, overrides)?;
    Ok(LoadedScene {
        path: path.to_owned(),
        config,
    })
}

/// Parse scene text (`path` only names it in messages), apply overrides, validate.
pub fn parse(text: &str, path: &Path, overrides: &[String]) -> Result<SceneConfig, SceneError> {
    let mut table = parse_text(text, path)?;
    for o in overrides {
        apply_override(&mut table, o)?;
    }
    from_table(table, Some(text), path)
}

/// Scene text as a TOML table, before overrides (`path` only names it in messages).
pub fn parse_text(text: &str, path: &Path) -> Result<toml::Table, SceneError> {
    toml::from_str(text).map_err(|e| SceneError::Parse {
        path: path.to_owned(),
        message: softbench_core::quote::clip_source(e.to_string().trim_end()),
    })
}

/// Deserialize and validate a scene table (the file's, with any overrides applied). `text`,
/// the file as written, lets an error in the file itself name its line.
pub fn from_table(
    table: toml::Table,
    text: Option<&str>,
    path: &Path,
) -> Result<SceneConfig, SceneError> {
    let config = from_table_leaving_refusals(table, text, path)?;
    peer::validate(&config).map_err(|r| SceneError::Invalid {
        path: path.to_owned(),
        key: r.key,
        message: r.message,
    })?;
    Ok(config)
}

/// [`from_table`] without a peer method's refusals of the scene (a material, damping, drags it
/// lacks): a study that leaves out what a method cannot run (a suite) learns them from
/// [`applicable`] instead, and records them as omissions.
pub fn from_table_leaving_refusals(
    table: toml::Table,
    text: Option<&str>,
    path: &Path,
) -> Result<SceneConfig, SceneError> {
    let mut config: SceneConfig = match table.try_into() {
        Ok(c) => c,
        Err(e) => {
            // Deserializing the file text directly gives the error its line and column; if the
            // file alone is fine, the overrides are at fault.
            if let Some(Err(located)) = text.map(toml::from_str::<SceneConfig>) {
                return Err(SceneError::Parse {
                    path: path.to_owned(),
                    message: softbench_core::quote::clip_source(located.to_string().trim_end()),
                });
            }
            let context = if text.is_some() {
                "after overrides: "
            } else {
                ""
            };
            return Err(SceneError::Parse {
                path: path.to_owned(),
                message: softbench_core::quote::clip_source(&format!(
                    "{context}{}",
                    e.to_string().trim_end()
                )),
            });
        }
    };
    peer::resolve(&mut config).map_err(|r| SceneError::Invalid {
        path: path.to_owned(),
        key: r.key,
        message: r.message,
    })?;
    validate(&config, path)?;
    Ok(config)
}

/// A refused scene: the key at fault and why (the scene's path is added by the caller).
struct Refusal {
    key: String,
    message: String,
}

/// Check a parsed scene: every key in its range, the parts consistent with one another; the
/// error names the key.
fn validate(c: &SceneConfig, path: &Path) -> Result<(), SceneError> {
    let invalid = |r: Refusal| SceneError::Invalid {
        path: path.to_owned(),
        key: r.key,
        message: r.message,
    };
    check_run(c).map_err(invalid)?;
    check_mesh(c).map_err(invalid)?;
    check_start(c).map_err(invalid)?;
    validate_newton_components(c, path)?;
    check_contact(c).map_err(invalid)?;
    Ok(())
}

/// `[run]` (its step, counts and budget), `[problem]`, the springs and the budget's keys.
fn check_run(c: &SceneConfig) -> Result<(), Refusal> {
    let invalid = |key: &str, message: String| Refusal {
        key: key.into(),
        message,
    };
    let r = &c.run;
    if !(r.dt.is_finite() && r.dt > 0.0) {
        return Err(invalid(
            "run.dt",
            format!("must be a positive time step in seconds (got {:e})", r.dt),
        ));
    }
    if r.steps == 0 {
        return Err(invalid("run.steps", "must be at least 1".into()));
    }
    if r.sample_every == 0 {
        return Err(invalid("run.sample_every", "must be at least 1".into()));
    }
    if !(r.energy_limit.is_finite() && r.energy_limit >= 0.0) {
        return Err(invalid(
            "run.energy_limit",
            format!(
                "must be >= 0 (0 turns the check off; got {})",
                r.energy_limit
            ),
        ));
    }
    if let Some(b) = &r.budget {
        for (key, limit) in b.limits() {
            if !(limit.is_finite() && limit > 0.0) {
                return Err(invalid(
                    &format!("run.budget.{key}"),
                    format!("must be a positive number (got {limit})"),
                ));
            }
        }
    }
    if let Some(p) = &c.problem {
        p.validate(r.dt, r.steps)
            .map_err(|e| invalid(&e.key, e.message))?;
    }
    springs::validate(c).map_err(|e| invalid(&e.key, e.message))?;
    budget::check(c).map_err(|e| invalid(e.key, e.message))?;
    Ok(())
}

/// `[mesh]`: one source, and a generated box or ball with positive sizes.
fn check_mesh(c: &SceneConfig) -> Result<(), Refusal> {
    let invalid = |key: &str, message: String| Refusal {
        key: key.into(),
        message,
    };
    let mesh = c.mesh.as_ref();
    if let Some(mesh) = mesh {
        match (&mesh.file, &mesh.generate) {
            (Some(_), None) | (None, Some(_)) => {}
            _ => {
                return Err(invalid(
                    "mesh",
                    "give exactly one of `file` or `generate`".into(),
                ));
            }
        }
    }
    if let Some(g) = mesh.and_then(|m| m.generate.as_ref()) {
        let shape = (
            g.box_cells.is_some() || g.size.is_some(),
            g.ball.is_some() || g.radius.is_some(),
        );
        match shape {
            (true, false) => {
                let (Some(cells), Some(size)) = (g.box_cells, g.size) else {
                    return Err(invalid(
                        "mesh.generate",
                        "a box needs both `box = [nx, ny, nz]` and `size = [sx, sy, sz]`".into(),
                    ));
                };
                if cells.contains(&0) || !size.iter().all(|s| s.is_finite() && *s > 0.0) {
                    return Err(invalid(
                        "mesh.generate",
                        "box cell counts must be >= 1 and sizes > 0".into(),
                    ));
                }
            }
            (false, true) => {
                let (Some(n), Some(radius)) = (g.ball, g.radius) else {
                    return Err(invalid(
                        "mesh.generate",
                        "a ball needs both `ball = n` and `radius = r`".into(),
                    ));
                };
                if n == 0 || !(radius.is_finite() && radius > 0.0) {
                    return Err(invalid(
                        "mesh.generate",
                        "ball resolution must be >= 1 and radius > 0".into(),
                    ));
                }
            }
            _ => {
                return Err(invalid(
                    "mesh.generate",
                    "give either a box (`box`, `size`) or a ball (`ball`, `radius`)".into(),
                ));
            }
        }
    }
    Ok(())
}

/// The fixed rule, the initial state, gravity and the integrator's settings.
fn check_start(c: &SceneConfig) -> Result<(), Refusal> {
    let invalid = |key: &str, message: String| Refusal {
        key: key.into(),
        message,
    };
    if let Some(rule) = &c.fixed.rule
        && !(rule.tolerance.is_finite() && rule.tolerance >= 0.0)
    {
        return Err(invalid(
            "fixed.rule.tolerance",
            format!("must be >= 0 (got {})", rule.tolerance),
        ));
    }
    let init = &c.initial;
    if init
        .stretch
        .is_some_and(|s| !s.iter().all(|x| x.is_finite() && *x != 0.0))
    {
        return Err(invalid(
            "initial.stretch",
            "must be three finite nonzero scale factors (a negative one mirrors the body, \
             inverting every element)"
                .into(),
        ));
    }
    if init.twist.is_some_and(|t| !t.rate.is_finite()) {
        return Err(invalid(
            "initial.twist.rate",
            "must be a finite number of radians per metre".into(),
        ));
    }
    if init.from.is_some()
        && (init.stretch.is_some()
            || init.twist.is_some()
            || init.velocity != [0.0; 3]
            || init.angular_velocity != [0.0; 3])
    {
        return Err(invalid(
            "initial.from",
            "a frame gives positions and velocities; give either `from` or stretch/twist/\
             velocity/angular_velocity, not both"
                .into(),
        ));
    }
    if !init
        .velocity
        .iter()
        .chain(&init.angular_velocity)
        .all(|x| x.is_finite())
    {
        return Err(invalid(
            "initial",
            "velocity and angular_velocity must be finite".into(),
        ));
    }
    if !c.forces.gravity.iter().all(|g| g.is_finite()) {
        return Err(invalid(
            "forces.gravity",
            "must be three finite numbers (m/s^2)".into(),
        ));
    }
    c.integrator
        .validate()
        .map_err(|m| invalid("integrator", m))?;
    Ok(())
}

/// The obstacles and `[contact]`, and a response that sees the obstacles given.
fn check_contact(c: &SceneConfig) -> Result<(), Refusal> {
    let invalid = |key: &str, message: String| Refusal {
        key: key.into(),
        message,
    };
    for (i, o) in c.obstacles.iter().enumerate() {
        o.validate(&format!("obstacles[{i}]"))
            .map_err(|e| invalid(&e.key, e.message))?;
    }
    c.contact
        .validate(c.integrator.method)
        .map_err(|e| invalid(&e.key, e.message))?;
    if !c.contact.response.facts().sees_mesh_obstacles
        && let Some(i) = c.obstacles.iter().position(|o| o.is_mesh())
    {
        let seeing: Vec<&str> = ContactResponse::ALL
            .iter()
            .filter(|r| r.facts().sees_mesh_obstacles)
            .map(|r| r.name())
            .collect();
        return Err(invalid(
            &format!("obstacles[{i}].kind"),
            format!(
                "a mesh obstacle has no signed distance; only contact.response = \"{}\" sees \
                 its faces (the response is \"{}\")",
                seeing.join("\", \""),
                c.contact.response
            ),
        ));
    }
    Ok(())
}

/// The Newton loop's components apply to methods on it, and the constrained contact
/// response chooses its own direction and test; `gravity-gradient` needs gravity.
fn validate_newton_components(c: &SceneConfig, path: &Path) -> Result<(), SceneError> {
    let invalid = |key: &str, message: String| SceneError::Invalid {
        path: path.to_owned(),
        key: key.into(),
        message,
    };
    let n = &c.integrator.newton;
    let defaults = softbench_core::integrate::NewtonSettings::default();
    let chosen = [
        ("criterion", n.criterion != defaults.criterion),
        ("direction", n.direction != defaults.direction),
        ("globalization", n.globalization != defaults.globalization),
        ("log_iterations", n.log_iterations),
        ("roundoff_stop", !n.roundoff_stop),
    ];
    let method = c.integrator.method;
    if let Some((key, _)) = chosen.iter().find(|(_, set)| *set) {
        if !method.uses_newton() {
            return Err(invalid(
                &format!("integrator.newton.{key}"),
                format!(
                    "applies to methods on the Newton loop, and `{method}` is not one (those \
                     are the methods `softbench list` marks newton = yes)"
                ),
            ));
        }
        if !matches!(*key, "log_iterations" | "roundoff_stop")
            && !c.obstacles.is_empty()
            && c.contact.response.facts().owns_newton_components
        {
            return Err(invalid(
                &format!("integrator.newton.{key}"),
                format!(
                    "contact.response = \"{}\" chooses the direction (a QP) and tests its \
                     Lagrangian gradient itself: leave newton.{key} at its default",
                    c.contact.response
                ),
            ));
        }
    }
    if n.criterion == softbench_core::integrate::newton::Criterion::GravityGradient
        && c.forces.gravity.iter().all(|g| *g == 0.0)
    {
        return Err(invalid(
            "integrator.newton.criterion",
            "`gravity-gradient` is relative to the body's weight, and forces.gravity is zero: \
             choose another criterion (scaled-gradient, relative-gradient, ...)"
                .into(),
        ));
    }
    Ok(())
}

/// A built scene: the model, its initial state and the integrator of its first run.
pub struct Scene {
    pub name: String,
    pub config: SceneConfig,
    pub model: Model,
    pub initial: State,
    /// Obstacles and their response; `None` without obstacles.
    pub contact: Option<Contact>,
    /// Springs of a mass-spring body per kind (`structural`, `shear`, ...), kinds with none
    /// left out; empty for a FEM body.
    pub spring_counts: Vec<(&'static str, usize)>,
    /// The scene mesh's tets when the model has no elastic tets (a mass-spring body, such as
    /// a jello cube's lattice): the surface its frames and pictures show, kept so that
    /// nothing reads the mesh again. Empty when the model has tets of its own.
    pub mesh_tets: Vec<[usize; 4]>,
    /// The integrator [`build`] made and checked against the model, until a run takes it.
    integrator: Option<Box<dyn Integrator>>,
}

impl Scene {
    /// The integrator for a run of this scene, with its contact response if it has
    /// obstacles: the one [`build`] checked against the model for the first run, a new one
    /// for every later run (a stability search's trials each start fresh).
    ///
    /// The linear solvers run with the model's parallelism (the CLI's `--threads` sizes the
    /// pool), so the direct solvers' factorization and CG's mat-vecs get the same threads as
    /// assembly.
    pub fn take_integrator(&mut self) -> Box<dyn Integrator> {
        self.integrator
            .take()
            .unwrap_or_else(|| new_integrator(&self.config, &self.model, self.contact.as_ref()))
    }

    /// The tets whose boundary is the body's surface: the model's elastic tets, or for a body
    /// without any, the scene mesh's ([`Scene::mesh_tets`]).
    pub fn surface_tets(&self) -> &[[usize; 4]] {
        if self.model.tets().is_empty() {
            &self.mesh_tets
        } else {
            self.model.tets()
        }
    }
}

/// The integrator `config` names for `model`, with the model's parallelism and the contact
/// response of `contact`.
/// Whether the integrator `config` names can run `scene`'s model (built from a config of the
/// same physics): `Err` with why not (a local solver with no form for the material, ...).
pub fn applicable(config: &SceneConfig, scene: &Scene) -> Result<(), String> {
    let method = config.integrator.method;
    peer::validate(config)
        .map_err(|r| format!("`{method}` cannot run this scene: {}: {}", r.key, r.message))?;
    new_integrator(config, &scene.model, scene.contact.as_ref())
        .check_model(&scene.model)
        .map_err(|e| format!("`{}` cannot run this scene: {e}", config.integrator.method))
}

fn new_integrator(
    config: &SceneConfig,
    model: &Model,
    contact: Option<&Contact>,
) -> Box<dyn Integrator> {
    let settings = config.integrator.with_parallelism(model.parallelism());
    match contact {
        Some(contact) => contact.integrator(&settings),
        None => settings.build(),
    }
}

/// The tet mesh a scene names: read through the data search path, or generated; for a
/// `[jello]` body, its particles (with the cube's lattice tets, for display).
pub fn scene_mesh(loaded: &LoadedScene, data: &DataPaths) -> Result<TetMesh, SceneError> {
    let path = &loaded.path;
    let Some(mesh_config) = &loaded.config.mesh else {
        let jello = loaded
            .config
            .jello
            .as_ref()
            .expect("validated: mesh or jello");
        return Ok(springs::jello_mesh(jello));
    };
    if let Some(file) = &mesh_config.file {
        let resolved = data
            .resolve(file, Some(loaded.base_dir()))
            .map_err(|error| SceneError::Data {
                path: path.clone(),
                error,
            })?;
        return softbench_core::mesh::read_tet_mesh(&resolved).map_err(|error| SceneError::Mesh {
            path: path.clone(),
            error,
        });
    }
    let g = mesh_config
        .generate
        .as_ref()
        .expect("validated: file or generate");
    let mut mesh = match (g.box_cells, g.size, g.ball, g.radius) {
        (Some(cells), Some(size), _, _) => generate::box_mesh(cells, size),
        (_, _, Some(n), Some(r)) => generate::ball(r, n),
        _ => unreachable!("validated"),
    };
    if let Some(o) = g.origin {
        let o = Vector3::from(o);
        mesh.positions.iter_mut().for_each(|p| *p += o);
    }
    Ok(mesh)
}

/// The material a scene names.
fn scene_material(m: &MaterialConfig, path: &Path) -> Result<MaterialModel, SceneError> {
    let err = |error| SceneError::Material {
        path: path.to_owned(),
        error,
    };
    let invalid = |message: &str| SceneError::Invalid {
        path: path.to_owned(),
        key: "material".into(),
        message: message.into(),
    };
    if let (Some(c), Some(d)) = (m.c, m.d) {
        if m.model != MaterialKind::NeoHookean.name() {
            return Err(invalid(
                "`c` and `d` are the course Neo-Hookean's constants; use them with model = \"neo-hookean\"",
            ));
        }
        if m.youngs_modulus.is_some() || m.mu.is_some() {
            return Err(invalid(
                "give one set of constants: youngs_modulus + poisson_ratio, mu + lambda, or c + d",
            ));
        }
        LameParameters::new(2.0 * c, 2.0 * d).map_err(err)?;
        return Ok(MaterialModel::NeoHookean(NeoHookean::from_c_d(c, d)));
    }
    let lame = match (m.youngs_modulus, m.poisson_ratio, m.mu, m.lambda) {
        (Some(e), Some(nu), None, None) => {
            LameParameters::from_youngs_poisson(e, nu).map_err(err)?
        }
        (None, None, Some(mu), Some(lambda)) => LameParameters::new(mu, lambda).map_err(err)?,
        _ => {
            return Err(invalid(
                "give one set of constants: youngs_modulus + poisson_ratio, mu + lambda, or c + d",
            ));
        }
    };
    MaterialModel::from_name(&m.model, lame).map_err(err)
}

/// The state `[initial]` describes: rest, stretched and moving about the rest centroid, or
/// an exported frame's.
fn initial_state(
    model: &Model,
    init: &InitialConfig,
    loaded: &LoadedScene,
    data: &DataPaths,
    tets: &[[usize; 4]],
) -> Result<State, SceneError> {
    if let Some(file) = &init.from {
        return frame_state(model, file, loaded, data, tets);
    }
    let mut state = State::at_rest(model);
    if *init == InitialConfig::default() {
        return Ok(state);
    }
    let rest = model.rest_positions();
    let centroid = rest.iter().sum::<Vector3<f64>>() / rest.len().max(1) as f64;
    let stretch = Vector3::from(init.stretch.unwrap_or([1.0; 3]));
    let (v0, w) = (
        Vector3::from(init.velocity),
        Vector3::from(init.angular_velocity),
    );
    // The kinetic energy of the start (lumped masses): a speed that overflows it is an input
    // error, not a run that starts at infinity.
    let mut kinetic = 0.0;
    let masses = model.vertex_masses();
    for (k, &vertex) in model.dofs().free_vertices().iter().enumerate() {
        let r = rest[vertex] - centroid;
        let mut x = r.component_mul(&stretch);
        if let Some(twist) = init.twist {
            let axis = Vector3::ith_axis(twist.axis.index());
            let turn =
                nalgebra::Rotation3::from_axis_angle(&axis, twist.rate * r[twist.axis.index()]);
            x = turn * x;
        }
        let x = centroid + x;
        let v = v0 + w.cross(&r);
        kinetic += 0.5 * masses[vertex] * v.norm_squared();
        state.q[3 * k..3 * k + 3].copy_from_slice(x.as_slice());
        state.v[3 * k..3 * k + 3].copy_from_slice(v.as_slice());
    }
    if !kinetic.is_finite() {
        let key = if init.angular_velocity != [0.0; 3] {
            "initial.angular_velocity"
        } else {
            "initial.velocity"
        };
        return Err(SceneError::Invalid {
            path: loaded.path.clone(),
            key: key.into(),
            message: format!(
                "the body's initial kinetic energy would be {kinetic} J: the speed overflows; \
                 give a speed whose kinetic energy is a finite number"
            ),
        });
    }
    Ok(state)
}

/// The state of a VTU frame of this scene's mesh (`[initial] from`): its points as the free
/// vertices' positions, its `velocity` array (zero when absent) and its `TimeValue` (0 when
/// absent). The frame must have the scene's vertices and tets (in any vertex order within a
/// tet, since `mesh.reorient` may have swapped two); fixed vertices keep their rest positions.
fn frame_state(
    model: &Model,
    file: &str,
    loaded: &LoadedScene,
    data: &DataPaths,
    tets: &[[usize; 4]],
) -> Result<State, SceneError> {
    let path = &loaded.path;
    let resolved = data
        .resolve(file, Some(loaded.base_dir()))
        .map_err(|error| SceneError::InitialData {
            path: path.clone(),
            error,
        })?;
    let frame =
        softbench_core::mesh::vtk::read_vtu_frame(&resolved).map_err(|error| SceneError::Mesh {
            path: path.clone(),
            error,
        })?;
    let invalid = |message: String| SceneError::Invalid {
        path: path.clone(),
        key: "initial.from".into(),
        message,
    };
    let n = model.rest_positions().len();
    let sorted = |t: &[usize; 4]| {
        let mut t = *t;
        t.sort_unstable();
        t
    };
    if frame.mesh.positions.len() != n
        || frame.mesh.tets.len() != tets.len()
        || frame
            .mesh
            .tets
            .iter()
            .zip(tets)
            .any(|(a, b)| sorted(a) != sorted(b))
    {
        return Err(invalid(format!(
            "{} is not a frame of this scene's mesh: it has {} vertices and {} tets, the mesh \
             {n} and {} (or the tets differ)",
            resolved.display(),
            frame.mesh.positions.len(),
            frame.mesh.tets.len(),
            tets.len()
        )));
    }
    let velocity = frame.point_vector("velocity");
    let mut state = State::at_rest(model);
    for (k, &vertex) in model.dofs().free_vertices().iter().enumerate() {
        let x = frame.mesh.positions[vertex];
        state.q[3 * k..3 * k + 3].copy_from_slice(x.as_slice());
        if let Some(v) = velocity {
            if !v[vertex].iter().all(|c| c.is_finite()) {
                return Err(invalid(format!(
                    "{}: the velocity of vertex {vertex} is not finite",
                    resolved.display()
                )));
            }
            state.v[3 * k..3 * k + 3].copy_from_slice(v[vertex].as_slice());
        }
    }
    match frame.time {
        Some(t) if t.is_finite() => state.t = t,
        Some(t) => {
            return Err(invalid(format!(
                "{}: TimeValue {t} is not finite",
                resolved.display()
            )));
        }
        None => {}
    }
    Ok(state)
}

/// The scene's triangle-mesh obstacles, read from their files.
fn mesh_obstacles(
    c: &SceneConfig,
    loaded: &LoadedScene,
    data: &DataPaths,
) -> Result<Vec<MeshObstacle>, SceneError> {
    let path = &loaded.path;
    c.obstacles
        .iter()
        .enumerate()
        .filter(|(_, o)| o.is_mesh())
        .map(|(i, o)| {
            let file = o.file.as_deref().expect("validated");
            let resolved =
                data.resolve(file, Some(loaded.base_dir()))
                    .map_err(|e| SceneError::Invalid {
                        path: path.clone(),
                        key: format!("obstacles[{i}].file"),
                        message: e.to_string(),
                    })?;
            o.mesh_obstacle(&resolved)
                .map_err(|error| SceneError::Mesh {
                    path: path.clone(),
                    error,
                })
        })
        .collect()
}

/// Build the scene: mesh, material, fixed vertices, forces, obstacles, initial state.
pub fn build(
    loaded: &LoadedScene,
    data: &DataPaths,
    parallelism: Parallelism,
) -> Result<Scene, SceneError> {
    let c = &loaded.config;
    let path = &loaded.path;
    let mesh = scene_mesh(loaded, data)?;
    let tets = c.initial.from.as_ref().map(|_| mesh.tets.clone());
    // A body without an elastic material has no model tets; its surface is the mesh's.
    let mesh_tets = if c.material.is_none() {
        mesh.tets.clone()
    } else {
        Vec::new()
    };
    let material = c
        .material
        .as_ref()
        .map(|m| scene_material(m, path))
        .transpose()?;
    let density = c.material.as_ref().map(|m| m.density);
    // Particles of a mass-spring body have lumped masses.
    let mass_kind = c.material.as_ref().map_or(MassKind::Lumped, |m| m.mass);
    let (point_masses, springs, spring_counts) = match springs::spring_body(c, &mesh) {
        Some((body, mass)) => {
            let counts = softbench_core::springs::SpringKind::ALL
                .iter()
                .map(|&k| (k.name(), body.count(k)))
                .filter(|(_, n)| *n > 0)
                .collect();
            (Some(body.point_masses(mass)), body.springs, counts)
        }
        None => (None, Vec::new(), Vec::new()),
    };
    let fixed = fixed::selection(&c.fixed);
    let gravity = Vector3::from(c.forces.gravity);
    let spec = ModelSpec {
        mesh,
        material,
        density,
        mass_kind,
        point_masses,
        springs,
        gravity: (gravity != Vector3::zeros()).then_some(gravity),
        fixed,
        inverted_tets: if c.mesh.as_ref().is_some_and(|m| m.reorient) {
            InvertedTets::Reorient
        } else {
            InvertedTets::Refuse
        },
        parallelism,
        damping: c.damping.to_model(),
    };
    // The boundary surface contact works on (a response keeping the body off itself) and the
    // intersection check of sampled frames examines.
    let response = c.contact.response.facts();
    let surface = if response.self_contact || !c.obstacles.is_empty() {
        softbench_core::mesh::surface::boundary_faces(&spec.mesh.tets)
    } else {
        Vec::new()
    };
    let mut model = Model::new(spec).map_err(|error| SceneError::Model {
        path: path.clone(),
        error,
    })?;
    fixed::check_some_free(&c.fixed, &model).map_err(|(key, message)| SceneError::Invalid {
        path: path.clone(),
        key,
        message,
    })?;
    springs::add_drags(&mut model, &c.drag).map_err(|e| SceneError::Invalid {
        path: path.clone(),
        key: e.key,
        message: e.message,
    })?;
    let meshes = if response.sees_mesh_obstacles {
        mesh_obstacles(c, loaded, data)?
    } else {
        Vec::new()
    };
    let setup = ContactSetup {
        obstacles: &c.obstacles,
        meshes: &meshes,
        config: &c.contact,
        surface: &surface,
        dt: c.run.dt,
    };
    let contact = Contact::build(&setup, &mut model);
    // A method that has no form for the model's material or potentials says so now, not at
    // its first step. The integrator checked is the one the first run uses.
    let integrator = new_integrator(c, &model, contact.as_ref());
    integrator
        .check_model(&model)
        .map_err(|e| SceneError::Invalid {
            path: path.clone(),
            key: "integrator.method".into(),
            message: format!("`{}` cannot run this scene: {e}", c.integrator.method),
        })?;
    let initial = initial_state(
        &model,
        &c.initial,
        loaded,
        data,
        tets.as_deref().unwrap_or(&[]),
    )?;
    if let Some(ipc) = contact.as_ref().and_then(Contact::ipc) {
        let x = model.full_positions(&initial.q);
        let (_, distance, admissible) = ipc.contact_stats(&x, initial.t);
        if !admissible {
            return Err(SceneError::Invalid {
                path: path.clone(),
                key: "contact.response".into(),
                message: format!(
                    "incremental potential contact needs a start where nothing touches: \
                     primitives of the initial state touch or intersect (or a vertex is inside \
                     an obstacle; smallest distance {distance:.3e} m); move the body apart"
                ),
            });
        }
    }
    Ok(Scene {
        name: loaded.name(),
        config: c.clone(),
        model,
        initial,
        contact,
        spring_counts,
        mesh_tets,
        integrator: Some(integrator),
    })
}
