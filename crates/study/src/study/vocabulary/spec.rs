//! What loading a study gives: the [`Study`] and the [`RunSpec`] of every run of its grid.

use crate::study::vocabulary::config::StudyFile;
use softbench_core::integrate::Method;
use softbench_core::solve::LinearSolverKind;
use softbench_run::data::DataPaths;
use softbench_run::scene::LoadedScene;
use std::path::PathBuf;
use toml::Value;

/// A study ready to run: its settings and the runs of its grid.
#[derive(Clone, Debug)]
pub struct Study {
    /// The study file.
    pub path: PathBuf,
    /// The study as written, with `--quick` applied.
    pub file: StudyFile,
    /// The registered kind that measures each run (a sweep's inner kind).
    pub kind: &'static str,
    /// That kind's measured columns of `runs.csv` (after the identity and parameter columns).
    pub kind_columns: &'static [&'static str],
    /// Whether `--quick` shortened it.
    pub quick: bool,
    /// The study file as written.
    pub text: String,
    /// Swept scene keys other than the method and linear solver: the parameter columns.
    pub parameters: Vec<String>,
    /// The runs, in grid order.
    pub runs: Vec<RunSpec>,
    /// What the grid named that is not run, with why (only kinds that leave such runs out
    /// instead of refusing the study: see `Kind::leaves_out_what_cannot_run`).
    pub omitted: Vec<Omission>,
    /// The kind's cut-off levels, loosest first (a suite's; empty for other kinds).
    pub levels: Vec<String>,
    /// What loading found worth saying that is not an error (a scene's `run.steps` the kind
    /// replaces): printed when the study runs, kept in meta.json and report.md.
    pub warnings: Vec<String>,
}

/// A run, or a whole scene, that the study leaves out.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Omission {
    pub scene: String,
    /// `None`: every run of the scene.
    pub method: Option<String>,
    pub reason: String,
}

/// One run of the grid.
#[derive(Clone, Debug)]
pub struct RunSpec {
    /// Unique within the study; names its series file.
    pub id: String,
    /// The scene's name.
    pub scene: String,
    pub method: Method,
    /// `None` for explicit methods (which need no linear solver of their own).
    pub linear_solver: Option<LinearSolverKind>,
    /// The value of each of [`Study::parameters`] (`None` where this run does not set it).
    pub parameters: Vec<Option<Value>>,
    /// The resolved scene: file plus `set`, the grid values and quick settings.
    pub loaded: LoadedScene,
    /// Identifies the resolved run (scene, settings of the study kind, softbench version):
    /// a finished run with the same hash is not run again.
    pub hash: String,
    /// Identifies the physics (everything but integrator and run settings), for the caches of
    /// reference solutions and eigenvalues.
    pub physics: u64,
    /// Free degrees of freedom of the built scene (for the cost estimate that balances shards).
    pub dofs: usize,
    /// Roughly how many steps the run takes (a stability search's trials together), as its
    /// kind estimates it: the cost estimate that balances shards (only ratios matter).
    pub estimated_steps: f64,
    /// Where the scene's data files (meshes, display meshes) are found.
    pub data: DataPaths,
}

impl Study {
    /// The swept parameters that get a column (the time step has its own `dt` column), with the
    /// index into [`RunSpec::parameters`].
    pub(in crate::study) fn parameter_columns(&self) -> Vec<(usize, String)> {
        self.parameters
            .iter()
            .enumerate()
            .filter(|(_, p)| !(p.as_str() == "run.dt" && self.kind_columns.contains(&"dt")))
            .map(|(i, p)| (i, p.clone()))
            .collect()
    }
}
