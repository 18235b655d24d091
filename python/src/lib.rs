//! `softbench._native`: the Rust side of the `softbench` Python package. Each module wraps one
//! part of the library for Python; `python/softbench/__init__.py` turns what they return into
//! pandas DataFrames and SciPy sparse matrices. Arrays cross without per-element copies: a
//! vector softbench computed is moved into NumPy (`PyArray1::from_vec`), and arrays passed in
//! are read in place when they are contiguous float64.

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

mod errors;
mod mesh;
mod method;
mod model;
mod peer;
mod scene;
mod simulate;
mod study;

create_exception!(
    _native,
    SoftbenchError,
    PyException,
    "An error softbench reported (the message says what and where)."
);
create_exception!(
    _native,
    BadInputError,
    SoftbenchError,
    "Bad input: a scene, study, mesh or option that is missing or malformed (the command \
     line's exit code 2). Nothing was written."
);

/// The `softbench` command line with every method registered in this process (peers
/// included): `argv` as the binary takes it (the first word is the program's name); returns
/// the exit status. `host` is the command that runs it, written into Slurm job scripts.
#[pyfunction]
fn cli(py: Python<'_>, argv: Vec<String>, host: Vec<std::path::PathBuf>) -> u8 {
    softbench::cli::set_host_command(host);
    py.detach(|| softbench::cli::status(argv))
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("SoftbenchError", m.py().get_type::<SoftbenchError>())?;
    m.add("BadInputError", m.py().get_type::<BadInputError>())?;
    m.add_function(wrap_pyfunction!(mesh::load_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(simulate::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(study::run_study, m)?)?;
    m.add_function(wrap_pyfunction!(method::register_method, m)?)?;
    m.add_function(wrap_pyfunction!(method::methods, m)?)?;
    m.add_function(wrap_pyfunction!(peer::register_peer, m)?)?;
    m.add_function(wrap_pyfunction!(cli, m)?)?;
    m.add_class::<model::Model>()?;
    m.add_class::<method::StepModel>()?;
    Ok(())
}
