//! `shards/K-of-N/shard.json`: what one shard of a study is doing or did — which study file
//! (absolute, so a merge on another node finds it), its runs, the machine, when it started
//! and finished — written when the shard starts and again when it ends. A merge lists these
//! records in `meta.json` and `report.md`.

use crate::study::vocabulary::format::now_utc;
use crate::study::vocabulary::machine::Machine;
use crate::study::vocabulary::shard::Shard;
use crate::study::vocabulary::spec::{RunSpec, Study};
use softbench_run::io::write_atomic;
use std::path::{Path, PathBuf};

/// One shard's record.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct ShardRecord {
    /// K of `--shard K/N`.
    pub shard: usize,
    /// N of `--shard K/N`.
    pub of: usize,
    /// `running` (or killed: no end was recorded), `finished`, `interrupted` or `failed`.
    pub status: String,
    /// The host that ran it, and the process.
    pub host: String,
    pub pid: u32,
    pub machine: Machine,
    /// The study file, absolute; `--quick` or not.
    pub study_file: PathBuf,
    pub quick: bool,
    pub command: Vec<String>,
    pub jobs: usize,
    pub started: String,
    pub started_epoch: u64,
    pub finished: Option<String>,
    pub finished_epoch: Option<u64>,
    pub wall_seconds: Option<f64>,
    /// The shard's runs (by id) and their estimated cost (see [`crate::study::vocabulary::shard`]).
    pub runs: Vec<String>,
    pub estimated_cost: f64,
    /// Runs executed by this invocation, and reused from earlier ones.
    pub ran: usize,
    pub reused: usize,
}

impl ShardRecord {
    /// The record of a shard starting now.
    #[allow(clippy::too_many_arguments)]
    pub(in crate::study) fn start(
        study: &Study,
        shard: Shard,
        runs: &[&RunSpec],
        estimated_cost: f64,
        jobs: usize,
        machine: &Machine,
        started: &str,
        started_epoch: u64,
    ) -> Self {
        Self {
            shard: shard.index,
            of: shard.count,
            status: "running".into(),
            host: softbench_run::lock::hostname(),
            pid: std::process::id(),
            machine: machine.clone(),
            study_file: std::path::absolute(&study.path).unwrap_or_else(|_| study.path.clone()),
            quick: study.quick,
            command: std::env::args().collect(),
            jobs,
            started: started.to_owned(),
            started_epoch,
            finished: None,
            finished_epoch: None,
            wall_seconds: None,
            runs: runs.iter().map(|r| r.id.clone()).collect(),
            estimated_cost,
            ran: 0,
            reused: 0,
        }
    }

    /// Record the end of the shard.
    pub(in crate::study) fn end(
        &mut self,
        status: &str,
        elapsed: std::time::Duration,
        ran: usize,
        reused: usize,
    ) {
        self.status = status.to_owned();
        self.finished = Some(now_utc());
        self.finished_epoch = Some(crate::study::vocabulary::format::epoch_seconds());
        self.wall_seconds = Some(elapsed.as_secs_f64());
        self.ran = ran;
        self.reused = reused;
    }

    /// Write `shard.json` into the shard's folder (atomically).
    pub(in crate::study) fn write(&self, folder: &Path) -> std::io::Result<()> {
        write_atomic(&folder.join("shard.json"), |w| {
            serde_json::to_writer_pretty(&mut *w, self)?;
            writeln!(w)
        })
    }

    /// The shard folders of a study folder (`shards/K-of-N`), by N then K.
    pub(in crate::study) fn folders(dir: &Path) -> std::io::Result<Vec<(Shard, PathBuf)>> {
        let entries = match std::fs::read_dir(dir.join("shards")) {
            Ok(e) => e,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
            Err(e) => return Err(e),
        };
        let mut folders = Vec::new();
        for entry in entries {
            let entry = entry?;
            if let Some(shard) = Shard::from_folder_name(&entry.file_name().to_string_lossy())
                && entry.file_type()?.is_dir()
            {
                folders.push((shard, entry.path()));
            }
        }
        folders.sort_by_key(|(s, _)| (s.count, s.index));
        Ok(folders)
    }

    /// The shards (`K/N`) of `count` shards in `quick` mode whose record says `running`:
    /// still at work, writing their end, or killed.
    pub(in crate::study) fn unended(
        dir: &Path,
        count: usize,
        quick: bool,
    ) -> std::io::Result<Vec<String>> {
        Ok(Self::read_all(dir)?
            .into_iter()
            .filter(|r| r.of == count && r.quick == quick && r.status == "running")
            .map(|r| format!("{}/{}", r.shard, r.of))
            .collect())
    }

    /// Every shard record of a study folder, by N then K (a folder without a readable
    /// record is skipped: its shard never got past its start).
    pub(in crate::study) fn read_all(dir: &Path) -> std::io::Result<Vec<Self>> {
        let mut records = Vec::new();
        for (_, folder) in Self::folders(dir)? {
            let Ok(text) = std::fs::read_to_string(folder.join("shard.json")) else {
                continue;
            };
            if let Ok(record) = serde_json::from_str(&text) {
                records.push(record);
            }
        }
        Ok(records)
    }
}
