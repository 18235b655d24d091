//! The finishing step of an invocation, the same for a whole study and a shard: the table as
//! the runs left it is written, the kind's columns no run filled are said, and then the
//! invocation stops (a failed run: its error; a signal: what was done, to resume) or its
//! strategy finishes the folder.

use crate::study::execute::invocation::StudyRun;
use crate::study::execute::progress::Progress;
use crate::study::execute::shared::SharedWork;
use crate::study::execute::strategy::{Ended, Started, Strategy};
use crate::study::execute::workers::Stop;
use crate::study::kind::{Measure, not_ok};
use crate::study::vocabulary::error::{RunError, io_error as io};
use crate::study::vocabulary::spec::Study;
use crate::study::vocabulary::table::Table;
use softbench_core::interrupt::{self, Signal};
use softbench_run::lock::FolderLock;
use std::collections::BTreeSet;

/// What the runs of an invocation left.
pub(in crate::study) struct Left<'a> {
    /// The invocation's table, all rows written so far.
    pub table: Table,
    /// Why the runs stopped before every one was done, if they did.
    pub stop: Option<Stop>,
    /// A signal that arrived before the runs began.
    pub signal_before: Option<Signal>,
    /// Runs to do now, and runs reused from earlier invocations.
    pub pending: usize,
    pub reused: usize,
    /// Runs of the study that `--only` (or the shard) left out.
    pub skipped: usize,
    /// The names of the cells the runs done now wrote.
    pub filled: BTreeSet<&'static str>,
    pub shared: &'a SharedWork,
}

/// Finish the invocation: see the module documentation.
pub(in crate::study) fn finish(
    study: &Study,
    mut strategy: Box<dyn Strategy>,
    lock: FolderLock,
    started: &Started,
    progress: &Progress,
    left: Left,
) -> Result<StudyRun, RunError> {
    let table_path = strategy.own_dir().join("runs.csv");
    let signal = match left.stop {
        Some(Stop::Failed(e)) => {
            strategy.failed(started, left.pending, left.reused);
            return Err(e);
        }
        Some(Stop::Interrupted(signal)) => Some(left.signal_before.unwrap_or(signal)),
        None => left.signal_before,
    };
    let table = left.table;
    table.write(&table_path).map_err(io(&table_path))?;
    let measured = crate::study::kinds::measure(study.kind);
    let presented = crate::study::kinds::present(study.kind);
    let unfilled_columns = unfilled(measured, &left.filled);
    if !unfilled_columns.is_empty() {
        progress.line(&format!(
            "warning: the {} study kind declares columns none of its runs filled: {} (a \
             defect of the kind; the columns are empty)",
            study.kind,
            unfilled_columns.join(", ")
        ));
    }
    let dir = strategy.results_dir().to_owned();
    if let Some(signal) = signal.or_else(interrupt::requested) {
        let done_now = table.rows.len().saturating_sub(left.reused);
        strategy.interrupted(started, done_now, left.reused)?;
        return Ok(StudyRun {
            dir,
            ran: done_now,
            reused: left.reused,
            skipped: left.skipped,
            not_ok: not_ok(presented, &table),
            interrupted: Some(signal),
            merged: None,
            unfilled_columns: Vec::new(),
        });
    }
    let ended = Ended {
        table: &table,
        ran: left.pending,
        reused: left.reused,
        shared: left.shared,
    };
    let merged = strategy.finish(study, started, &ended, lock)?;
    Ok(StudyRun {
        dir,
        ran: left.pending,
        reused: left.reused,
        skipped: left.skipped,
        not_ok: not_ok(presented, &table),
        interrupted: None,
        merged,
        unfilled_columns,
    })
}

/// The kind's measured columns that no run of `filled` (the names of the cells the runs done
/// now wrote) filled; none when no run was done. The outcome is the runner's own.
fn unfilled(kind: &dyn Measure, filled: &BTreeSet<&'static str>) -> Vec<&'static str> {
    if filled.is_empty() {
        return Vec::new();
    }
    kind.columns()
        .iter()
        .copied()
        .filter(|c| *c != "outcome" && !filled.contains(c))
        .collect()
}
