//! The scene sections for mass-spring bodies and scripted drags:
//!
//! ```toml
//! [springs]            # a spring along every edge of the [mesh]'s tets
//! from_tets = true
//! stiffness = 1e5      # N/m
//! damping = 0.0        # N s/m (default 0)
//! particle_mass = 1.0  # kg per particle, or total_mass = ... split evenly
//!
//! [jello]              # instead of [mesh]: a generated mass-spring body
//! shape = "cube"       # n, size, origin (min corner, default 0)
//! n = 6
//! size = 0.5
//! stiffness = { structural = 2e3, shear = 1.5e3, bending = 5e2 }
//! damping = { structural = 0.5 }   # per kind, default 0
//! total_mass = 1.0
//! # shape = "sphere": rings, segments, radius, center; kinds also radial, antipodal
//!
//! [[drag]]             # any number of drags, on any body
//! point = [0.8, 0.8, 0.3]
//! radius = 0.05        # picks the vertices within; at least the nearest one
//! stiffness = 1e5
//! path = [{ t = 0.0, offset = [0, 0, 0] }, { t = 0.5, offset = [0.2, 0, 0] }]
//! release = 1.0        # s; omit to hold to the end
//! ```
//!
//! Validation messages name the key (`jello.stiffness.bending`, `drag[0].path[1].t`).

use super::SceneConfig;
use nalgebra::Vector3;
use softbench_core::mesh::TetMesh;
use softbench_core::model::{Drag, DragPath, Model, Waypoint};
use softbench_core::springs::{
    JelloCube, JelloSphere, ParticleMass, SpringBody, SpringCoefficients, SpringKind, tet_edges,
};

/// `[springs]`: springs along the tet edges of the scene's mesh.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpringsConfig {
    /// A spring along every unique tet edge (the only source of springs so far: must be true).
    pub from_tets: bool,
    /// Stiffness of every spring (N/m), >= 0.
    pub stiffness: f64,
    /// Damping coefficient of every spring (N s/m), >= 0. Default 0.
    #[serde(default)]
    pub damping: f64,
    /// Mass of each particle (kg); give this or `total_mass`.
    #[serde(default)]
    pub particle_mass: Option<f64>,
    /// Total mass (kg), split evenly over the particles.
    #[serde(default)]
    pub total_mass: Option<f64>,
}

/// The shape of a `[jello]` body.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JelloShape {
    Cube,
    Sphere,
}

/// A value per spring kind (`stiffness = { structural = 2e3, shear = 1e3, ... }`).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KindTable {
    #[serde(default)]
    pub structural: Option<f64>,
    #[serde(default)]
    pub shear: Option<f64>,
    #[serde(default)]
    pub bending: Option<f64>,
    /// Sphere only: centre to every particle.
    #[serde(default)]
    pub radial: Option<f64>,
    /// Sphere only: each particle to its antipode.
    #[serde(default)]
    pub antipodal: Option<f64>,
}

impl KindTable {
    fn get(&self, kind: SpringKind) -> Option<f64> {
        match kind {
            SpringKind::Structural => self.structural,
            SpringKind::Shear => self.shear,
            SpringKind::Bending => self.bending,
            SpringKind::Radial => self.radial,
            SpringKind::Antipodal => self.antipodal,
            SpringKind::Edge => None,
        }
    }
}

/// `[jello]`: a generated mass-spring body, instead of `[mesh]`.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JelloConfig {
    /// `cube` or `sphere`.
    pub shape: JelloShape,
    /// Cube: particles per edge, >= 2.
    #[serde(default)]
    pub n: Option<usize>,
    /// Cube: edge length (m), > 0.
    #[serde(default)]
    pub size: Option<f64>,
    /// Cube: the minimum corner (m). Default 0.
    #[serde(default)]
    pub origin: Option<[f64; 3]>,
    /// Sphere: rings of latitude between the poles, >= 2.
    #[serde(default)]
    pub rings: Option<usize>,
    /// Sphere: particles per ring, even and >= 6.
    #[serde(default)]
    pub segments: Option<usize>,
    /// Sphere: radius (m), > 0.
    #[serde(default)]
    pub radius: Option<f64>,
    /// Sphere: centre (m). Default 0.
    #[serde(default)]
    pub center: Option<[f64; 3]>,
    /// Stiffness per kind (N/m): every kind the shape has (cube: structural, shear, bending;
    /// sphere also radial, antipodal).
    pub stiffness: KindTable,
    /// Damping coefficient per kind (N s/m). Default 0 for every kind.
    #[serde(default)]
    pub damping: KindTable,
    /// Mass of each particle (kg); give this or `total_mass`.
    #[serde(default)]
    pub particle_mass: Option<f64>,
    /// Total mass (kg), split evenly over the particles.
    #[serde(default)]
    pub total_mass: Option<f64>,
}

