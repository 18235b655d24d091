//! The scene-file side of contact: `[[obstacles]]` tables and the `[contact]` section, their
//! validation, and turning them into [`Obstacle`]s.
//!
//! ```toml
//! [[obstacles]]
//! kind = "plane"
//! point = [0.0, 0.0, 0.0]
//! normal = [0.0, 1.0, 0.0]
//!
//! [[obstacles]]
//! kind = "sphere"
//! center = [0.0, -1.2, 0.0]
//! radius = 1.0
//! transform = { translation = [0.5, 0.0, 0.0], rotation = { axis = [0, 0, 1], degrees = 30 } }
//! path = { times = [0.0, 1.0], offsets = [[0, 0, 0], [0, 0.2, 0]] }
//!
//! [contact]
//! response = "projection"
//! restitution = 0.5
//! friction = 0.2
//! ```

use super::obstacle::{Obstacle, Shape};
use super::path::Path;
pub use super::responses::{ContactResponse, ResponseFacts, UnknownContactResponse};
use super::{Capsule, Cuboid, HalfSpace, Sphere};
use crate::integrate::Method;
use nalgebra::{Isometry3, Rotation3, Translation3, Unit, UnitQuaternion, Vector3};

/// What the code asks of an obstacle kind: the keys of its `[[obstacles]]` table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ObstacleFacts {
    /// The keys that apply to it (besides `kind`, `transform` and `path`).
    pub fields: &'static [&'static str],
    /// The keys it cannot do without.
    pub required: &'static [&'static str],
}

impl crate::registry::ListFacts for ObstacleFacts {
    fn list(&self) -> Vec<crate::registry::Fact> {
        vec![("fields", self.fields.join(","))]
    }
}

crate::named_enum! {
    /// The shape of an obstacle (`kind` in `[[obstacles]]`).
    pub enum ObstacleKind: "obstacle kind", UnknownObstacleKind, ObstacleFacts {
        /// A half-space below a plane: `point`, `normal` (outward).
        Plane = "plane", "the half-space below a plane (point, outward normal)",
            ObstacleFacts { fields: &["point", "normal"], required: &["normal"] },
        /// `center`, `radius`.
        Sphere = "sphere", "a ball (center, radius)",
            ObstacleFacts { fields: &["center", "radius"], required: &["radius"] },
        /// An oriented box: `center`, `half_extents`, optional `rotation`.
        Box = "box", "an oriented box (center, half extents, rotation)",
            ObstacleFacts {
                fields: &["center", "half_extents", "rotation"],
                required: &["half_extents"],
            },
        /// A segment from `a` to `b` thickened by `radius`.
        Capsule = "capsule", "a segment from a to b thickened by a radius",
            ObstacleFacts { fields: &["a", "b", "radius"], required: &["a", "b", "radius"] },
        /// The union of `members` (obstacle tables): the minimum distance.
        Group = "group", "the union of member obstacles (the minimum distance)",
            ObstacleFacts { fields: &["members"], required: &["members"] },
        /// A static triangle mesh read from an OBJ `file` (placed by `transform`); only
        /// `contact.response = "ipc"` sees its edges and faces.
        Mesh = "mesh", "a static triangle mesh from an OBJ file (response ipc only)",
            ObstacleFacts { fields: &["file"], required: &["file"] },
    }
}

/// A rotation by `degrees` about `axis` (right-handed).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotationConfig {
    pub axis: [f64; 3],
    pub degrees: f64,
}

impl RotationConfig {
    fn rotation(&self) -> Rotation3<f64> {
        Rotation3::from_axis_angle(
            &Unit::new_normalize(Vector3::from(self.axis)),
            self.degrees.to_radians(),
        )
    }
}

/// A rigid transform: rotate (about the origin), then translate.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformConfig {
    /// Translation (m). Default 0.
    #[serde(default)]
    pub translation: [f64; 3],
    /// Rotation. Default none.
    #[serde(default)]
    pub rotation: Option<RotationConfig>,
}

