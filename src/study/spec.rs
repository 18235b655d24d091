//! What loading a study gives: the [`Study`] and the [`RunSpec`] of every run of its grid.

use super::config::{StudyFile, StudyKind};
use crate::data::DataPaths;
use crate::integrate::Method;
use crate::scene::LoadedScene;
use crate::solve::LinearSolverKind;
use std::path::PathBuf;
use toml::Value;

/// A study ready to run: its settings and the runs of its grid.
#[derive(Clone, Debug)]
pub struct Study {
    /// The study file.
    pub path: PathBuf,
    /// The study as written, with `--quick` applied.
    pub file: StudyFile,
    /// What each run measures (a sweep's inner kind).
    pub kind: StudyKind,
    /// Whether `--quick` shortened it.
    pub quick: bool,
    /// The study file as written.
    pub text: String,
    /// Swept scene keys other than the method and linear solver: the parameter columns.
    pub parameters: Vec<String>,
    /// The runs, in grid order.
    pub runs: Vec<RunSpec>,
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
    /// Where the scene's data files (meshes, display meshes) are found.
    pub data: DataPaths,
}

impl Study {
    /// The swept parameters that get a column (the time step has its own `dt` column), with the
    /// index into [`RunSpec::parameters`].
    pub(super) fn parameter_columns(&self) -> Vec<(usize, String)> {
        self.parameters
            .iter()
            .enumerate()
            .filter(|(_, p)| {
                !(p.as_str() == "run.dt" && super::kinds::spec(self.kind).columns.contains(&"dt"))
            })
            .map(|(i, p)| (i, p.clone()))
            .collect()
    }
}
