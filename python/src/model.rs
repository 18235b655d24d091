//! `Model`: a built scene's potential, gradient, Hessian and mass at positions Python gives,
//! so a method can be prototyped in Python against softbench's FEM. Coordinates are the free
//! DOFs stacked `[x0 y0 z0 x1 ...]` over the free vertices in order; `full_positions` puts
//! them back among the fixed ones.

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use softbench::model::{HessianOptions, Model as FemModel};
use softbench::parallel::Parallelism;
use softbench::scene::{self, Scene};
use softbench::threads::Threads;

use crate::errors::IntoPy;
use crate::scene::SceneSource;

/// A sparse matrix as SciPy's CSC arrays: `(data, indices, indptr, n)`.
pub type Csc<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
    usize,
);

/// A scene built once: its model and initial state.
#[pyclass(module = "softbench._native", unsendable)]
pub struct Model {
    scene: Scene,
    /// The pool its evaluations run in (`threads=`), or the caller's.
    threads: Threads,
}

impl Model {
    /// The scene's incremental potential contact, or an error saying it has none.
    fn ipc(&self) -> PyResult<&std::sync::Arc<softbench::contact::ipc::Ipc>> {
        self.scene
            .contact
            .as_ref()
            .and_then(|c| c.ipc())
            .ok_or_else(|| {
                crate::BadInputError::new_err(
                    "the scene has no incremental potential contact (contact.response = \"ipc\")",
                )
            })
    }
}

