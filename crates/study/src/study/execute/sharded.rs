//! Running one shard of a study (`--shard K/N`): the shard locks its own folder under
//! `shards/` and keeps its table and record (`shard.json`) there, adds its runs' series to
//! the study's `series/` (the other shards write theirs meanwhile), shares the work the runs
//! share with the other shards under a lock per item, and the shard that finds every run of
//! the study done at its end merges them.

use crate::study::execute::invocation::MergeOutcome;
use crate::study::execute::rows::{is_done, shard_folder};
use crate::study::execute::shared::Source;
use crate::study::execute::strategy::{Ended, Started, Strategy};
use crate::study::vocabulary::error::{RunError, io_error as io};
use crate::study::vocabulary::shard::Shard;
use crate::study::vocabulary::shard_record::ShardRecord;
use crate::study::vocabulary::shared_store::SharedStore;
use crate::study::vocabulary::spec::{RunSpec, Study};
use crate::study::vocabulary::table::Table;
use softbench_run::lock::{FolderLock, Wait};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

/// One shard of a study.
pub(in crate::study) struct Sharded {
    /// The study's results folder.
    dir: PathBuf,
    /// `dir/shards/K-of-N`.
    own: PathBuf,
    shard: Shard,
    /// Show the merge's progress.
    progress: bool,
    /// Written at the start, ended at the end.
    record: Option<ShardRecord>,
}

impl Sharded {
    /// Shard `shard` of the study whose results folder is `dir`.
    pub fn new(dir: &Path, shard: Shard, progress: bool) -> Self {
        Self {
            dir: dir.to_owned(),
            own: shard_folder(dir, shard),
            shard,
            progress,
            record: None,
        }
    }

    /// End the shard's record with `status` and write it.
    fn end(
        &mut self,
        status: &str,
        started: &Started,
        ran: usize,
        reused: usize,
    ) -> Result<(), RunError> {
        let Some(record) = self.record.as_mut() else {
            return Ok(());
        };
        record.end(status, started.clock.elapsed(), ran, reused);
        record.write(&self.own).map_err(io(&self.own))
    }

    /// After the shard's end is recorded: merge if every run of the study is done and every
    /// shard has recorded its end (a merge is idempotent, so any shard that finds it may).
    /// Each shard records its end before it looks, so the last to end sees every record
    /// ended: a merge never lists a shard as `running` that only had its record to write.
    fn merge_if_last(&self, study: &Study) -> Result<Option<MergeOutcome>, RunError> {
        let dir = &self.dir;
        if !crate::study::execute::merge::is_complete(study, dir)? {
            return Ok(None);
        }
        let unended = ShardRecord::unended(dir, self.shard.count, study.quick)
            .map_err(io(&dir.join("shards")))?;
        if !unended.is_empty() {
            return Ok(Some(MergeOutcome::Unended(unended)));
        }
        match crate::study::execute::merge::merge_study(study, dir, Wait::No, self.progress) {
            Ok(m) => Ok(Some(MergeOutcome::Merged(m))),
            Err(RunError::Lock(softbench_run::lock::LockError::Held { holder, .. })) => {
                Ok(Some(MergeOutcome::Busy(holder.to_string())))
            }
            Err(e) => Err(e),
        }
    }
}

impl Strategy for Sharded {
    fn results_dir(&self) -> &Path {
        &self.dir
    }

    fn own_dir(&self) -> &Path {
        &self.own
    }

    fn purpose(&self, study: &Study) -> String {
        format!("run {} --shard {}", study.file.name, self.shard)
    }

    fn label(&self, study: &Study) -> String {
        format!("{} shard {}", study.file.name, self.shard)
    }

    fn assigned<'s>(&self, study: &'s Study) -> (Vec<&'s RunSpec>, Option<f64>) {
        let (runs, cost) = crate::study::vocabulary::shard::runs_of(study, self.shard);
        (runs, Some(cost))
    }

    /// The shard's folder, and in `series/` only the files of its own runs.
    fn remove_stale_partials(&self, assigned: &[&RunSpec]) -> Result<(), RunError> {
        softbench_run::io::remove_stale_partials(&self.own).map_err(io(&self.own))?;
        let own: HashSet<String> = assigned
            .iter()
            .flat_map(|r| {
                let tables = crate::study::vocabulary::measured::SERIES_TABLES
                    .map(|t| format!("{}-{t}.csv", r.id));
                std::iter::once(format!("{}.csv", r.id)).chain(tables)
            })
            .collect();
        let series = self.dir.join("series");
        softbench_run::io::remove_stale_partials_of(&series, |target| own.contains(target))
            .map_err(io(&series))?;
        Ok(())
    }

    fn start(
        &mut self,
        study: &Study,
        assigned: &[&RunSpec],
        estimated_cost: Option<f64>,
        started: &Started,
    ) -> Result<(), RunError> {
        let record = ShardRecord::start(
            study,
            self.shard,
            assigned,
            estimated_cost.unwrap_or(0.0),
            started.jobs,
            &started.machine,
            &started.when,
            started.epoch,
        );
        record.write(&self.own).map_err(io(&self.own))?;
        self.record = Some(record);
        Ok(())
    }

    fn source<'a>(&self, store: &'a SharedStore, _force: bool) -> Result<Source<'a>, RunError> {
        Ok(Source::Stored(store))
    }

    fn table(
        &self,
        _: &Study,
        header: &[String],
        assigned: &[&RunSpec],
        rows: &HashMap<String, Vec<String>>,
    ) -> Table {
        let mut table = Table::new(header.to_vec());
        table.rows = assigned
            .iter()
            .filter(|r| is_done(&self.dir, r, rows))
            .filter_map(|r| rows.get(&r.id).cloned())
            .collect();
        table
    }

    fn failed(&mut self, started: &Started, ran: usize, reused: usize) {
        let _ = self.end("failed", started, ran, reused);
    }

    fn interrupted(
        &mut self,
        started: &Started,
        ran: usize,
        reused: usize,
    ) -> Result<(), RunError> {
        self.end("interrupted", started, ran, reused)
    }

    fn finish(
        mut self: Box<Self>,
        study: &Study,
        started: &Started,
        ended: &Ended,
        lock: FolderLock,
    ) -> Result<Option<MergeOutcome>, RunError> {
        self.end("finished", started, ended.ran, ended.reused)?;
        // The merge reads every shard's folder: this one is done with its own.
        drop(lock);
        self.merge_if_last(study)
    }
}