impl JelloConfig {
    /// The spring kinds this shape has.
    fn kinds(&self) -> &'static [SpringKind] {
        match self.shape {
            JelloShape::Cube => &[
                SpringKind::Structural,
                SpringKind::Shear,
                SpringKind::Bending,
            ],
            JelloShape::Sphere => &[
                SpringKind::Structural,
                SpringKind::Shear,
                SpringKind::Bending,
                SpringKind::Radial,
                SpringKind::Antipodal,
            ],
        }
    }

    /// The generated body. Panics if a key of the shape is missing or out of range; a
    /// configuration from [`super::load`] or [`super::parse`] has been validated.
    pub fn body(&self) -> SpringBody {
        let coefficients = |kind| SpringCoefficients {
            stiffness: self.stiffness.get(kind).unwrap_or(0.0),
            damping: self.damping.get(kind).unwrap_or(0.0),
        };
        match self.shape {
            JelloShape::Cube => JelloCube {
                n: self.n.expect("validated"),
                size: self.size.expect("validated"),
                origin: Vector3::from(self.origin.unwrap_or_default()),
            }
            .build(coefficients),
            JelloShape::Sphere => JelloSphere {
                rings: self.rings.expect("validated"),
                segments: self.segments.expect("validated"),
                radius: self.radius.expect("validated"),
                center: Vector3::from(self.center.unwrap_or_default()),
            }
            .build(coefficients),
        }
    }
}

/// A waypoint of a drag path: `{ t = 0.5, offset = [0.2, 0, 0] }`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WaypointConfig {
    /// Time (s).
    pub t: f64,
    /// Offset of the targets from the picked vertices' rest positions (m).
    pub offset: [f64; 3],
}

/// `[[drag]]`: pick the vertices near `point` and pull them along `path` (see
/// [`softbench_core::model::Drag`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DragConfig {
    /// Where to pick, in rest coordinates (m).
    pub point: [f64; 3],
    /// Pick the vertices within this distance (m), >= 0; at least the nearest one. Default 0.
    #[serde(default)]
    pub radius: f64,
    /// Stiffness of each drag spring (N/m), >= 0.
    pub stiffness: f64,
    /// Offsets over time, piecewise linear; times increasing.
    pub path: Vec<WaypointConfig>,
    /// Time (s) from which the drag pulls no more. Default: never released.
    #[serde(default)]
    pub release: Option<f64>,
}

/// A key and what is wrong with its value.
pub(super) struct Invalid {
    pub key: String,
    pub message: String,
}

fn invalid(key: impl Into<String>, message: impl Into<String>) -> Invalid {
    Invalid {
        key: key.into(),
        message: message.into(),
    }
}

fn check_non_negative(key: &str, value: f64, unit: &str) -> Result<(), Invalid> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(invalid(key, format!("must be >= 0 {unit} (got {value})")))
    }
}

fn check_positive(key: &str, value: f64, unit: &str) -> Result<(), Invalid> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(invalid(key, format!("must be > 0 {unit} (got {value})")))
    }
}

fn check_finite(key: &str, value: &[f64]) -> Result<(), Invalid> {
    if value.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(invalid(key, format!("must be finite (got {value:?})")))
    }
}

fn particle_mass(
    section: &str,
    each: Option<f64>,
    total: Option<f64>,
) -> Result<ParticleMass, Invalid> {
    match (each, total) {
        (Some(m), None) => {
            check_positive(&format!("{section}.particle_mass"), m, "kg")?;
            Ok(ParticleMass::Each(m))
        }
        (None, Some(m)) => {
            check_positive(&format!("{section}.total_mass"), m, "kg")?;
            Ok(ParticleMass::Total(m))
        }
        _ => Err(invalid(
            section,
            "give exactly one of `particle_mass` (kg each) or `total_mass` (kg, split evenly)",
        )),
    }
}