impl TransformConfig {
    fn isometry(&self) -> Isometry3<f64> {
        let rotation = self
            .rotation
            .map_or(Rotation3::identity(), |r| r.rotation());
        Isometry3::from_parts(
            Translation3::from(Vector3::from(self.translation)),
            UnitQuaternion::from_rotation_matrix(&rotation),
        )
    }
}

/// A prescribed translation through waypoints, linear in between (see [`Path`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PathConfig {
    /// Strictly increasing times (s).
    pub times: Vec<f64>,
    /// The offset (m) at each time.
    pub offsets: Vec<[f64; 3]>,
}

/// One `[[obstacles]]` table. Which fields apply depends on `kind` (see [`ObstacleKind`]);
/// a field that does not apply is an error.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObstacleConfig {
    pub kind: ObstacleKind,
    /// A point on a plane (m). Default: the origin.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub point: Option<[f64; 3]>,
    /// A plane's outward normal (need not be unit length).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal: Option<[f64; 3]>,
    /// Centre of a sphere or box (m). Default: the origin.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub center: Option<[f64; 3]>,
    /// Radius of a sphere or capsule (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
    /// Half-extents of a box along its axes (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_extents: Option<[f64; 3]>,
    /// Orientation of a box's axes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation: Option<RotationConfig>,
    /// End points of a capsule's segment (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub a: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub b: Option<[f64; 3]>,
    /// The obstacles of a group.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub members: Option<Vec<ObstacleConfig>>,
    /// A mesh obstacle's OBJ file (next to the scene file, then in `SOFTBENCH_DATA`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// Placement of the shape (any kind).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transform: Option<TransformConfig>,
    /// Prescribed motion (any kind), applied after `transform`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<PathConfig>,
}

/// `[contact]`: how contact with the obstacles is resolved. Ignored without obstacles.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ContactConfig {
    /// Default `penalty`.
    pub response: ContactResponse,
    /// Projection and velocity-flip: the fraction of the approaching normal velocity that is
    /// reversed, in [0, 1] (1 elastic, 0 inelastic). Default 0.
    pub restitution: f64,
    /// Projection and velocity-flip: the fraction of the tangential velocity removed, in
    /// [0, 1] (0 frictionless, 1 sticking). Default 0.
    pub friction: f64,
    /// Penalty stiffness k (N/m per vertex and obstacle), > 0. Default 1e5.
    pub stiffness: f64,
    /// Vertices within this distance (m) of an obstacle count as contacts in reports and get
    /// a constraint in the constrained response; >= 0. Default 1e-3.
    pub margin: f64,
    /// `[contact.ipc]`: incremental potential contact's settings (response `ipc`).
    pub ipc: super::ipc::IpcConfig,
}

impl Default for ContactConfig {
    fn default() -> Self {
        Self {
            response: ContactResponse::Penalty,
            restitution: 0.0,
            friction: 0.0,
            stiffness: 1e5,
            margin: 1e-3,
            ipc: super::ipc::IpcConfig::default(),
        }
    }
}

/// A configuration mistake: the dotted key and what is wrong.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ConfigError {
    pub key: String,
    pub message: String,
}

fn error(key: impl Into<String>, message: impl Into<String>) -> ConfigError {
    ConfigError {
        key: key.into(),
        message: message.into(),
    }
}

fn finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

