//! Errors from reading and validating meshes. Every message names the file and, where there
//! is one, the 1-based line.

use std::path::PathBuf;

/// What went wrong while reading a mesh file.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// The file could not be opened or read.
    #[error("{path}: cannot read: {error}")]
    Io {
        path: PathBuf,
        /// The I/O error, shown in the message (and so not also reported as `source()`,
        /// which would print it twice in an error chain).
        error: std::io::Error,
    },
    /// The content is malformed at a given line.
    #[error("{path}:{line}: {message}")]
    Parse {
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        message: String,
    },
    /// The content is malformed as a whole (no line to point at).
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    /// A file needs a companion that cannot be read (a TetGen `.node` without its `.ele`).
    #[error("{path}: needs {companion} next to it, which cannot be read: {error}")]
    MissingCompanion {
        /// The file that was asked for.
        path: PathBuf,
        /// The file it needs.
        companion: PathBuf,
        /// The I/O error, shown in the message (and so not also reported as `source()`,
        /// which would print it twice in an error chain).
        error: std::io::Error,
    },
    /// The format could not be told from the extension or content.
    #[error("{path}: unknown mesh format: {message}")]
    UnknownFormat { path: PathBuf, message: String },
}

impl crate::error_class::Classify for MeshError {
    /// A mesh file that cannot be read, parsed or used is the user's to fix.
    fn class(&self) -> crate::error_class::ErrorClass {
        crate::error_class::ErrorClass::BadInput
    }
}
