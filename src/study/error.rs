//! Why a study could not be loaded or run.

use std::path::PathBuf;

/// A problem with a study file or what it names. Everything here is found before anything is
/// written.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    #[error("{path}: cannot read: {error}")]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    /// Malformed TOML, an unknown key or a wrong type (the message has the line).
    #[error("{path}: {message}")]
    Parse { path: PathBuf, message: String },
    /// A value that is not valid, at `line` of the study file, under `key`.
    #[error("{path}:{line}: {key}: {}", crate::quote::clip_message(.message))]
    Invalid {
        path: PathBuf,
        line: usize,
        key: String,
        message: String,
    },
    /// A scene the study names (or a run's resolved scene) is not valid.
    #[error("{path}:{line}: {key}: {error}")]
    Scene {
        path: PathBuf,
        line: usize,
        key: String,
        error: Box<crate::scene::SceneError>,
    },
}

/// A results folder that cannot be read back (`softbench plot`).
#[derive(Debug, thiserror::Error)]
pub enum ResultsError {
    #[error("{path}: cannot read: {error}")]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("{path}: {message}")]
    Malformed { path: PathBuf, message: String },
}
