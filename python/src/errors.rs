//! softbench's errors as Python exceptions: bad input (what the command line answers with exit
//! code 2) is `BadInputError`, anything else `SoftbenchError`; the message is the whole chain
//! of causes, as the command line prints it.

use pyo3::PyErr;

use crate::{BadInputError, SoftbenchError};

/// The Python exception for `err`.
pub fn to_py(err: anyhow::Error) -> PyErr {
    let message = format!("{err:#}");
    if softbench::cli::is_bad_input(&err) {
        BadInputError::new_err(message)
    } else {
        SoftbenchError::new_err(message)
    }
}

/// `Result<T, E>` into `PyResult<T>` through [`to_py`].
pub trait IntoPy<T> {
    fn py_err(self) -> pyo3::PyResult<T>;
}

impl<T, E: Into<anyhow::Error>> IntoPy<T> for Result<T, E> {
    fn py_err(self) -> pyo3::PyResult<T> {
        self.map_err(|e| to_py(e.into()))
    }
}
