//! `softbench simulate` as a library call: one scene, one integrator, into an output folder
//! (trajectory.csv, final_positions.csv, summary.json; frames/ with an export format;
//! run.snapshots, filmstrip.png and animation.gif with pictures; iterations.csv with
//! `integrator.newton.log_iterations`).
//!
//! [`Simulation::prepare`] builds everything and finds every bad input before anything is
//! written; [`Simulation::run`] runs and writes.

use softbench_core::error_class::{Classify, ErrorClass};
use softbench_core::threads::{Threads, ThreadsError};
use std::path::{Path, PathBuf};

use super::body::BodySurface;
use super::iterations::{ITERATIONS_CSV, IterationRows};
use super::observed::{Frames, ObserveError, Recording, run_observed};
use super::summary::SummaryFile;
use crate::data::DataPaths;
use crate::export::{Display, DisplayError, ExportFormat, FrameContent};
use crate::io::{AtomicFile, write_atomic};
use crate::render::{self, Coloring, RenderError, RunPictures, Snapshots, Surface};
use crate::run::{RunSummary, Sample};
use crate::scene::{self, LoadedScene, Scene, SceneError};
use softbench_core::model::DofCounts;
use softbench_core::parallel::Parallelism;

/// The snapshot file a run with pictures writes into its output folder.
pub const RUN_SNAPSHOTS: &str = "run.snapshots";

/// The folder (inside the output folder) frames are written to.
pub const FRAMES_DIR: &str = "frames";

/// What a simulation writes besides its trajectory, final positions and summary.
#[derive(Clone, Copy, Debug)]
pub struct SimulateOptions {
    /// Frames in this format into `frames/`.
    pub export: Option<ExportFormat>,
    /// A frame every `every` steps (and at step 0 and the last step); at least 1.
    pub every: usize,
    /// Snapshots of the surface ([`RUN_SNAPSHOTS`]) and their pictures.
    pub pictures: bool,
    /// A progress bar on stderr (drawn only when it is a terminal).
    pub progress: bool,
    /// The threads of the run's pool; `None`: the caller's pool (rayon's global one). The
    /// results are the same bits for any count.
    pub threads: Option<usize>,
}