/// Check `[springs]`, `[jello]` and `[[drag]]`, and that the scene has exactly one body source
/// (`[mesh]` or `[jello]`).
pub(super) fn validate(c: &SceneConfig) -> Result<(), Invalid> {
    match (&c.mesh, &c.jello) {
        (Some(_), None) | (None, Some(_)) => {}
        (None, None) => {
            return Err(invalid(
                "mesh",
                "a scene needs a body: give `[mesh]` (a tet mesh) or `[jello]` (a generated mass-spring body)",
            ));
        }
        (Some(_), Some(_)) => {
            return Err(invalid(
                "jello",
                "give exactly one body source: `[mesh]` or `[jello]`, not both",
            ));
        }
    }
    if let Some(s) = &c.springs {
        if c.mesh.is_none() {
            return Err(invalid(
                "springs",
                "`[springs]` puts springs on the edges of `[mesh]`; a `[jello]` body has its own",
            ));
        }
        if !s.from_tets {
            return Err(invalid(
                "springs.from_tets",
                "must be true (springs along the tet edges are the only kind so far)",
            ));
        }
        check_non_negative("springs.stiffness", s.stiffness, "N/m")?;
        check_non_negative("springs.damping", s.damping, "N s/m")?;
        particle_mass("springs", s.particle_mass, s.total_mass)?;
    }
    if let Some(j) = &c.jello {
        validate_jello(j, c.material.is_some())?;
    }
    for (i, d) in c.drag.iter().enumerate() {
        validate_drag(i, d)?;
    }
    Ok(())
}

fn validate_jello(j: &JelloConfig, has_material: bool) -> Result<(), Invalid> {
    if has_material {
        return Err(invalid(
            "material",
            "a `[jello]` body is particles and springs only; remove `[material]`",
        ));
    }
    let cube_keys = [
        ("n", j.n.is_some()),
        ("size", j.size.is_some()),
        ("origin", j.origin.is_some()),
    ];
    let sphere_keys = [
        ("rings", j.rings.is_some()),
        ("segments", j.segments.is_some()),
        ("radius", j.radius.is_some()),
        ("center", j.center.is_some()),
    ];
    let (this, other, other_keys) = match j.shape {
        JelloShape::Cube => ("cube", "sphere", &sphere_keys[..]),
        JelloShape::Sphere => ("sphere", "cube", &cube_keys[..]),
    };
    if let Some((key, _)) = other_keys.iter().find(|(_, given)| *given) {
        return Err(invalid(
            format!("jello.{key}"),
            format!("applies to shape = \"{other}\", not \"{this}\""),
        ));
    }
    match j.shape {
        JelloShape::Cube => {
            let n = j.n.ok_or_else(|| invalid("jello.n", "a cube needs `n`"))?;
            if n < 2 {
                return Err(invalid(
                    "jello.n",
                    format!("must be at least 2 particles per edge (got {n})"),
                ));
            }
            let size = j
                .size
                .ok_or_else(|| invalid("jello.size", "a cube needs `size`"))?;
            check_positive("jello.size", size, "m")?;
            check_finite("jello.origin", &j.origin.unwrap_or_default())?;
        }
        JelloShape::Sphere => {
            let rings = j
                .rings
                .ok_or_else(|| invalid("jello.rings", "a sphere needs `rings`"))?;
            if rings < 2 {
                return Err(invalid(
                    "jello.rings",
                    format!("must be at least 2 (got {rings})"),
                ));
            }
            let segments = j
                .segments
                .ok_or_else(|| invalid("jello.segments", "a sphere needs `segments`"))?;
            if segments < 6 || segments % 2 != 0 {
                return Err(invalid(
                    "jello.segments",
                    format!(
                        "must be even (every particle needs an antipode) and at least 6 (got {segments})"
                    ),
                ));
            }
            let radius = j
                .radius
                .ok_or_else(|| invalid("jello.radius", "a sphere needs `radius`"))?;
            check_positive("jello.radius", radius, "m")?;
            check_finite("jello.center", &j.center.unwrap_or_default())?;
        }
    }
    let kinds = j.kinds();
    for kind in SpringKind::ALL {
        if kind == SpringKind::Edge {
            continue;
        }
        for (table, name, required) in [
            (&j.stiffness, "stiffness", true),
            (&j.damping, "damping", false),
        ] {
            let key = format!("jello.{name}.{kind}");
            match (table.get(kind), kinds.contains(&kind)) {
                (Some(v), true) => {
                    check_non_negative(&key, v, if required { "N/m" } else { "N s/m" })?
                }
                (None, true) if required => {
                    return Err(invalid(
                        key,
                        format!("a {this} needs the stiffness of its {kind} springs"),
                    ));
                }
                (Some(_), false) => {
                    return Err(invalid(key, format!("a {this} has no {kind} springs")));
                }
                _ => {}
            }
        }
    }
    particle_mass("jello", j.particle_mass, j.total_mass)?;
    Ok(())
}

