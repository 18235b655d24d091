//! One run of a scene, the same for `softbench simulate`, every run of a study and a program
//! that uses the library: the scene's model and integrator built once
//! ([`crate::scene::build`]), the observers wired one way ([`run_observed`]: rows, frames,
//! snapshots, progress), one surface for frames and pictures ([`BodySurface`], the
//! `[display]` mesh skinned once), and `simulate`'s outputs with a typed `summary.json`
//! ([`Simulation`], [`SummaryFile`]) and, when a scene asks, `iterations.csv` ([`IterationRows`]). Data paths and parallelism come in as values; nothing
//! here reads the environment.

mod body;
mod iterations;
mod observed;
mod simulation;
mod summary;

pub use body::BodySurface;
pub use iterations::{ITERATIONS_CSV, IterationRows};
pub use observed::{Frames, ObserveError, Observed, Recording, run_observed};
pub use simulation::{
    FRAMES_DIR, RUN_SNAPSHOTS, SimulateError, SimulateOptions, Simulated, Simulation, draw_pictures,
};
pub use summary::SummaryFile;
