//! `summary.json`: what `simulate` ran (scene, resolved configuration) and how the run went.

use std::io::{self, Write};
use std::path::Path;

use serde::{Serialize, Serializer};

use crate::run::RunSummary;
use crate::scene::SceneConfig;
use softbench_core::model::DofCounts;

/// The document `simulate` writes to `summary.json`.
#[derive(Debug, Serialize)]
pub struct SummaryFile<'a> {
    /// The softbench that ran it.
    pub softbench_version: &'a str,
    /// The scene's name.
    pub scene: &'a str,
    /// The scene file.
    pub scene_file: &'a Path,
    /// The linear solver of a method that uses one (`null` otherwise).
    pub linear_solver: Option<String>,
    /// The body's vertices, how many are fixed, and its free and fixed DOFs.
    pub dofs: DofCounts,
    /// Springs of a mass-spring body per kind (an empty object for a FEM body).
    #[serde(serialize_with = "as_map")]
    pub springs: &'a [(&'static str, usize)],
    /// How the run went.
    pub summary: &'a RunSummary,
    /// The resolved scene (file plus overrides).
    pub config: &'a SceneConfig,
}

fn as_map<S: Serializer>(pairs: &&[(&'static str, usize)], s: S) -> Result<S::Ok, S::Error> {
    s.collect_map(pairs.iter().map(|(k, n)| (k, n)))
}

impl SummaryFile<'_> {
    /// The document as pretty JSON with a final newline. It goes through a
    /// [`serde_json::Value`], whose objects keep their keys sorted, so the file lists every
    /// object's keys in the order it always has.
    pub fn write(&self, w: &mut dyn Write) -> io::Result<()> {
        let value = serde_json::to_value(self).map_err(io::Error::other)?;
        serde_json::to_writer_pretty(&mut *w, &value)?;
        writeln!(w)
    }
}
