//! `meta.json`: the study, the machine and build, when it ran, and every run's resolved
//! configuration.

use crate::study::vocabulary::format::now_utc;
use crate::study::vocabulary::machine::Machine;
use crate::study::vocabulary::spec::Study;
use softbench_run::io::write_atomic;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// `meta.json`: what ran, where, when.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Meta {
    pub study: StudyMeta,
    pub machine: Machine,
    pub started: String,
    pub finished: Option<String>,
    pub wall_seconds: Option<f64>,
    /// The load average (1, 5, 15 min) when the study finished (the start's is the machine's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub finished_load_average: Option<[f64; 3]>,
    pub command: Vec<String>,
    /// The study file (as written and as resolved: its settings) and every run's resolved
    /// scene configuration: `runs.<id>.scene` and `.integrator` name entries of `scenes` (the
    /// scene without its integrator) and `integrators` (see [`Meta::run_config`]).
    pub config: serde_json::Value,
    /// For a study run as shards and merged: each shard's record (host, machine, times, runs).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shards: Vec<crate::study::vocabulary::shard_record::ShardRecord>,
    /// Runs of the study that no shard has finished (a merge of an incomplete study).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub missing: Vec<String>,
    /// The peer methods the study ran (another package's code), by method name: the package,
    /// its version and the softbench method it implements. Their settings are in each run's
    /// resolved integrator (`integrator.peer`).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub peers: BTreeMap<String, PeerMeta>,
}

/// A peer method as `meta.json` records it.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PeerMeta {
    pub package: String,
    pub version: Option<String>,
    pub twin: Option<String>,
}

/// The peer methods among `study`'s runs.
fn peers_of(study: &Study) -> BTreeMap<String, PeerMeta> {
    study
        .runs
        .iter()
        .filter_map(|r| {
            let method = r.loaded.config.integrator.method;
            method.entry().peer.map(|p| {
                (
                    method.name().to_owned(),
                    PeerMeta {
                        package: p.package.clone(),
                        version: p.version.clone(),
                        twin: p.twin.clone(),
                    },
                )
            })
        })
        .collect()
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
    pub omitted: Vec<crate::study::vocabulary::spec::Omission>,
    /// What loading warned about (see `Study::warnings`); report.md's findings list them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

impl Meta {
    pub(in crate::study) fn of(
        study: &Study,
        jobs: usize,
        only: Option<&str>,
        machine: &Machine,
        started: &str,
        elapsed: Option<std::time::Duration>,
    ) -> Self {
        // Each run's resolved scene, as two parts kept once each: the scene without its
        // integrator (one per scene, mostly) and the integrator settings (one per method
        // block), so a suite of thousands of runs records them in kilobytes, not megabytes.
        let mut scenes = serde_json::Map::new();
        let mut integrators = serde_json::Map::new();
        let part = |table: &mut serde_json::Map<String, serde_json::Value>,
                    value: serde_json::Value| {
            let key = format!(
                "{:016x}",
                crate::study::vocabulary::identity::fnv1a(value.to_string().as_bytes())
            );
            table.entry(key.clone()).or_insert(value);
            key
        };
        let runs: serde_json::Map<String, serde_json::Value> = study
            .runs
            .iter()
            .map(|r| {
                let mut scene = serde_json::to_value(&r.loaded.config).unwrap_or_default();
                let integrator = scene
                    .as_object_mut()
                    .and_then(|o| o.remove("integrator"))
                    .unwrap_or_default();
                (
                    r.id.clone(),
                    serde_json::json!({
                        "scene_file": r.loaded.path,
                        "config_hash": r.hash,
                        "scene": part(&mut scenes, scene),
                        "integrator": part(&mut integrators, integrator),
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
                levels: study.levels.clone(),
                omitted: study.omitted.clone(),
                warnings: study.warnings.clone(),
            },
            machine: machine.clone(),
            started: started.to_owned(),
            finished: elapsed.map(|_| now_utc()),
            wall_seconds: elapsed.map(|d| d.as_secs_f64()),
            finished_load_average: elapsed
                .and_then(|_| crate::study::vocabulary::machine::load_average()),
            command: std::env::args().collect(),
            config: {
                let mut config = serde_json::json!({
                    "study_file": study.text,
                    "jobs": jobs,
                    "only": only,
                    "sweep": study.file.sweep,
                    "quick": study.quick.then_some(&study.file.quick),
                    "runs": runs,
                    "scenes": scenes,
                    "integrators": integrators,
                });
                // Every kind's settings table as resolved, under its name with `_` for `-`.
                for (kind, table) in &study.file.tables {
                    config[kind.replace('-', "_")] = table.clone();
                }
                config
            },
            shards: Vec::new(),
            missing: Vec::new(),
            peers: peers_of(study),
        }
    }
}

impl Meta {
    /// The resolved scene of run `id`, as recorded (also from a meta.json written before the
    /// scenes were kept apart, where `runs.<id>.scene` is the configuration itself).
    pub fn run_config(&self, id: &str) -> Option<serde_json::Value> {
        let run = self.config.get("runs")?.get(id)?;
        match run.get("scene")? {
            serde_json::Value::String(key) => {
                let mut scene = self.config.get("scenes")?.get(key)?.clone();
                let integrator = run
                    .get("integrator")
                    .and_then(|k| self.config.get("integrators")?.get(k.as_str()?))
                    .cloned()
                    .unwrap_or_default();
                scene
                    .as_object_mut()?
                    .insert("integrator".into(), integrator);
                Some(scene)
            }
            inline => Some(inline.clone()),
        }
    }

    /// Write `meta.json` into `dir` (atomically).
    pub(in crate::study) fn write(&self, dir: &std::path::Path) -> std::io::Result<()> {
        write_atomic(&dir.join("meta.json"), |w| {
            serde_json::to_writer_pretty(&mut *w, self)?;
            writeln!(w)
        })
    }
}