impl ContactConfig {
    /// Check ranges; `method` is the scene's integrator (the constrained response needs one
    /// whose Newton unknown is the end-of-step position).
    pub fn validate(&self, method: Method) -> Result<(), ConfigError> {
        let unit = |x: f64| (0.0..=1.0).contains(&x);
        if !unit(self.restitution) {
            return Err(error(
                "contact.restitution",
                format!("must lie in [0, 1] (got {})", self.restitution),
            ));
        }
        if !unit(self.friction) {
            return Err(error(
                "contact.friction",
                format!("must lie in [0, 1] (got {})", self.friction),
            ));
        }
        if !(self.stiffness.is_finite() && self.stiffness > 0.0) {
            return Err(error(
                "contact.stiffness",
                format!("must be > 0 (N/m; got {})", self.stiffness),
            ));
        }
        if !(self.margin.is_finite() && self.margin >= 0.0) {
            return Err(error(
                "contact.margin",
                format!("must be >= 0 (m; got {})", self.margin),
            ));
        }
        if self.response == ContactResponse::Ipc {
            self.ipc
                .validate()
                .map_err(|(key, message)| error(key, message))?;
        } else if self.ipc != super::ipc::IpcConfig::default() {
            return Err(error(
                "contact.ipc",
                format!(
                    "applies to contact.response = \"ipc\" only (the response is \"{}\")",
                    self.response
                ),
            ));
        }
        if self.response.facts().in_newton_loop && !method.entry().constrained_contact {
            let able: Vec<&str> = Method::all()
                .into_iter()
                .filter(|m| m.entry().constrained_contact)
                .map(|m| m.name())
                .collect();
            return Err(error(
                "contact.response",
                format!(
                    "`{}` acts on the end-of-step positions inside a Newton solve; \
                     integrator.method `{method}` has none (methods that can: {})",
                    self.response,
                    able.join(", ")
                ),
            ));
        }
        Ok(())
    }
}

impl ObstacleConfig {
    /// Check that the fields fit the kind and their values; `key` names this table in
    /// messages (`obstacles[0]`).
    pub fn validate(&self, key: &str) -> Result<(), ConfigError> {
        let kind = self.kind;
        let present = [
            ("point", self.point.is_some()),
            ("normal", self.normal.is_some()),
            ("center", self.center.is_some()),
            ("radius", self.radius.is_some()),
            ("half_extents", self.half_extents.is_some()),
            ("rotation", self.rotation.is_some()),
            ("a", self.a.is_some()),
            ("b", self.b.is_some()),
            ("members", self.members.is_some()),
            ("file", self.file.is_some()),
        ];
        let allowed = kind.facts().fields;
        if let Some((name, _)) = present
            .iter()
            .find(|(name, set)| *set && !allowed.contains(name))
        {
            return Err(error(
                format!("{key}.{name}"),
                format!(
                    "does not apply to a {kind} (its fields: {}, transform, path)",
                    allowed.join(", ")
                ),
            ));
        }
        let required = kind.facts().required;
        if let Some(name) = required
            .iter()
            .find(|name| !present.iter().any(|(n, set)| n == *name && *set))
        {
            return Err(error(
                format!("{key}.{name}"),
                format!("a {kind} needs `{name}`"),
            ));
        }
        let points = [
            ("point", self.point),
            ("center", self.center),
            ("a", self.a),
            ("b", self.b),
        ];
        for (name, p) in points {
            if let Some(p) = p
                && !finite(&p)
            {
                return Err(error(format!("{key}.{name}"), "must be finite (m)"));
            }
        }
        if let Some(n) = self.normal
            && !(finite(&n) && Vector3::from(n).norm() > 0.0)
        {
            return Err(error(
                format!("{key}.normal"),
                format!("must be a finite, non-zero vector (got {n:?})"),
            ));
        }
        if let Some(r) = self.radius
            && !(r.is_finite() && r > 0.0)
        {
            return Err(error(
                format!("{key}.radius"),
                format!("must be > 0 (m; got {r})"),
            ));
        }
        if let Some(h) = self.half_extents
            && !h.iter().all(|x| x.is_finite() && *x > 0.0)
        {
            return Err(error(
                format!("{key}.half_extents"),
                format!("must be three numbers > 0 (m; got {h:?})"),
            ));
        }
        if let Some(r) = &self.rotation {
            validate_rotation(r, &format!("{key}.rotation"))?;
        }
        if let Some(members) = &self.members {
            if members.is_empty() {
                return Err(error(
                    format!("{key}.members"),
                    "a group needs at least one member",
                ));
            }
            for (i, m) in members.iter().enumerate() {
                m.validate(&format!("{key}.members[{i}]"))?;
            }
        }
        if let Some(tr) = &self.transform {
            if !finite(&tr.translation) {
                return Err(error(
                    format!("{key}.transform.translation"),
                    "must be finite (m)",
                ));
            }
            if let Some(r) = &tr.rotation {
                validate_rotation(r, &format!("{key}.transform.rotation"))?;
            }
        }
        if kind == ObstacleKind::Mesh && self.path.is_some() {
            return Err(error(
                format!("{key}.path"),
                "a mesh obstacle is static (place it with `transform`)",
            ));
        }
        if let Some(path) = &self.path {
            let key = format!("{key}.path");
            if path.times.is_empty() || path.times.len() != path.offsets.len() {
                return Err(error(
                    key,
                    format!(
                        "needs as many offsets as times, and at least one (got {} times, {} offsets)",
                        path.times.len(),
                        path.offsets.len()
                    ),
                ));
            }
            let increasing = path.times.windows(2).all(|w| w[0] < w[1]);
            if !finite(&path.times) || !increasing {
                return Err(error(
                    format!("{key}.times"),
                    "must be finite and strictly increasing (s)",
                ));
            }
            if !path.offsets.iter().all(|o| finite(o)) {
                return Err(error(format!("{key}.offsets"), "must be finite (m)"));
            }
        }
        Ok(())
    }