#[pymethods]
impl Model {
    /// Build the scene (mesh, material, fixed vertices, forces, obstacles).
    #[new]
    #[pyo3(signature = (path=None, table_json=None, base_dir=None, set=Vec::new(), set_json=None, data_dir=None, threads=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        path: Option<std::path::PathBuf>,
        table_json: Option<String>,
        base_dir: Option<std::path::PathBuf>,
        set: Vec<String>,
        set_json: Option<String>,
        data_dir: Option<std::path::PathBuf>,
        threads: Option<usize>,
    ) -> PyResult<Self> {
        let threads = Threads::new(threads).py_err()?;
        let source = SceneSource {
            path,
            table_json,
            base_dir,
            set,
            set_json,
        };
        let data = crate::scene::data_paths(data_dir);
        let scene = py
            .detach(|| -> Result<Scene, softbench::error::Error> {
                let loaded = source.load()?;
                Ok(threads.install(|| scene::build(&loaded, &data, Parallelism::Rayon))?)
            })
            .py_err()?;
        Ok(Self { scene, threads })
    }

    /// The scene's name.
    #[getter]
    fn name(&self) -> String {
        self.scene.name.clone()
    }

    /// The scene's initial free coordinates and velocities and start time.
    fn initial_state<'py>(
        &self,
        py: Python<'py>,
    ) -> (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>, f64) {
        let s = &self.scene.initial;
        (
            PyArray1::from_slice(py, &s.q),
            PyArray1::from_slice(py, &s.v),
            s.t,
        )
    }

    /// The scene's time step and number of steps (`run.dt`, `run.steps`).
    fn run_length(&self) -> (f64, usize) {
        (self.scene.config.run.dt, self.scene.config.run.steps)
    }

    fn num_dofs(&self) -> usize {
        self.scene.model.num_dofs()
    }
    fn counts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        counts(py, &self.scene.model)
    }
    fn rest_q<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.scene.model.rest_state().into_pyarray(py)
    }
    fn fixed<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        fixed(py, &self.scene.model)
    }
    fn tets<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<i64>> {
        let tets = self.scene.surface_tets();
        let flat: Vec<i64> = tets.iter().flatten().map(|&i| i as i64).collect();
        Array2::from_shape_vec((tets.len(), 4), flat)
            .expect("4 per tet")
            .into_pyarray(py)
    }
    fn full_positions<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        full_positions(py, &self.scene.model, q)
    }
    fn vertex_masses<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.scene.model.vertex_masses())
    }
    fn energy(&mut self, q: PyReadonlyArray1<'_, f64>) -> PyResult<f64> {
        energy(&mut self.scene.model, q, &self.threads)
    }
    fn energy_parts<'py>(
        &mut self,
        py: Python<'py>,
        q: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        energy_parts(py, &mut self.scene.model, q, &self.threads)
    }
    fn gradient<'py>(
        &mut self,
        py: Python<'py>,
        q: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        gradient(py, &mut self.scene.model, q, &self.threads)
    }
    #[pyo3(signature = (q, projected=false))]
    fn hessian<'py>(
        &mut self,
        py: Python<'py>,
        q: PyReadonlyArray1<'py, f64>,
        projected: bool,
    ) -> PyResult<Csc<'py>> {
        hessian(py, &mut self.scene.model, q, projected, &self.threads)
    }
    fn mass<'py>(&self, py: Python<'py>) -> Csc<'py> {
        mass(py, &self.scene.model)
    }
    fn evaluations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        evaluations(py, &self.scene.model)
    }

    /// softbench's incremental potential contact at every vertex's `positions` (n, 3) and
    /// time `t`: the barrier with κ = 1, its gradient (n, 3), the contacts within d̂ and their
    /// smallest distance, and with a `displacement` (n, 3) its collision-free fraction (CCD).
    /// For comparison with another implementation (ipc-toolkit); the scene must use
    /// `contact.response = "ipc"`.
    #[pyo3(signature = (positions, displacement=None, t=0.0))]
    fn ipc_probe<'py>(
        &self,
        py: Python<'py>,
        positions: numpy::PyReadonlyArray2<'py, f64>,
        displacement: Option<numpy::PyReadonlyArray2<'py, f64>>,
        t: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let ipc = self.ipc()?;
        let n = self.scene.model.rest_positions().len();
        let rows = |a: &numpy::PyReadonlyArray2<'py, f64>, what: &str| {
            let a = a.as_array();
            if a.dim() != (n, 3) {
                return Err(PyValueError::new_err(format!(
                    "{what} must be ({n}, 3), one row per vertex (got {:?})",
                    a.dim()
                )));
            }
            Ok((0..n)
                .map(|i| nalgebra::Vector3::new(a[(i, 0)], a[(i, 1)], a[(i, 2)]))
                .collect::<Vec<_>>())
        };
        let x = rows(&positions, "positions")?;
        let dx = displacement.map(|d| rows(&d, "displacement")).transpose()?;
        let probe = ipc.probe(&x, t, dx.as_deref());
        let d = PyDict::new(py);
        d.set_item("barrier", probe.barrier)?;
        let g = Array2::from_shape_fn((n, 3), |(i, c)| probe.gradient[i][c]);
        d.set_item("gradient", g.into_pyarray(py))?;
        d.set_item("contacts", probe.contacts)?;
        d.set_item("min_distance", probe.min_distance)?;
        d.set_item("step", probe.step)?;
        Ok(d)
    }

    /// The collision mesh softbench's IPC computes on: `num_body` (the body's vertices come
    /// first), `obstacle_positions` (k, 3) (vertices `num_body + i`), the collision `vertices`,
    /// `edges` (E, 2) and `faces` (F, 3) over both, `dhat` and `self_contact`.
    fn ipc_collision_mesh<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let ipc = self.ipc()?;
        let m = ipc.collision_mesh_arrays();
        let d = PyDict::new(py);
        d.set_item("num_body", m.num_body)?;
        let o = &m.obstacle_positions;
        d.set_item(
            "obstacle_positions",
            Array2::from_shape_fn((o.len(), 3), |(i, c)| o[i][c]).into_pyarray(py),
        )?;
        let vertices: Vec<i64> = m.vertices.iter().map(|&v| i64::from(v)).collect();
        d.set_item("vertices", PyArray1::from_vec(py, vertices))?;
        let edges = Array2::from_shape_fn((m.edges.len(), 2), |(e, k)| i64::from(m.edges[e][k]));
        d.set_item("edges", edges.into_pyarray(py))?;
        let faces = Array2::from_shape_fn((m.faces.len(), 3), |(f, k)| i64::from(m.faces[f][k]));
        d.set_item("faces", faces.into_pyarray(py))?;
        let (dhat, self_contact) = ipc.dhat_and_self_contact();
        d.set_item("dhat", dhat)?;
        d.set_item("self_contact", self_contact)?;
        Ok(d)
    }
}

/// `q` as a slice of the model's length.
fn free<'a>(model: &FemModel, q: &'a PyReadonlyArray1<'_, f64>) -> PyResult<&'a [f64]> {
    let q = q
        .as_slice()
        .map_err(|_| PyValueError::new_err("q must be a contiguous float64 array"))?;
    if q.len() != model.num_dofs() {
        return Err(PyValueError::new_err(format!(
            "q has {} entries; the model has {} free DOFs",
            q.len(),
            model.num_dofs()
        )));
    }
    Ok(q)
}

