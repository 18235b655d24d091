//! Running a whole study in its folder: the study folder is locked, `meta.json` is written at
//! the start (without an end time, so an interrupted study is not taken for a finished one),
//! the work the runs share is kept in `shared/` for a resume, and the end draws the plots,
//! writes the report and completes `meta.json`.

use crate::study::execute::invocation::MergeOutcome;
use crate::study::execute::rows::ordered;
use crate::study::execute::shared::Source;
use crate::study::execute::strategy::{Ended, Started, Strategy};
use crate::study::present::report;
use crate::study::vocabulary::error::{RunError, io_error as io};
use crate::study::vocabulary::meta::Meta;
use crate::study::vocabulary::shared_store::SharedStore;
use crate::study::vocabulary::spec::{RunSpec, Study};
use crate::study::vocabulary::table::Table;
use softbench_run::lock::FolderLock;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The whole study, run in its folder.
pub(in crate::study) struct Local {
    dir: PathBuf,
}

impl Local {
    /// The study whose results folder is `dir`.
    pub fn new(dir: &Path) -> Self {
        Self {
            dir: dir.to_owned(),
        }
    }

    /// `meta.json` of this invocation, with its elapsed time when it has ended.
    fn meta(&self, study: &Study, started: &Started, ended: bool) -> Meta {
        Meta::of(
            study,
            started.jobs,
            started.only,
            &started.machine,
            &started.when,
            ended.then(|| started.clock.elapsed()),
        )
    }
}

impl Strategy for Local {
    fn results_dir(&self) -> &Path {
        &self.dir
    }

    fn own_dir(&self) -> &Path {
        &self.dir
    }

    fn purpose(&self, study: &Study) -> String {
        format!("run {}", study.file.name)
    }

    fn label(&self, study: &Study) -> String {
        study.file.name.clone()
    }

    fn assigned<'s>(&self, study: &'s Study) -> (Vec<&'s RunSpec>, Option<f64>) {
        (study.runs.iter().collect(), None)
    }

    fn remove_stale_partials(&self, _: &[&RunSpec]) -> Result<(), RunError> {
        for folder in [self.dir.clone(), self.dir.join("series")] {
            softbench_run::io::remove_stale_partials(&folder).map_err(io(&folder))?;
        }
        Ok(())
    }

    fn start(
        &mut self,
        study: &Study,
        _: &[&RunSpec],
        _: Option<f64>,
        started: &Started,
    ) -> Result<(), RunError> {
        self.meta(study, started, false)
            .write(&self.dir)
            .map_err(io(&self.dir.join("meta.json")))
    }

    fn source<'a>(&self, store: &'a SharedStore, force: bool) -> Result<Source<'a>, RunError> {
        // Redoing every run redoes the work they share too.
        if force {
            let shared = self.dir.join("shared");
            if shared.is_dir() {
                std::fs::remove_dir_all(&shared).map_err(io(&shared))?;
            }
        }
        Ok(Source::Local(store))
    }

    fn table(
        &self,
        study: &Study,
        header: &[String],
        _: &[&RunSpec],
        rows: &HashMap<String, Vec<String>>,
    ) -> Table {
        ordered(study, header, rows)
    }

    // meta.json stays as written at the start (no end time): the study is not finished.
    fn failed(&mut self, _: &Started, _: usize, _: usize) {}

    fn interrupted(&mut self, _: &Started, _: usize, _: usize) -> Result<(), RunError> {
        Ok(())
    }

    fn finish(
        self: Box<Self>,
        study: &Study,
        started: &Started,
        ended: &Ended,
        _lock: FolderLock,
    ) -> Result<Option<MergeOutcome>, RunError> {
        // Under the study folder's lock to the end.
        let dir = &self.dir;
        let meta = self.meta(study, started, true);
        let plots = crate::study::present::plots::draw_all(dir, &meta.study, ended.table)
            .map_err(|e| RunError::Run(format!("cannot draw the plots: {e}")))?;
        report::write(
            dir,
            study,
            &meta,
            ended.table,
            &plots,
            ended.reused,
            report::References {
                solved: &ended.shared.references,
                failed: &ended.shared.failed_references,
            },
        )
        .map_err(io(&dir.join("report.md")))?;
        meta.write(dir).map_err(io(&dir.join("meta.json")))?;
        Ok(None)
    }
}
