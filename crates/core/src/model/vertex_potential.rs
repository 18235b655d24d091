//! Potentials that act on vertices one at a time — contact penalties against obstacles, drag
//! springs to moving targets. They couple no two vertices, so their Hessian is block-diagonal
//! and fits the pattern the elements already built; they may depend on time.

use nalgebra::{Matrix3, Vector3};

/// A per-vertex potential `sum_v phi_v(x_v, t)`.
pub trait VertexPotential: Send + Sync + std::fmt::Debug {
    /// A short name for reports ("contact", "drag").
    fn name(&self) -> &str;

    /// The energy at time `t` for positions `x` (every vertex of the mesh).
    fn energy(&self, t: f64, x: &[Vector3<f64>]) -> f64;

    /// Call `add(v, dphi/dx_v)` for each vertex with a non-zero gradient.
    fn gradient(&self, t: f64, x: &[Vector3<f64>], add: &mut dyn FnMut(usize, Vector3<f64>));

    /// Call `add(v, d2phi/dx_v^2)` for each vertex with a non-zero Hessian block; with
    /// `project`, each block must be positive semi-definite.
    fn hessian(
        &self,
        t: f64,
        x: &[Vector3<f64>],
        project: bool,
        add: &mut dyn FnMut(usize, Matrix3<f64>),
    );

    /// The potential as zero-rest-length springs `k/2 |x_v − target|²` at time `t`, if it is
    /// one: calls `add(v, k, target)` per vertex and returns `true`. Methods that are not
    /// Newton on the whole potential (projective dynamics, XPBD) take such a potential as
    /// projective terms or compliant constraints; one that returns `false` (contact
    /// penalties) they refuse.
    fn anchors(&self, _t: f64, _add: &mut dyn FnMut(usize, f64, Vector3<f64>)) -> bool {
        false
    }
}

/// A model's vertex potentials at one time as one zero-rest-length spring per vertex,
/// `K_v/2 |x_v − t_v|²` (several springs on a vertex sum to one, up to a constant).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Anchors {
    /// `K_v` (N/m), 0 where nothing pulls.
    pub stiffness: Vec<f64>,
    /// `K_v t_v`.
    pub pull: Vec<Vector3<f64>>,
}

impl Anchors {
    /// Gather `potentials` at time `t` over `vertices` vertices; `Err` names the first
    /// potential that is not a set of anchors.
    pub fn gather<'a>(
        &mut self,
        potentials: &'a [Box<dyn VertexPotential>],
        vertices: usize,
        t: f64,
    ) -> Result<(), &'a str> {
        self.stiffness.clear();
        self.stiffness.resize(vertices, 0.0);
        self.pull.clear();
        self.pull.resize(vertices, Vector3::zeros());
        for p in potentials {
            let (k, pull) = (&mut self.stiffness, &mut self.pull);
            if !p.anchors(t, &mut |v, kv, target| {
                k[v] += kv;
                pull[v] += target * kv;
            }) {
                return Err(p.name());
            }
        }
        Ok(())
    }

    /// `Err` names the first of `potentials` that is not a set of anchors.
    pub fn check(potentials: &[Box<dyn VertexPotential>]) -> Result<(), &str> {
        match potentials
            .iter()
            .find(|p| !p.anchors(0.0, &mut |_, _, _| {}))
        {
            Some(p) => Err(p.name()),
            None => Ok(()),
        }
    }

    /// Whether any vertex is pulled.
    pub fn any(&self) -> bool {
        self.stiffness.iter().any(|&k| k > 0.0)
    }
}