pub fn counts<'py>(py: Python<'py>, model: &FemModel) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let dofs = model.dofs();
    d.set_item("vertices", dofs.num_vertices())?;
    d.set_item("free_vertices", dofs.num_free())?;
    d.set_item("fixed_vertices", dofs.num_vertices() - dofs.num_free())?;
    d.set_item("free_dofs", model.num_dofs())?;
    d.set_item("fixed_dofs", 3 * dofs.num_vertices() - model.num_dofs())?;
    Ok(d)
}

pub fn fixed<'py>(py: Python<'py>, model: &FemModel) -> Bound<'py, PyArray1<bool>> {
    let dofs = model.dofs();
    let fixed: Vec<bool> = (0..dofs.num_vertices()).map(|v| dofs.is_fixed(v)).collect();
    fixed.into_pyarray(py)
}

pub fn full_positions<'py>(
    py: Python<'py>,
    model: &FemModel,
    q: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let x = model.full_positions(free(model, &q)?);
    let flat: Vec<f64> = x.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    Ok(Array2::from_shape_vec((x.len(), 3), flat)
        .expect("3 per vertex")
        .into_pyarray(py))
}

pub fn energy(
    model: &mut FemModel,
    q: PyReadonlyArray1<'_, f64>,
    threads: &Threads,
) -> PyResult<f64> {
    let q = free(model, &q)?;
    threads.install(|| model.potential(q)).py_err()
}

pub fn energy_parts<'py>(
    py: Python<'py>,
    model: &mut FemModel,
    q: PyReadonlyArray1<'py, f64>,
    threads: &Threads,
) -> PyResult<Bound<'py, PyDict>> {
    let q = free(model, &q)?;
    let p = threads.install(|| model.potential_parts(q)).py_err()?;
    let d = PyDict::new(py);
    d.set_item("elastic", p.elastic)?;
    d.set_item("springs", p.springs)?;
    d.set_item("gravity", p.gravity)?;
    d.set_item("vertex", p.vertex)?;
    d.set_item("contact", p.contact)?;
    d.set_item("total", p.total())?;
    Ok(d)
}

pub fn gradient<'py>(
    py: Python<'py>,
    model: &mut FemModel,
    q: PyReadonlyArray1<'py, f64>,
    threads: &Threads,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let q = free(model, &q)?;
    let mut g = vec![0.0; q.len()];
    threads.install(|| model.gradient(q, &mut g)).py_err()?;
    Ok(g.into_pyarray(py))
}

pub fn hessian<'py>(
    py: Python<'py>,
    model: &mut FemModel,
    q: PyReadonlyArray1<'py, f64>,
    projected: bool,
    threads: &Threads,
) -> PyResult<Csc<'py>> {
    let q = free(model, &q)?;
    let mut h = model.new_hessian();
    let options = if projected {
        HessianOptions::projected()
    } else {
        HessianOptions::default()
    };
    threads
        .install(|| model.hessian(q, &mut h, options))
        .py_err()?;
    let p = h.pattern().clone();
    let indptr: Vec<i64> = p.col_ptr().iter().map(|&i| i as i64).collect();
    let indices: Vec<i64> = p.row_idx().iter().map(|&i| i as i64).collect();
    let n = h.dim();
    Ok((
        h.values().to_vec().into_pyarray(py),
        indices.into_pyarray(py),
        indptr.into_pyarray(py),
        n,
    ))
}

pub fn mass<'py>(py: Python<'py>, model: &FemModel) -> Csc<'py> {
    let m = model.mass().to_csc();
    let n = m.nrows();
    let (offsets, rows, values) = m.disassemble();
    let indptr: Vec<i64> = offsets.into_iter().map(|i| i as i64).collect();
    let indices: Vec<i64> = rows.into_iter().map(|i| i as i64).collect();
    (
        values.into_pyarray(py),
        indices.into_pyarray(py),
        indptr.into_pyarray(py),
        n,
    )
}

pub fn evaluations<'py>(py: Python<'py>, model: &FemModel) -> PyResult<Bound<'py, PyDict>> {
    let c = model.counters();
    let d = PyDict::new(py);
    d.set_item("potential", c.potential)?;
    d.set_item("gradient", c.gradient)?;
    d.set_item("hessian", c.hessian)?;
    Ok(d)
}
