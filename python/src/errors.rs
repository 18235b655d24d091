//! softbench's errors as Python exceptions: bad input (what the command line answers with exit
//! code 2) is `BadInputError`, anything else `SoftbenchError`. The error says which it is
//! ([`softbench::error::Classify`]); the message is the whole chain of causes, as the command
//! line prints it.

use pyo3::PyErr;
use softbench::error::Error;

use crate::{BadInputError, SoftbenchError};

/// The Python exception for `err`.
pub fn to_py(err: Error) -> PyErr {
    let message = err.to_string();
    if err.class().is_bad_input() {
        BadInputError::new_err(message)
    } else {
        SoftbenchError::new_err(message)
    }
}

/// `Result<T, E>` into `PyResult<T>` through [`to_py`], for any error that says its class.
pub trait IntoPy<T> {
    fn py_err(self) -> pyo3::PyResult<T>;
}

impl<T, E: Into<Error>> IntoPy<T> for Result<T, E> {
    fn py_err(self) -> pyo3::PyResult<T> {
        self.map_err(|e| to_py(e.into()))
    }
}