fn validate_drag(i: usize, d: &DragConfig) -> Result<(), Invalid> {
    let key = |k: &str| format!("drag[{i}].{k}");
    check_finite(&key("point"), &d.point)?;
    check_non_negative(&key("radius"), d.radius, "m")?;
    check_non_negative(&key("stiffness"), d.stiffness, "N/m")?;
    if d.path.is_empty() {
        return Err(invalid(
            key("path"),
            "needs at least one waypoint, e.g. [{ t = 0.0, offset = [0, 0, 0] }]",
        ));
    }
    for (w, p) in d.path.iter().enumerate() {
        check_finite(&key(&format!("path[{w}].t")), &[p.t])?;
        check_finite(&key(&format!("path[{w}].offset")), &p.offset)?;
        if w > 0 && p.t <= d.path[w - 1].t {
            return Err(invalid(
                key(&format!("path[{w}].t")),
                format!(
                    "waypoint times must increase (got {} after {})",
                    p.t,
                    d.path[w - 1].t
                ),
            ));
        }
    }
    if let Some(r) = d.release {
        check_non_negative(&key("release"), r, "s")?;
    }
    Ok(())
}

/// The particles of a `[jello]` scene as a tet mesh (the cube's tets are for display).
pub(super) fn jello_mesh(j: &JelloConfig) -> TetMesh {
    j.body().mesh()
}

/// The springs and particle masses of the scene's body, if it is a mass-spring body:
/// `[jello]`, or `[springs]` on `mesh`. The configuration must have passed [`validate`].
pub(super) fn spring_body(c: &SceneConfig, mesh: &TetMesh) -> Option<(SpringBody, ParticleMass)> {
    if let Some(j) = &c.jello {
        let mass = particle_mass("jello", j.particle_mass, j.total_mass).ok()?;
        return Some((j.body(), mass));
    }
    let s = c.springs.as_ref()?;
    let mass = particle_mass("springs", s.particle_mass, s.total_mass).ok()?;
    let coefficients = SpringCoefficients {
        stiffness: s.stiffness,
        damping: s.damping,
    };
    Some((tet_edges(mesh, coefficients), mass))
}

/// Pick the vertices of each `[[drag]]` on the model's rest positions and add the drags.
/// A drag whose picked vertices are all fixed is an error (it would do nothing).
pub(super) fn add_drags(model: &mut Model, drags: &[DragConfig]) -> Result<(), Invalid> {
    for (i, d) in drags.iter().enumerate() {
        let rest = model.rest_positions();
        let vertices = Drag::pick(rest, &Vector3::from(d.point), d.radius);
        if vertices.iter().all(|&v| model.dofs().is_fixed(v)) {
            return Err(invalid(
                format!("drag[{i}].point"),
                format!(
                    "every vertex it picks is fixed ({vertices:?}); pick a free part of the body"
                ),
            ));
        }
        let waypoints = d
            .path
            .iter()
            .map(|w| Waypoint {
                t: w.t,
                offset: Vector3::from(w.offset),
            })
            .collect();
        let path = DragPath::new(waypoints)
            .map_err(|e| invalid(format!("drag[{i}].path"), e.to_string()))?;
        let drag = Drag::new(rest, vertices, d.stiffness, path, d.release)
            .map_err(|e| invalid(format!("drag[{i}]"), e.to_string()))?;
        model.add_vertex_potential(Box::new(drag));
    }
    Ok(())
}
