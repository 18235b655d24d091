//! `simulate`: one scene through the same pipeline as `softbench simulate`, into a folder the
//! Python side reads back (trajectory.csv, final_positions.csv, summary.json, and VTU frames
//! when positions over time are asked for).

use softbench::error::Failure;
use std::path::PathBuf;

use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray1, PyArray3};
use pyo3::prelude::*;
use softbench::export::ExportFormat;
use softbench::parallel::Parallelism;
use softbench::pipeline::{SimulateOptions, Simulation};

use crate::errors::IntoPy;
use crate::scene::SceneSource;

/// What a simulation wrote: its folder and, with `every`, the positions of every vertex at the
/// frames (`(frames, n, 3)`) and their times.
type Simulated<'py> = (
    String,
    Option<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray3<f64>>)>,
);

/// Run a scene and write its outputs into `out` (which must exist). With `every`, also a
/// frame every `every` steps (and the first and last), returned as arrays. Raises
/// `BadInputError` for a bad scene; a run that blows up is a result (see its summary).
#[pyfunction]
#[pyo3(signature = (out, path=None, table_json=None, base_dir=None, set=Vec::new(), set_json=None, data_dir=None, every=None, threads=None))]
#[allow(clippy::too_many_arguments)]
pub fn simulate<'py>(
    py: Python<'py>,
    out: PathBuf,
    path: Option<PathBuf>,
    table_json: Option<String>,
    base_dir: Option<PathBuf>,
    set: Vec<String>,
    set_json: Option<String>,
    data_dir: Option<PathBuf>,
    every: Option<usize>,
    threads: Option<usize>,
) -> PyResult<Simulated<'py>> {
    let source = SceneSource {
        path,
        table_json,
        base_dir,
        set,
        set_json,
    };
    let data = crate::scene::data_paths(data_dir);
    let done = py
        .detach(|| -> Result<_, softbench::error::Error> {
            let loaded = source.load()?;
            let options = SimulateOptions {
                export: every.map(|_| ExportFormat::Vtu),
                every: every.unwrap_or(1).max(1),
                pictures: false,
                progress: false,
                threads,
            };
            let simulation = Simulation::prepare(loaded, &data, Parallelism::Rayon, options)?;
            let done = simulation.run(&out)?;
            let frames = match every {
                Some(_) => Some(read_frames(&done.frames_dir)?),
                None => None,
            };
            Ok((done.summary_file, frames))
        })
        .py_err()?;
    let (summary_file, frames) = done;
    let frames =
        frames.map(|(times, positions)| (times.into_pyarray(py), positions.into_pyarray(py)));
    Ok((summary_file.to_string_lossy().into_owned(), frames))
}

/// The VTU frames of a run, in order: their times and positions `(frames, n, 3)`.
fn read_frames(dir: &std::path::Path) -> Result<(Vec<f64>, Array3<f64>), softbench::error::Error> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "vtu"))
        .collect();
    files.sort();
    let mut times = Vec::with_capacity(files.len());
    let mut flat = Vec::new();
    let mut n = 0;
    for file in &files {
        let frame = softbench::mesh::vtk::read_vtu_frame(file)?;
        n = frame.mesh.positions.len();
        times.push(frame.time.unwrap_or(f64::NAN));
        flat.extend(frame.mesh.positions.iter().flat_map(|p| [p.x, p.y, p.z]));
    }
    let positions = Array3::from_shape_vec((files.len(), n, 3), flat)
        .failure("the frames do not have the same number of vertices")?;
    Ok((times, positions))
}
