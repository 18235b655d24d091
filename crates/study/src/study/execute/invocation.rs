//! One invocation of a study, from the outside: how to run it ([`RunOptions`]), which runs
//! `--only` selects ([`matches`]) and what it did ([`StudyRun`], [`MergeOutcome`]).

use crate::study::vocabulary::shard::Shard;
use std::path::PathBuf;

/// How to run a study.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// The study's results folder (e.g. `results/<study>`).
    pub dir: PathBuf,
    /// Only runs whose id matches this pattern (`*` matches anything; otherwise a substring).
    pub only: Option<String>,
    /// Runs in parallel.
    pub jobs: usize,
    /// Redo runs even when a finished run with the same resolved config exists.
    pub force: bool,
    /// Show a progress bar (on a terminal) or a line per run (otherwise), after the warnings
    /// loading the study found ([`Study::warnings`]).
    pub progress: bool,
    /// When another process holds the folder's lock: wait for it (else stop with an error
    /// naming it).
    pub wait: bool,
    /// Run only this part of the grid (`--shard K/N`): its runs' series go to `series/`, its
    /// table and record to `shards/K-of-N/`, and the shard that finds every run of the study
    /// done merges them (see [`crate::study::execute::merge`]).
    pub shard: Option<Shard>,
    /// The threads of the study's pool, which every run and shared computation (highest
    /// modes, references) runs in; `None`: the caller's pool (rayon's global one). With
    /// `jobs` above 1 each run is sequential, and the count does not matter. The results are
    /// the same bits for any count.
    pub threads: Option<usize>,
}

impl RunOptions {
    /// The whole study into `dir`, one run at a time in the caller's thread pool, resuming
    /// (finished runs reused), without a progress display, not waiting for another holder of
    /// the folder: set the fields that differ.
    pub fn new(dir: PathBuf) -> Self {
        Self {
            dir,
            only: None,
            jobs: 1,
            force: false,
            progress: false,
            wait: false,
            shard: None,
            threads: None,
        }
    }
}

/// What a study invocation did.
#[derive(Clone, Debug)]
pub struct StudyRun {
    pub dir: PathBuf,
    /// Runs executed now.
    pub ran: usize,
    /// Runs reused from a previous invocation.
    pub reused: usize,
    /// Runs left out by `--only`.
    pub skipped: usize,
    /// Runs whose status is not ok.
    pub not_ok: Vec<(String, String)>,
    /// Set when SIGINT/SIGTERM stopped the study: the finished runs are in `runs.csv`, plots
    /// and report are not drawn, and running the same command again resumes.
    pub interrupted: Option<softbench_core::interrupt::Signal>,
    /// For a shard that found every run of the study done: the merge it did, or who else
    /// held the study folder.
    pub merged: Option<MergeOutcome>,
    /// The kind's measured columns that none of the runs done now filled (a defect of the
    /// kind, which declares a column it never writes; a warning line says so). Empty when no
    /// run was done now.
    pub unfilled_columns: Vec<&'static str>,
}

/// What a shard that finished last did about the merge.
#[derive(Clone, Debug)]
pub enum MergeOutcome {
    Merged(crate::study::execute::merge::Merged),
    /// Another process (e.g. another shard merging) holds the study folder.
    Busy(String),
    /// Every run is done but these shards (`K/N`) have not recorded their end yet: each is
    /// still writing (it merges when it ends) or was killed (`softbench merge` then).
    Unended(Vec<String>),
}

/// Whether a run id matches `--only`.
pub fn matches(id: &str, pattern: &str) -> bool {
    if !pattern.contains('*') {
        return id.contains(pattern);
    }
    let parts: Vec<&str> = pattern.split('*').collect();
    let (first, last) = (parts[0], parts[parts.len() - 1]);
    if !id.starts_with(first) || id.len() < first.len() + last.len() || !id.ends_with(last) {
        return false;
    }
    let mut rest = &id[first.len()..id.len() - last.len()];
    for part in &parts[1..parts.len() - 1] {
        match rest.find(part) {
            Some(i) => rest = &rest[i + part.len()..],
            None => return false,
        }
    }
    true
}
