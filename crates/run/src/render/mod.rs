//! Pictures of the body, in pure Rust (no system libraries, no GPU): what a run looked like.
//!
//! A run records [`Snapshots`] (its surface at [`SAMPLES`] simulated times and the obstacles,
//! compact on disk, see [`snapshots`]) through a [`SnapshotRecorder`]; [`film`] draws them as a
//! filmstrip PNG and an animated GIF per run, and for a study one panel PNG and one GIF with
//! the runs of a scene side by side; [`raster`] is the flat-shaded z-buffer rasterizer under
//! them, [`obstacles`] turns obstacles into triangles. Pictures are drawn from the snapshot
//! files only, so `softbench render` can redraw them.

pub mod film;
pub mod obstacles;
pub mod raster;
pub mod recorder;
pub mod snapshots;

use std::path::PathBuf;

pub use film::{Coloring, RunPictures, animation, filmstrip, panel};
pub use recorder::{SAMPLES, SnapshotRecorder, Surface};
pub use snapshots::{SnapshotFrame, Snapshots};

/// File name suffix of a run's snapshots (`series/<run-id>.snapshots` in a study,
/// `snapshots.bin` next to `summary.json` for `simulate`).
pub const SNAPSHOT_EXTENSION: &str = "snapshots";

/// Why a picture could not be made.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("{}: {error}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        error: std::io::Error,
    },
    #[error("{}: not a readable snapshot file: {why}", path.display())]
    Snapshot { path: PathBuf, why: String },
    #[error("cannot draw: {0}")]
    Draw(String),
}

impl softbench_core::error_class::Classify for RenderError {
    fn class(&self) -> softbench_core::error_class::ErrorClass {
        softbench_core::error_class::ErrorClass::Failure
    }
}