/// Why a simulation could not be prepared or its results written.
#[derive(Debug, thiserror::Error)]
pub enum SimulateError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Display(#[from] DisplayError),
    /// Pictures were asked for a body without tets.
    #[error("the body has no tets whose surface could be drawn")]
    NoSurface,
    #[error(transparent)]
    Observe(#[from] ObserveError),
    #[error("cannot write {}", path.display())]
    Write {
        path: PathBuf,
        #[source]
        error: std::io::Error,
    },
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    Threads(#[from] ThreadsError),
    /// `frames` in the output folder is a symbolic link or not a folder: frames are never
    /// written (or old ones deleted) through it, since it can point outside the output folder.
    #[error(
        "{} is {what}: --export writes and deletes frames only in a real folder inside \
         --out; remove it (or choose another --out)",
        path.display()
    )]
    FramesNotAFolder { path: PathBuf, what: &'static str },
}

impl Classify for SimulateError {
    /// The input is at fault for a scene, mesh or display mesh that is missing or malformed,
    /// pictures of a body without a surface, or a `frames` that is not a folder; writing and
    /// drawing are the system's.
    fn class(&self) -> ErrorClass {
        match self {
            Self::Scene(e) => e.class(),
            Self::Display(e) => e.class(),
            Self::NoSurface | Self::FramesNotAFolder { .. } => ErrorClass::BadInput,
            Self::Observe(e) => e.class(),
            Self::Render(e) => e.class(),
            Self::Threads(e) => e.class(),
            Self::Write { .. } => ErrorClass::Failure,
        }
    }
}

/// A scene built and ready to run: the model and its integrator, built once, and the
/// surface its frames and pictures show.
pub struct Simulation {
    loaded: LoadedScene,
    scene: Scene,
    body: Option<BodySurface>,
    frames: Option<FrameContent>,
    pictures: Option<Surface>,
    options: SimulateOptions,
    /// The pool the run steps in.
    threads: Threads,
}

/// What a finished simulation wrote and how its run went.
#[derive(Debug)]
pub struct Simulated {
    /// The scene's name.
    pub name: String,
    pub summary: RunSummary,
    /// Rows written to trajectory.csv.
    pub rows: usize,
    /// Frames written to [`Simulated::frames_dir`].
    pub frames: usize,
    /// The body's vertices, how many are fixed, and its free and fixed DOFs.
    pub dofs: DofCounts,
    /// Springs of a mass-spring body per kind.
    pub spring_counts: Vec<(&'static str, usize)>,
    pub trajectory: PathBuf,
    pub final_positions: PathBuf,
    pub summary_file: PathBuf,
    pub frames_dir: PathBuf,
}

impl Simulation {
    /// Build `loaded` (its data files found through `data`, element loops and linear
    /// solvers run with `parallelism`) and what `options` asks for: every bad input is
    /// found here, before anything is written.
    pub fn prepare(
        loaded: LoadedScene,
        data: &DataPaths,
        parallelism: Parallelism,
        options: SimulateOptions,
    ) -> Result<Self, SimulateError> {
        let threads = Threads::new(options.threads)?;
        let scene = threads.install(|| scene::build(&loaded, data, parallelism))?;
        if options.pictures && scene.surface_tets().is_empty() {
            return Err(SimulateError::NoSurface);
        }
        // The display mesh is read only for what shows it: OBJ frames and pictures.
        let skin = options.pictures || options.export == Some(ExportFormat::Obj);
        let body = (options.pictures || options.export.is_some())
            .then(|| BodySurface::new(&loaded, data, &scene, skin))
            .transpose()?;
        let frames = body
            .as_ref()
            .zip(options.export)
            .map(|(b, format)| b.frame_content(format, &scene));
        let pictures = match &body {
            Some(b) if options.pictures => {
                Some(b.picture_surface(&scene).ok_or(SimulateError::NoSurface)?)
            }
            _ => None,
        };
        Ok(Self {
            loaded,
            scene,
            body,
            frames,
            pictures,
            options,
            threads,
        })
    }

    /// The built scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The display mesh its OBJ frames or pictures show, skinned onto the tets, if any.
    pub fn display(&self) -> Option<&Display> {
        self.body.as_ref().and_then(BodySurface::display)
    }

    /// Run and write the results into `out` (an existing folder the caller holds; files of
    /// a previous run are replaced). A run that blows up is written like any other; its
    /// outcome is in [`Simulated::summary`].
    pub fn run(self, out: &Path) -> Result<Simulated, SimulateError> {
        let threads = self.threads.clone();
        threads.install(|| self.run_here(out))
    }

    /// [`Self::run`] on the calling thread (in the run's pool).
    fn run_here(self, out: &Path) -> Result<Simulated, SimulateError> {
        let Self {
            loaded,
            mut scene,
            frames,
            pictures,
            options,
            ..
        } = self;
        let write_error = |path: &Path| {
            let path = path.to_owned();
            move |error| SimulateError::Write { path, error }
        };
        let frames_dir = out.join(FRAMES_DIR);
        if frames.is_some()
            && let Ok(meta) = std::fs::symlink_metadata(&frames_dir)
            && !meta.is_dir()
        {
            let what = if meta.file_type().is_symlink() {
                "a symbolic link"
            } else {
                "not a folder"
            };
            return Err(SimulateError::FramesNotAFolder {
                path: frames_dir,
                what,
            });
        }
        let trajectory_path = out.join("trajectory.csv");
        let mut trajectory =
            AtomicFile::create(&trajectory_path).map_err(write_error(&trajectory_path))?;
        let mut csv = csv::Writer::from_writer(trajectory.writer());
        let mut rows = 0usize;
        let mut write_row = |row: &Sample| {
            rows += 1;
            csv.serialize(row)
                .map_err(|e| std::io::Error::other(format!("{}: {e}", trajectory_path.display())))
        };
        let recording = Recording {
            frames: frames.map(|content| Frames {
                dir: frames_dir.clone(),
                every: options.every,
                content,
            }),
            pictures,
            progress: options.progress,
        };
        let run = scene.config.run;
        let iterations_path = out.join(ITERATIONS_CSV);
        let mut iterations = if scene.config.integrator.newton.log_iterations {
            Some(AtomicFile::create(&iterations_path).map_err(write_error(&iterations_path))?)
        } else {
            // A previous run's log would describe another run.
            match std::fs::remove_file(&iterations_path) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    return Err(write_error(&iterations_path)(e));
                }
                _ => None,
            }
        };
        let observed = match iterations.as_mut() {
            Some(file) => {
                let mut rows = IterationRows::new(&mut write_row, file.writer())
                    .map_err(write_error(&iterations_path))?;
                let observed = run_observed(&mut scene, &run, recording, &mut rows)?;
                rows.flush().map_err(write_error(&iterations_path))?;
                observed
            }
            None => run_observed(&mut scene, &run, recording, &mut write_row)?,
        };
        if let Some(file) = iterations {
            file.commit().map_err(write_error(&iterations_path))?;
        }
        if let Some(snapshots) = &observed.snapshots {
            snapshots.write(&out.join(RUN_SNAPSHOTS))?;
            draw_pictures(out, snapshots, Coloring::VolumeRatio)?;
        }
        csv.flush().map_err(write_error(&trajectory_path))?;
        drop(csv);
        trajectory.commit().map_err(write_error(&trajectory_path))?;

        let positions_path = out.join("final_positions.csv");
        let positions = scene.model.full_positions(&observed.state.q);
        write_atomic(&positions_path, |w| {
            writeln!(w, "vertex,x,y,z")?;
            for (v, p) in positions.iter().enumerate() {
                writeln!(w, "{v},{:e},{:e},{:e}", p.x, p.y, p.z)?;
            }
            Ok(())
        })
        .map_err(write_error(&positions_path))?;

        let config = &scene.config;
        let dofs = scene.model.dofs().counts();
        let summary_path = out.join("summary.json");
        let document = SummaryFile {
            softbench_version: env!("CARGO_PKG_VERSION"),
            scene: &scene.name,
            scene_file: &loaded.path,
            linear_solver: (config.integrator.method.uses_linear_solver())
                .then(|| config.integrator.linear_solver.to_string()),
            dofs,
            springs: &scene.spring_counts,
            summary: &observed.summary,
            config,
        };
        write_atomic(&summary_path, |w| document.write(w)).map_err(write_error(&summary_path))?;
        Ok(Simulated {
            name: scene.name,
            summary: observed.summary,
            rows,
            frames: observed.frames.len(),
            dofs,
            spring_counts: scene.spring_counts,
            trajectory: trajectory_path,
            final_positions: positions_path,
            summary_file: summary_path,
            frames_dir,
        })
    }
}

/// filmstrip.png and animation.gif of one run's snapshots into `dir`.
pub fn draw_pictures(dir: &Path, s: &Snapshots, coloring: Coloring) -> Result<(), RenderError> {
    render::filmstrip(&dir.join("filmstrip.png"), s, coloring)?;
    let one = [RunPictures {
        label: String::new(),
        snapshots: s,
    }];
    render::animation(&dir.join("animation.gif"), &one, coloring)?;
    Ok(())
}
