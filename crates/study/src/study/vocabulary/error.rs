//! Why a study could not be loaded or run.

use softbench_core::error_class::{Classify, ErrorClass};
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
    #[error("{path}:{line}: {key}: {}", softbench_core::quote::clip_message(.message))]
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
        error: Box<softbench_run::scene::SceneError>,
    },
    /// A stop was requested (SIGINT or SIGTERM) while the study was being loaded.
    #[error("stopped by {} while loading the study; nothing was written", .0.name())]
    Interrupted(softbench_core::interrupt::Signal),
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

/// Why a study stopped before finishing.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("{path}: cannot write: {error}")]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error(transparent)]
    Results(#[from] ResultsError),
    /// Another process is writing the study's folder.
    #[error(transparent)]
    Lock(#[from] softbench_run::lock::LockError),
    /// A run could not even start (its scene failed to build), or a reference failed.
    #[error("{0}")]
    Run(String),
    /// The study's pool of threads could not be made.
    #[error(transparent)]
    Threads(#[from] softbench_core::threads::ThreadsError),
}

/// The error for a failed write of `path`.
pub(in crate::study) fn io_error(
    path: &std::path::Path,
) -> impl FnOnce(std::io::Error) -> RunError + use<> {
    let path = path.to_owned();
    move |error| RunError::Io { path, error }
}

impl Classify for StudyError {
    /// Everything found while loading a study is the study file's or its scenes' (a stop
    /// requested meanwhile is reported by its signal first).
    fn class(&self) -> ErrorClass {
        ErrorClass::BadInput
    }
}

impl Classify for ResultsError {
    /// A results folder read back (by `softbench plot`, or to resume a study) that is not
    /// what softbench wrote.
    fn class(&self) -> ErrorClass {
        ErrorClass::BadInput
    }
}

impl Classify for RunError {
    /// A study stops on a failed write or run (failures), on a results folder it cannot read
    /// back, or on a lock file that is not softbench's (the input's).
    fn class(&self) -> ErrorClass {
        match self {
            Self::Io { .. } | Self::Run(_) => ErrorClass::Failure,
            Self::Results(e) => e.class(),
            Self::Lock(e) => e.class(),
            Self::Threads(e) => e.class(),
        }
    }
}
