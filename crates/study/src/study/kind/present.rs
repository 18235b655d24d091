//! What presenting a study asks of its kind: how a row ended, its rankings and warnings, its
//! report paragraphs, its charts and tables, and which runs its pictures show. Everything here
//! reads the written files (runs.csv, series, meta.json) only.

use crate::study::present::charts::{Emit, SceneRows};
use crate::study::present::findings::Ranking;
use crate::study::present::pictures::PictureRows;
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::meta::StudyMeta;
use crate::study::vocabulary::table::Table;
use softbench_run::plot::PlotError;
use softbench_run::run::OutcomeKind;
use std::path::Path;

/// What the report, the plots and the pictures ask of a study kind.
pub(in crate::study) trait Present: Sync {
    /// The report's summary table columns (those present in runs.csv are shown).
    fn summary_columns(&self) -> &'static [&'static str];

    /// The metrics a sweep plots when the study names none.
    fn sweep_metrics(&self) -> &'static [&'static str];

    /// What `--quick` does to the kind's runs, for the report's quick-mode notice.
    fn quick_notice(&self) -> &'static str;

    /// How a row of `runs.csv` ended: the word the report and the progress show, and whether
    /// the run answered its question. By default the `outcome` column, clean when
    /// `completed`.
    fn verdict<'a>(&self, runs: &'a Table, row: &'a [String]) -> Verdict<'a> {
        let outcome = runs.get(row, "outcome").unwrap_or_default();
        Verdict {
            word: outcome,
            clean: outcome == OutcomeKind::Completed.name(),
        }
    }

    /// Whether a clean row still deserves a line under the report's "Runs that did not
    /// finish cleanly" (an unscored error, a non-monotone limit).
    fn flagged(&self, _: &Table, _: &[String]) -> bool {
        false
    }

    /// Whether a row's `outcome` is how its series file ends (a stability row's is how its
    /// first unstable trial ended, while its series is the trial it reports).
    fn outcome_ends_series(&self) -> bool {
        true
    }

    /// The kind's rankings of one scene's runs, in the order the findings list them
    /// (`damped`: how the scene is damped, if it is).
    fn rankings(&self, _: &SceneRows, _damped: Option<&str>) -> Vec<Ranking> {
        Vec::new()
    }

    /// Warnings the kind's own measurements call for over the whole table (an observed order
    /// above theory).
    fn table_warnings(&self, _: &Table) -> Vec<String> {
        Vec::new()
    }

    /// Whether a row's error is within its reference's own accuracy (not scored).
    fn unscored(&self, _: &Table, _: &[String]) -> bool {
        false
    }

    /// Whether a row stopped before its horizon, which the findings warn about. By default
    /// any outcome but `completed`.
    fn stopped_early(&self, runs: &Table, row: &[String]) -> bool {
        let outcome = runs.get(row, "outcome").unwrap_or_default();
        !outcome.is_empty() && outcome != OutcomeKind::Completed.name()
    }

    /// For a sweep that plots `metric`: a sentence for the chart's caption and a reference
    /// column drawn as a line of its own.
    fn sweep_line(&self, _metric: &str) -> SweepLine {
        SweepLine::default()
    }

    /// The report's notes on the units of the kind's own columns among `shown`.
    fn unit_notes(&self, _runs: &Table, _shown: &dyn Fn(&str) -> bool) -> Vec<String> {
        Vec::new()
    }

    /// What the report adds after the settings paragraph and every cap that can decide a
    /// result.
    fn report_settings(&self, _: &mut String, _: &StudyFile) {}

    /// What the report adds after the references, before the runs (a work-precision study's
    /// observed orders; a suite's aggregates).
    fn report_findings(&self, _: &mut String, _: &Table, _: &StudyMeta) {}

    /// What the report says under "Runs that did not finish cleanly" instead of listing them,
    /// for a kind whose failed runs are results (a suite counts them per method and kind).
    fn failures_note(&self, _: &Table) -> Option<String> {
        None
    }

    /// Whether the report lists every run in a table (a suite's thousands of runs are in
    /// `runs.csv` and its aggregates instead).
    fn report_runs_table(&self) -> bool {
        true
    }

    /// The kind's charts and tables of the whole study (before any scene's), e.g. a suite's
    /// profiles; `dir` is the results folder, where it may write tables of its own.
    fn study_charts(
        &self,
        _dir: &Path,
        _study: &StudyMeta,
        _runs: &Table,
        _emit: &mut Emit,
    ) -> Result<(), PlotError> {
        Ok(())
    }

    /// The kind's own charts of one scene (before the time histories and phases); `dir` is
    /// the results folder, for the tables its runs wrote next to their series.
    fn scene_charts(&self, _: &SceneRows, _dir: &Path, _: &mut Emit) -> Result<(), PlotError> {
        Ok(())
    }

    /// The caption of the energy chart over time, if the kind draws time histories.
    fn energy_caption(&self) -> Option<&'static str> {
        None
    }

    /// Whether time histories get one chart per time step (when the scene has several).
    fn by_time_step(&self) -> bool {
        false
    }

    /// Whether the kind's rows carry time per step by phase (the phase chart), as runs of
    /// trajectories do.
    fn draws_phases(&self) -> bool {
        true
    }

    /// Whether the phase chart shows only each line's run at its smallest dt.
    fn phases_at_smallest_dt(&self) -> bool {
        false
    }

    /// Which runs the pictures of the bodies show.
    fn picture_rows(&self) -> PictureRows {
        PictureRows::All
    }

    /// The columns that hold a run's time step, in order of preference: the first present
    /// labels phase bars and time histories with their dt.
    fn dt_columns(&self) -> &'static [&'static str] {
        &["dt"]
    }
}

/// What a sweep's chart of one metric adds (see [`Kind::sweep_line`]).
#[derive(Clone, Copy, Debug, Default)]
pub(in crate::study) struct SweepLine {
    /// Appended to the caption (starts with a space).
    pub note: &'static str,
    /// A column drawn against the parameter as its own line, and the line's label.
    pub reference: Option<(&'static str, &'static str)>,
}

/// How a row ended, as its kind reads it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(in crate::study) struct Verdict<'a> {
    /// The word shown (an outcome, or a stability verdict).
    pub word: &'a str,
    /// Whether the run answered its question.
    pub clean: bool,
}

/// The runs of `table` whose verdict is not clean, with their verdict word.
pub(in crate::study) fn not_ok(kind: &dyn Present, table: &Table) -> Vec<(String, String)> {
    table
        .rows
        .iter()
        .filter_map(|row| {
            let verdict = kind.verdict(table, row);
            (!verdict.clean).then(|| (row[0].clone(), verdict.word.to_owned()))
        })
        .collect()
}
