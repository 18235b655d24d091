//! `meta.json`: the study, the machine and build, when it ran, and every run's resolved
//! configuration.

use super::format::now_utc;
use super::machine::Machine;
use super::spec::Study;
use crate::io::write_atomic;
use std::path::PathBuf;

/// `meta.json`: what ran, where, when.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Meta {
    pub study: StudyMeta,
    pub machine: Machine,
    pub started: String,
    pub finished: Option<String>,
    pub wall_seconds: Option<f64>,
    pub command: Vec<String>,
    /// The study file (as written and as resolved: its settings) and every run's resolved
    /// scene configuration.
    pub config: serde_json::Value,
    /// For a study run as shards and merged: each shard's record (host, machine, times, runs).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shards: Vec<super::shard_record::ShardRecord>,
    /// Runs of the study that no shard has finished (a merge of an incomplete study).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub missing: Vec<String>,
}

/// The parts of a study the plots and report need.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct StudyMeta {
    pub name: String,
    /// The registered kind that measured the runs.
    pub kind: String,
    /// The study file's `study` (`sweep` for a sweep, else `kind`).
    pub study: String,
    pub description: Option<String>,
    pub file: PathBuf,
    pub quick: bool,
    /// The swept parameter of a sweep, and the metrics to plot against it.
    pub sweep_parameter: Option<String>,
    pub sweep_metrics: Vec<String>,
    pub parameters: Vec<String>,
    /// A suite's cut-off levels, loosest first (empty for other kinds).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub levels: Vec<String>,
    /// What the study left out, with why (see `Study::omitted`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub omitted: Vec<super::spec::Omission>,
}

impl Meta {
    pub(super) fn of(
        study: &Study,
        jobs: usize,
        only: Option<&str>,
        machine: &Machine,
        started: &str,
        elapsed: Option<std::time::Duration>,
    ) -> Self {
        let runs: serde_json::Map<String, serde_json::Value> = study
            .runs
            .iter()
            .map(|r| {
                (
                    r.id.clone(),
                    serde_json::json!({
                        "scene_file": r.loaded.path,
                        "config_hash": r.hash,
                        "scene": r.loaded.config,
                    }),
                )
            })
            .collect();
        let sweep = study.file.sweep.as_ref();
        Self {
            study: StudyMeta {
                name: study.file.name.clone(),
                kind: study.kind.to_owned(),
                study: study.file.study.get_ref().clone(),
                description: study.file.description.clone(),
                file: study.path.clone(),
                quick: study.quick,
                sweep_parameter: sweep.map(|s| s.parameter.clone()),
                sweep_metrics: sweep.map(|s| s.metrics.clone()).unwrap_or_default(),
                parameters: study
                    .parameter_columns()
                    .into_iter()
                    .map(|(_, c)| c)
                    .collect(),
                levels: super::kinds::of(study.kind).levels(&study.file),
                omitted: study.omitted.clone(),
            },
            machine: machine.clone(),
            started: started.to_owned(),
            finished: elapsed.map(|_| now_utc()),
            wall_seconds: elapsed.map(|d| d.as_secs_f64()),
            command: std::env::args().collect(),
            config: {
                let mut config = serde_json::json!({
                    "study_file": study.text,
                    "jobs": jobs,
                    "only": only,
                    "sweep": study.file.sweep,
                    "quick": study.quick.then_some(&study.file.quick),
                    "runs": runs,
                });
                // Every kind's settings table as resolved, under its name with `_` for `-`.
                for (kind, table) in &study.file.tables {
                    config[kind.replace('-', "_")] = table.clone();
                }
                config
            },
            shards: Vec::new(),
            missing: Vec::new(),
        }
    }
}

impl Meta {
    /// Write `meta.json` into `dir` (atomically).
    pub(super) fn write(&self, dir: &std::path::Path) -> std::io::Result<()> {
        write_atomic(&dir.join("meta.json"), |w| {
            serde_json::to_writer_pretty(&mut *w, self)?;
            writeln!(w)
        })
    }
}
