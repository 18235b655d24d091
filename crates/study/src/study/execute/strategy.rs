//! What differs between running a whole study and running one shard of it: which runs the
//! invocation owns, where it locks and keeps its table, what it writes when it starts, where
//! the work the runs share comes from, and how it ends. `Local` and `Sharded` implement it;
//! the runner and the finishing step (`finish`) are the same for both.

use crate::study::execute::invocation::MergeOutcome;
use crate::study::execute::shared::{SharedWork, Source};
use crate::study::vocabulary::error::RunError;
use crate::study::vocabulary::machine::Machine;
use crate::study::vocabulary::shared_store::SharedStore;
use crate::study::vocabulary::spec::{RunSpec, Study};
use crate::study::vocabulary::table::Table;
use softbench_run::lock::FolderLock;
use std::collections::HashMap;
use std::path::Path;
use std::time::Instant;

/// When and where an invocation started, and with how many jobs: what `meta.json` or a shard's
/// record says of it.
pub(in crate::study) struct Started<'a> {
    /// UTC time, ISO 8601.
    pub when: String,
    /// The same, in seconds since the Unix epoch.
    pub epoch: u64,
    /// For the elapsed time at the end.
    pub clock: Instant,
    pub machine: Machine,
    pub jobs: usize,
    /// `--only`'s pattern.
    pub only: Option<&'a str>,
}

/// How an invocation's runs went, for its end.
pub(in crate::study) struct Ended<'a> {
    /// The invocation's table as written at the end.
    pub table: &'a Table,
    /// Runs done now.
    pub ran: usize,
    /// Runs reused from earlier invocations.
    pub reused: usize,
    /// The references computed (for the report).
    pub shared: &'a SharedWork,
}

/// A way of running a study's runs.
pub(in crate::study) trait Strategy {
    /// The study's results folder.
    fn results_dir(&self) -> &Path;

    /// The folder this invocation locks and keeps its table (`runs.csv`) in.
    fn own_dir(&self) -> &Path;

    /// What the lock says this process is doing.
    fn purpose(&self, study: &Study) -> String;

    /// How progress lines name the invocation.
    fn label(&self, study: &Study) -> String;

    /// The runs this invocation is for, with their share of the study's estimated cost when
    /// that is not all of it.
    fn assigned<'s>(&self, study: &'s Study) -> (Vec<&'s RunSpec>, Option<f64>);

    /// Remove the temporary files a killed writer left where this invocation owns them (under
    /// the lock, no live writer owns them).
    fn remove_stale_partials(&self, assigned: &[&RunSpec]) -> Result<(), RunError>;

    /// Write what says the invocation started: `meta.json` without an end, or the shard's
    /// record.
    fn start(
        &mut self,
        study: &Study,
        assigned: &[&RunSpec],
        estimated_cost: Option<f64>,
        started: &Started,
    ) -> Result<(), RunError>;

    /// Where the work the runs share comes from: computed here and stored for a resume, or
    /// shared with the other shards under a lock per item. `force` redoes it.
    fn source<'a>(&self, store: &'a SharedStore, force: bool) -> Result<Source<'a>, RunError>;

    /// The table of this invocation's rows: the whole study's in grid order, or the shard's
    /// runs that are done.
    fn table(
        &self,
        study: &Study,
        header: &[String],
        assigned: &[&RunSpec],
        rows: &HashMap<String, Vec<String>>,
    ) -> Table;

    /// A run failed and the invocation stops: say so where the invocation is recorded (best
    /// effort: the failure is what the caller reports).
    fn failed(&mut self, started: &Started, ran: usize, reused: usize);

    /// A signal stopped the invocation after its runs' rows were written.
    fn interrupted(&mut self, started: &Started, ran: usize, reused: usize)
    -> Result<(), RunError>;

    /// Every assigned run is done: write what the invocation leaves (plots, report and
    /// `meta.json` of the study; or the shard's record and, for the last shard, the merge).
    /// `lock` is this invocation's lock on [`Strategy::own_dir`], held until the strategy
    /// lets it go.
    fn finish(
        self: Box<Self>,
        study: &Study,
        started: &Started,
        ended: &Ended,
        lock: FolderLock,
    ) -> Result<Option<MergeOutcome>, RunError>;
}