    /// The obstacle this table describes. Call [`Self::validate`] first.
    ///
    /// # Panics
    /// On a table that does not validate.
    pub fn obstacle(&self) -> Obstacle {
        let v = |p: Option<[f64; 3]>| p.map_or(Vector3::zeros(), Vector3::from);
        let shape = match self.kind {
            ObstacleKind::Plane => Shape::HalfSpace(HalfSpace::new(v(self.point), v(self.normal))),
            ObstacleKind::Sphere => {
                Shape::Sphere(Sphere::new(v(self.center), self.radius.expect("validated")))
            }
            ObstacleKind::Box => Shape::Cuboid(Cuboid::new(
                v(self.center),
                v(self.half_extents),
                self.rotation
                    .map_or(Rotation3::identity(), |r| r.rotation()),
            )),
            ObstacleKind::Capsule => Shape::Capsule(Capsule::new(
                v(self.a),
                v(self.b),
                self.radius.expect("validated"),
            )),
            ObstacleKind::Group => Shape::Group(
                self.members
                    .iter()
                    .flatten()
                    .map(ObstacleConfig::obstacle)
                    .collect(),
            ),
            ObstacleKind::Mesh => {
                panic!("a mesh obstacle has no signed distance (see mesh_obstacle)")
            }
        };
        let mut obstacle = Obstacle::new(shape);
        if let Some(tr) = &self.transform {
            obstacle = obstacle.with_transform(tr.isometry());
        }
        if let Some(path) = &self.path {
            obstacle = obstacle.with_path(Path::new(
                path.times.clone(),
                path.offsets.iter().map(|o| Vector3::from(*o)).collect(),
            ));
        }
        obstacle
    }
}

impl ObstacleConfig {
    /// Whether this table is a mesh obstacle (not a signed distance).
    pub fn is_mesh(&self) -> bool {
        self.kind == ObstacleKind::Mesh
    }

    /// A mesh obstacle's triangles read from `path` (its resolved `file`), placed by its
    /// transform.
    pub fn mesh_obstacle(
        &self,
        path: &std::path::Path,
    ) -> Result<super::ipc::MeshObstacle, crate::mesh::MeshError> {
        let surface = crate::mesh::obj::read(path)?;
        let iso = self
            .transform
            .as_ref()
            .map_or(Isometry3::identity(), TransformConfig::isometry);
        Ok(super::ipc::MeshObstacle {
            positions: surface
                .positions
                .iter()
                .map(|p| (iso * nalgebra::Point3::from(*p)).coords)
                .collect(),
            triangles: surface.triangles,
        })
    }
}

fn validate_rotation(r: &RotationConfig, key: &str) -> Result<(), ConfigError> {
    if !(finite(&r.axis) && Vector3::from(r.axis).norm() > 0.0) {
        return Err(error(
            format!("{key}.axis"),
            format!("must be a finite, non-zero vector (got {:?})", r.axis),
        ));
    }
    if !r.degrees.is_finite() {
        return Err(error(format!("{key}.degrees"), "must be finite"));
    }
    Ok(())
}
