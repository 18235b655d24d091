//! `load_mesh`: any mesh file softbench reads, as NumPy arrays.

use softbench::error::Context;
use std::path::PathBuf;

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2};
use pyo3::prelude::*;

use crate::errors::IntoPy;

/// Vertices `(n, 3)` and tets `(m, 4)`.
type MeshArrays<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<i64>>);

/// Read a tet mesh: `(vertices (n, 3) float64, tets (m, 4) int64)`. `path` is looked up as
/// given, then in `data_dir` (default: SOFTBENCH_DATA).
#[pyfunction]
#[pyo3(signature = (path, data_dir=None))]
pub fn load_mesh<'py>(
    py: Python<'py>,
    path: PathBuf,
    data_dir: Option<PathBuf>,
) -> PyResult<MeshArrays<'py>> {
    let data = crate::scene::data_paths(data_dir);
    let file = data.resolve_from_cwd(&path).py_err()?;
    let mesh = py
        .detach(|| softbench::mesh::read_tet_mesh(&file))
        .with_context(|| format!("cannot read {}", file.display()))
        .py_err()?;
    let n = mesh.positions.len();
    let flat: Vec<f64> = mesh
        .positions
        .iter()
        .flat_map(|p| [p.x, p.y, p.z])
        .collect();
    let vertices = Array2::from_shape_vec((n, 3), flat).expect("3 coordinates per vertex");
    let m = mesh.tets.len();
    let ids: Vec<i64> = mesh.tets.iter().flatten().map(|&i| i as i64).collect();
    let tets = Array2::from_shape_vec((m, 4), ids).expect("4 vertices per tet");
    Ok((vertices.into_pyarray(py), tets.into_pyarray(py)))
}
