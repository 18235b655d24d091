//! The suite study kind, presenting: verdicts, report paragraphs, charts and pictures.

use super::{Suite, settings};
use crate::study::kind::{Present, Verdict};
use crate::study::present::charts::{Emit, SceneRows};
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::meta::StudyMeta;
use crate::study::vocabulary::table::Table;
use softbench_run::plot::PlotError;
use std::collections::BTreeMap;
use std::fmt::Write;
use std::path::Path;

impl Present for Suite {
    fn summary_columns(&self) -> &'static [&'static str] {
        &[
            "level",
            "solved",
            "failure",
            "error",
            "tolerance",
            "wall_seconds",
            "evaluations",
        ]
    }

    fn sweep_metrics(&self) -> &'static [&'static str] {
        &["error", "evaluations"]
    }

    fn quick_notice(&self) -> &'static str {
        "only the problems `[quick] problems` names run"
    }

    /// Every run answers: solved, or failed with its kind.
    fn verdict<'a>(&self, runs: &'a Table, row: &'a [String]) -> Verdict<'a> {
        let failure = runs.get(row, "failure").unwrap_or_default();
        Verdict {
            word: if failure.is_empty() {
                "solved"
            } else {
                failure
            },
            clean: true,
        }
    }

    fn stopped_early(&self, _: &Table, _: &[String]) -> bool {
        false
    }

    fn failures_note(&self, runs: &Table) -> Option<String> {
        let mut by_kind: BTreeMap<&str, usize> = BTreeMap::new();
        for row in &runs.rows {
            let failure = runs.get(row, "failure").unwrap_or_default();
            if !failure.is_empty() {
                *by_kind.entry(failure).or_default() += 1;
            }
        }
        let failed: usize = by_kind.values().sum();
        let kinds: Vec<String> = by_kind.iter().map(|(k, n)| format!("{k} {n}")).collect();
        Some(format!(
            "{failed} of the {} runs did not solve their problem{}. In a suite a failure is a \
             result: they are counted per method and kind under *Suite aggregates*, and every \
             row's `failure` and `message` are in `runs.csv`.",
            runs.rows.len(),
            if kinds.is_empty() {
                String::new()
            } else {
                format!(" ({})", kinds.join(", "))
            }
        ))
    }

    fn report_settings(&self, out: &mut String, file: &StudyFile) {
        if let Some(s) = settings(file) {
            let _ = writeln!(
                out,
                "Suite: cut-off levels {} (loosest first); methods: {}; Newton convergence {}; \
                 wall time the median of {} run(s). A run **solves** its problem when it reaches \
                 the horizon within the problem's budget with a relative position error within \
                 its tolerance (both are columns of every row).\n",
                s.levels
                    .iter()
                    .map(|l| format!("`{l}`"))
                    .collect::<Vec<_>>()
                    .join(", "),
                if s.methods == "all" {
                    "every registered method, those without a block at their defaults"
                } else {
                    "the listed blocks"
                },
                if s.require_newton_convergence {
                    "required (an unconverged step fails)"
                } else {
                    "not required (unconverged steps are accepted and counted)"
                },
                s.repeats
            );
        }
    }

    fn report_findings(&self, out: &mut String, runs: &Table, study: &StudyMeta) {
        crate::study::kinds::suite::report::report(out, runs, study);
    }

    fn report_runs_table(&self) -> bool {
        false
    }

    fn study_charts(
        &self,
        dir: &Path,
        study: &StudyMeta,
        runs: &Table,
        emit: &mut Emit,
    ) -> Result<(), PlotError> {
        crate::study::kinds::suite::tables::charts(dir, study, runs, emit)
    }

    fn scene_charts(&self, _: &SceneRows, _: &Path, _: &mut Emit) -> Result<(), PlotError> {
        Ok(())
    }

    fn draws_phases(&self) -> bool {
        false
    }
}
