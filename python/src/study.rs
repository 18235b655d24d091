//! `run_study`: a study file through the same runner as `softbench run`; the Python side reads
//! its runs.csv.

use std::path::PathBuf;

use pyo3::prelude::*;
use softbench::study;

use crate::errors::IntoPy;

/// Run the study `path` into `out/<study name>/` and return that folder. Finished runs with
/// the same configuration are reused unless `force`. Methods registered from Python run
/// under the study's runner like built-in ones (with `jobs > 1` they take turns at the GIL).
#[pyfunction]
#[pyo3(signature = (path, out, quick=false, jobs=1, only=None, force=false, data_dir=None, threads=None))]
#[allow(clippy::too_many_arguments)]
pub fn run_study(
    py: Python<'_>,
    path: PathBuf,
    out: PathBuf,
    quick: bool,
    jobs: usize,
    only: Option<String>,
    force: bool,
    data_dir: Option<PathBuf>,
    threads: Option<usize>,
) -> PyResult<String> {
    let data = crate::scene::data_paths(data_dir);
    if jobs == 0 {
        return Err(crate::BadInputError::new_err("jobs must be at least 1"));
    }
    py.detach(|| -> Result<String, softbench::error::Error> {
        let loaded = study::load(&path, quick, &data)?;
        let options = study::RunOptions {
            dir: out.join(&loaded.file.name),
            only,
            jobs,
            force,
            progress: false,
            wait: false,
            shard: None,
            threads,
        };
        let done = study::run(&loaded, &options)?;
        Ok(done.dir.to_string_lossy().into_owned())
    })
    .py_err()
}
