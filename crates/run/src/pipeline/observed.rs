//! One run with its observers wired the one way every caller gets them: the caller's rows,
//! then frames written as the run goes, then snapshots for pictures, then a progress bar.

use std::io;
use std::path::PathBuf;

use crate::export::{Frame, FrameContent, FrameWriter};
use crate::render::{SnapshotRecorder, Snapshots, Surface};
use crate::run::{self, Observer, RunProgress, RunSummary};
use crate::scene::{RunConfig, Scene};
use softbench_core::integrate::State;

/// Frames to write during a run.
#[derive(Debug)]
pub struct Frames {
    /// The folder they go to (created if needed; a previous run's frames are removed).
    pub dir: PathBuf,
    /// A frame every `every` steps (and at step 0 and the last step); at least 1.
    pub every: usize,
    /// What each frame holds.
    pub content: FrameContent,
}

/// What a run records besides the rows its caller keeps.
#[derive(Debug, Default)]
pub struct Recording {
    /// Frames written into a folder as the run goes.
    pub frames: Option<Frames>,
    /// The surface whose [`Snapshots`] are kept for pictures.
    pub pictures: Option<Surface>,
    /// A progress bar on stderr (drawn only when it is a terminal).
    pub progress: bool,
}

/// What a run gives back.
#[derive(Debug)]
pub struct Observed {
    pub summary: RunSummary,
    /// The state the run ended in (how far a run that ended early got).
    pub state: State,
    /// The pictures' snapshots, when [`Recording::pictures`] was given.
    pub snapshots: Option<Snapshots>,
    /// The frames written, when [`Recording::frames`] was given.
    pub frames: Vec<Frame>,
}

/// Why a run's observers failed (a run that blows up is not an error: see
/// [`RunSummary::outcome`]).
#[derive(Debug, thiserror::Error)]
pub enum ObserveError {
    /// The caller's rows could not be kept (e.g. the trajectory file cannot be written).
    #[error("cannot write the output")]
    Rows(#[source] io::Error),
    #[error("cannot write the frames")]
    Frames(#[source] io::Error),
}

impl softbench_core::error_class::Classify for ObserveError {
    /// A row or frame that could not be written.
    fn class(&self) -> softbench_core::error_class::ErrorClass {
        softbench_core::error_class::ErrorClass::Failure
    }
}

/// Run `scene` from its initial state with `run` and the scene's integrator for this run
/// ([`Scene::take_integrator`]), passing every sampled row to `rows` and recording what
/// `recording` asks for.
pub fn run_observed(
    scene: &mut Scene,
    run: &RunConfig,
    recording: Recording,
    rows: &mut dyn Observer,
) -> Result<Observed, ObserveError> {
    let mut integrator = scene.take_integrator();
    let mut state = scene.initial.clone();
    let mut frames = None;
    let rows_out: &mut dyn Observer = match recording.frames {
        Some(f) => frames.insert(
            FrameWriter::new(&f.dir, f.every, run.steps, f.content, rows)
                .map_err(ObserveError::Frames)?,
        ),
        None => rows,
    };
    let mut recorder = None;
    let observer: &mut dyn Observer = match recording.pictures {
        Some(surface) => recorder.insert(SnapshotRecorder::new(
            &scene.model,
            &state,
            surface,
            scene.contact.as_ref().map(|c| c.obstacles().clone()),
            (run.steps, run.dt),
            rows_out,
        )),
        None => rows_out,
    };
    let summary = if recording.progress {
        let horizon = state.t + run.dt * run.steps as f64;
        let mut progress = RunProgress::new(observer, run.steps, horizon, true);
        let summary = run::run(
            &mut scene.model,
            integrator.as_mut(),
            &mut state,
            run,
            &mut progress,
        );
        progress.finish();
        summary
    } else {
        run::run(
            &mut scene.model,
            integrator.as_mut(),
            &mut state,
            run,
            observer,
        )
    }
    .map_err(ObserveError::Rows)?;
    let snapshots = recorder.map(|r| r.finish(&scene.model, &summary.outcome));
    let frames = match frames {
        Some(f) => f
            .finish(&scene.model, &state, summary.steps_completed)
            .map_err(ObserveError::Frames)?,
        None => Vec::new(),
    };
    Ok(Observed {
        summary,
        state,
        snapshots,
        frames,
    })
}
