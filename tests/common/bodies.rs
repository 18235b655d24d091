//! Small test bodies and a fixed-step driver for integrator tests.

use nalgebra::Vector3;
use softbench::integrate::{Integrator, IntegratorSettings, Method, State};
use softbench::material::{LameParameters, MaterialModel};
use softbench::mesh::generate::box_mesh;
use softbench::model::{AxisRule, FixedSelection, Model, ModelSpec, Side};

/// A 0.2 m × 0.1 m × 0.1 m block (2×1×1 cells, 12 tets) of Stable Neo-Hookean rubber
/// (E = 1e4 Pa, nu = 0.3, 1000 kg/m^3), optionally clamped at x = 0 and under gravity.
pub fn block(clamped: bool, gravity: bool) -> Model {
    let lame = LameParameters::from_youngs_poisson(1e4, 0.3).unwrap();
    let material = MaterialModel::from_name("stable-neo-hookean", lame).unwrap();
    let mut spec = ModelSpec::elastic(box_mesh([2, 1, 1], [0.2, 0.1, 0.1]), material, 1000.0);
    if clamped {
        spec.fixed = clamped_at_min_x();
    }
    if gravity {
        spec.gravity = Some(Vector3::new(0.0, -9.81, 0.0));
    }
    Model::new(spec).unwrap()
}

/// The rest state with a smooth initial velocity (bending, twisting and, when the body is
/// free, translating), so every mode of interest moves.
pub fn kicked(model: &Model) -> State {
    let mut state = State::at_rest(model);
    for (f, &v) in model.dofs().free_vertices().iter().enumerate() {
        let x = model.rest_positions()[v];
        state.v[3 * f] = 0.1 + 0.3 * x.y;
        state.v[3 * f + 1] = 2.0 * x.x;
        state.v[3 * f + 2] = 1.5 * x.x * (x.y - 0.05);
    }
    state
}

/// An integrator for `method` with test-grade settings: Newton converged tightly (tolerance
/// 1e-11, up to 30 iterations, required), so nonlinear solve error does not blur the order.
pub fn integrator(method: Method) -> Box<dyn Integrator> {
    let mut settings = IntegratorSettings {
        method,
        ..Default::default()
    };
    settings.newton.tolerance = 1e-11;
    settings.newton.max_iterations = 30;
    settings.newton.require_convergence = true;
    settings.build()
}

/// Integrate from `start` to time `t_end` with `steps` equal steps.
pub fn integrate(
    model: &mut Model,
    method: Method,
    start: &State,
    t_end: f64,
    steps: usize,
) -> State {
    let mut integ = integrator(method);
    let mut state = start.clone();
    let dt = t_end / steps as f64;
    for _ in 0..steps {
        integ
            .step(model, &mut state, dt)
            .unwrap_or_else(|e| panic!("{method}: {e}"));
    }
    state
}

/// The largest angular frequency of the linearized system at rest, sqrt(max eig(M^-1 K)),
/// by a dense generalized eigen-solve (small models only).
pub fn omega_max(model: &mut Model) -> f64 {
    let q = model.rest_state();
    let mut k = model.new_hessian();
    model.hessian(&q, &mut k, Default::default()).unwrap();
    let softbench::model::MassMatrix::Consistent(m) = model.mass() else {
        panic!("consistent mass expected")
    };
    let l = m.to_dense().cholesky().unwrap().l();
    let l_inv = l.try_inverse().unwrap();
    let a = &l_inv * k.to_dense() * l_inv.transpose();
    let a = (&a + a.transpose()) * 0.5;
    a.symmetric_eigenvalues().max().sqrt()
}

/// ‖a − b‖₂.
pub fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// A zero-rest-length spring pulling vertex `vertex` towards a point moving on a circle —
/// a smooth, time-dependent per-vertex potential.
#[derive(Debug)]
pub struct MovingAnchor {
    pub vertex: usize,
    pub stiffness: f64,
    pub center: Vector3<f64>,
    pub radius: f64,
    pub angular_speed: f64,
}

impl MovingAnchor {
    fn target(&self, t: f64) -> Vector3<f64> {
        let a = self.angular_speed * t;
        self.center + Vector3::new(0.0, a.cos() - 1.0, a.sin()) * self.radius
    }
}

impl softbench::model::VertexPotential for MovingAnchor {
    fn name(&self) -> &str {
        "anchor"
    }

    fn energy(&self, t: f64, x: &[Vector3<f64>]) -> f64 {
        0.5 * self.stiffness * (x[self.vertex] - self.target(t)).norm_squared()
    }

    fn gradient(&self, t: f64, x: &[Vector3<f64>], add: &mut dyn FnMut(usize, Vector3<f64>)) {
        add(
            self.vertex,
            (x[self.vertex] - self.target(t)) * self.stiffness,
        );
    }

    fn hessian(
        &self,
        _t: f64,
        _x: &[Vector3<f64>],
        _project: bool,
        add: &mut dyn FnMut(usize, nalgebra::Matrix3<f64>),
    ) {
        add(self.vertex, nalgebra::Matrix3::identity() * self.stiffness);
    }
}

/// The clamped block with its far corner (vertex 5, at x = 0.2) pulled around a circle.
pub fn block_with_moving_anchor() -> Model {
    let mut model = block(true, false);
    let center = model.rest_positions()[5];
    model.add_vertex_potential(Box::new(MovingAnchor {
        vertex: 5,
        stiffness: 50.0,
        center,
        radius: 0.02,
        angular_speed: 40.0,
    }));
    model
}

/// The vertices at the smallest x fixed (a cantilever's clamp).
pub fn clamped_at_min_x() -> FixedSelection {
    FixedSelection {
        rules: vec![AxisRule {
            axis: 0,
            side: Side::Min,
            tolerance: 1e-9,
        }],
        ..Default::default()
    }
}
