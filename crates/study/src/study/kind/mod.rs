//! What the generic study code asks of a study kind. Each kind is one file (`trajectory.rs`,
//! `work_precision.rs`, `stability.rs`) with a type implementing [`Kind`]: its `runs.csv`
//! columns, how it checks and adapts its runs, how one run is measured, what its rows'
//! verdicts are, its charts, its report paragraphs and its quick table. `kinds.rs` lists them.
//!
//! Dependencies point one way: this trait sees the study's vocabulary (files, rows, tables,
//! references, chart helpers) and nothing that orchestrates studies, and the orchestrators
//! (load, runner, shared work, merge, report, plots) see kinds only through this trait.

use crate::study::present::charts::{Emit, SceneRows};
use crate::study::present::findings::Ranking;
use crate::study::present::pictures::PictureRows;
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::context::Context;
use crate::study::vocabulary::error::StudyError;
use crate::study::vocabulary::grid::Axis;
use crate::study::vocabulary::measured::Measured;
use crate::study::vocabulary::meta::StudyMeta;
use crate::study::vocabulary::meter::StepMeter;
use crate::study::vocabulary::reference::{Reference, ScoringSettings};
use crate::study::vocabulary::spec::{RunSpec, Study};
use crate::study::vocabulary::table::Table;
use softbench_core::parallel::Parallelism;
use softbench_run::plot::PlotError;
use softbench_run::run::OutcomeKind;
use softbench_run::scene::SceneConfig;
use std::path::Path;

/// A study kind: what one run measures and how its results are shown. Methods with a
/// default are the plain case (no settings table, no references, no charts of its own).
pub(in crate::study) trait Kind: Sync {
    /// The kind's name in study files (`study = "..."`, `[sweep] kind = "..."`).
    fn name(&self) -> &'static str;

    /// One line for `softbench list`: what a run of this kind measures.
    fn description(&self) -> &'static str;

    /// The tables a minimal study of this kind adds to `name`, `study` and `scenes`: its
    /// settings table and the grid it needs. `tests/study_kinds.rs` runs every registered kind
    /// from it, and the docs show it.
    fn example(&self) -> &'static str;

    /// What the kind's scenes add to a plain scene file (the suite's `[problem]` table);
    /// empty for kinds that run any scene.
    fn scene_example(&self) -> &'static str {
        ""
    }

    /// The measured columns of `runs.csv` (after the identity and parameter columns): its
    /// own, then the groups of [`crate::study::vocabulary::columns`] its runs fill (made by
    /// [`crate::study::vocabulary::columns::declare`]). Every run fills every one of them, and nothing else.
    fn columns(&self) -> &'static [&'static str];

    /// The kind's own columns: those no group of [`crate::study::vocabulary::columns`] names. A results table
    /// read back must have them (the groups grow as runs report more).
    fn own_columns(&self) -> &'static [&'static str] {
        self.columns()
    }

    /// The report's summary table columns (those present in runs.csv are shown).
    fn summary_columns(&self) -> &'static [&'static str];

    /// The metrics a sweep plots when the study names none.
    fn sweep_metrics(&self) -> &'static [&'static str];

    /// What the progress line adds after a finished run's outcome (", error 1e-3").
    fn progress(&self, _: &Measured) -> Option<String> {
        None
    }

    /// The names its settings table may have at the top level of a study file, the first the
    /// usual one (none: the kind has no table).
    fn table_names(&self) -> &'static [&'static str] {
        &[]
    }

    /// Its settings table parsed out of the study file's `text` (the rest of the file is
    /// ignored here), with defaults filled in, as JSON; null when the file has none. Errors
    /// name the line.
    fn parse_table(&self, _text: &str) -> Result<serde_json::Value, toml::de::Error> {
        Ok(serde_json::Value::Null)
    }

    /// The kind's settings table as hashed into every run's hash (null when it has none).
    fn settings_json(&self, file: &StudyFile) -> serde_json::Value {
        file.tables
            .get(self.name())
            .cloned()
            .unwrap_or(serde_json::Value::Null)
    }

    /// What `--quick` does to the kind's runs, for the report's quick-mode notice.
    fn quick_notice(&self) -> &'static str;

    /// Checks of the kind's settings table (`bad` makes the error for a key).
    fn check(
        &self,
        _: &StudyFile,
        _: &Context,
        _: &dyn Fn(&str, String) -> StudyError,
    ) -> Result<(), StudyError> {
        Ok(())
    }

    /// The `[quick]` keys the kind reads (besides `set`, which every kind applies).
    fn quick_keys(&self) -> &'static [&'static str] {
        &[]
    }

    /// Its `[quick]` keys parsed out of the study file's `text` (the rest is ignored here) as a
    /// JSON object, null where the file does not set them. Errors name the line.
    fn parse_quick(
        &self,
        _text: &str,
    ) -> Result<serde_json::Map<String, serde_json::Value>, toml::de::Error> {
        Ok(serde_json::Map::new())
    }

    /// Checks of the values of its `[quick]` keys, for every study whatever its kind and
    /// whether or not `--quick` is given, so a study file is valid or not.
    fn check_quick_values(
        &self,
        _: &StudyFile,
        _: &dyn Fn(&str, String) -> StudyError,
    ) -> Result<(), StudyError> {
        Ok(())
    }

    /// Checks of `[quick]` when this kind measures the study, whether or not `--quick` is
    /// given (a key another kind reads that this one refuses).
    fn check_quick(&self, _: &StudyFile, _: &Context) -> Result<(), StudyError> {
        Ok(())
    }

    /// `[quick]` applied to the kind's own settings table. Called for every registered kind
    /// in quick mode, whatever the study's kind, since meta.json records every table as
    /// resolved.
    fn quick_table(&self, _: &mut StudyFile, _: &Context) -> Result<(), StudyError> {
        Ok(())
    }

    /// In quick mode, what the kind drops from each method's axes.
    fn quick_axes(&self, _: &StudyFile, _: &mut [Vec<Axis>]) {}

    /// Adapt one run's resolved scene to the kind (`quick` applies `[quick]`); `axes` are the
    /// grid axes, for error lines.
    fn configure(
        &self,
        _ctx: &Context,
        _file: &StudyFile,
        _config: &mut SceneConfig,
        _axes: &[Axis],
        _quick: bool,
    ) -> Result<(), StudyError> {
        Ok(())
    }

    /// Scene keys the kind decides for every run itself (see [`OwnKey`]): loading refuses a
    /// grid over one, and a `[set]` of one it replaces.
    fn own_keys(&self) -> &'static [OwnKey] {
        &[]
    }

    /// The horizon every run covers whatever the scene's `run.steps` says, with how its
    /// steps follow from it (`"horizon / dt steps of each run.dt of the dt ladder"`): a scene
    /// whose own horizon differs gets a warning saying so. `None`: the kind runs the scene's.
    fn horizon(&self, _: &StudyFile) -> Option<(f64, &'static str)> {
        None
    }

    /// Roughly how many steps one run takes (its trials together, for a stability search):
    /// the cost estimate that balances `--shard` (only ratios between runs matter).
    fn estimated_steps(&self, _: &StudyFile, config: &SceneConfig) -> f64 {
        config.run.steps as f64
    }

    /// Whether the runs need the highest mode of each scene before they start.
    fn needs_omega(&self, _: &StudyFile) -> bool {
        false
    }

    /// Scene files or folders the kind adds to the study's `scenes` (relative to the study
    /// file), e.g. the suite's private problem folders.
    fn extra_scenes(&self, _: &StudyFile) -> Vec<String> {
        Vec::new()
    }

    /// Whether a scene the study names takes part (`quick`: in quick mode).
    fn keeps_scene(&self, _: &StudyFile, _scene: &str, _quick: bool) -> bool {
        true
    }

    /// Methods the kind runs besides the study's `[[methods]]` entries, each with its default
    /// settings (the suite's `methods = "all"`: every registered method).
    fn extra_methods(&self, _: &StudyFile) -> Vec<softbench_core::integrate::Method> {
        Vec::new()
    }

    /// What the kind's settings leave out of the study on purpose (the suite's `omit`), for
    /// the omissions list.
    fn declared_omissions(&self, _: &StudyFile) -> Vec<crate::study::vocabulary::spec::Omission> {
        Vec::new()
    }

    /// The cut-off levels of the kind's runs, loosest first (a suite's; empty for others).
    fn levels(&self, _: &StudyFile) -> Vec<String> {
        Vec::new()
    }

    /// Whether a run that cannot run its scene (the method refuses the model, or an optional
    /// scene's data is missing) is left out of the study with the reason (see
    /// [`Study::omitted`]) instead of failing the load.
    fn leaves_out_what_cannot_run(&self) -> bool {
        false
    }

    /// The settings of the reference solution `spec` is scored against, if the study computes
    /// any (a kind whose scenes state their own protocol gives each its own).
    fn reference_settings(&self, _: &StudyFile, _spec: &RunSpec) -> Option<ScoringSettings> {
        None
    }

    /// The reference step for the physics of a run (asked only when
    /// [`Kind::reference_settings`] gives settings).
    fn reference_dt(&self, _: &Study, w: &ScoringSettings, _: &RunSpec) -> f64 {
        w.horizon / 4000.0
    }

    /// Whether the runs go on without a reference that failed (else the study stops).
    fn reference_optional(&self) -> bool {
        false
    }

    /// Measure one run with what the runs share.
    fn measure(
        &self,
        study: &Study,
        spec: &RunSpec,
        inputs: &RunInputs,
        parallelism: Parallelism,
    ) -> Result<Measured, String>;

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

/// A scene key a kind decides for its runs (see [`Kind::own_keys`]). A grid over it would
/// only repeat one run under several ids; a value the study's `[set]` gives one the kind
/// replaces would be dropped without a word.
#[derive(Clone, Copy, Debug)]
pub(in crate::study) struct OwnKey {
    /// The dotted scene key (`run.dt`); its sub-keys are covered too.
    pub key: &'static str,
    /// What decides it instead, for the message: "the search chooses each trial's step".
    pub why: &'static str,
    /// Whether the kind replaces the value (so `[set]` of it is refused too), rather than
    /// leaving it unused (a scene needs `run.steps` even where the kind ignores it, so
    /// `[set]` may give it).
    pub replaced: bool,
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

/// What one run gets from the work the runs share (its scene's highest mode and its
/// reference solution), and where it counts its steps for the ETA.
pub(in crate::study) struct RunInputs<'a> {
    pub omega: Option<f64>,
    pub reference: Option<&'a Reference>,
    /// Where the run's trajectories count their steps (`measured::run_observed`); none
    /// outside a study's runner.
    pub meter: Option<&'a StepMeter>,
}

/// The runs of `table` whose verdict is not clean, with their verdict word.
pub(in crate::study) fn not_ok(kind: &dyn Kind, table: &Table) -> Vec<(String, String)> {
    table
        .rows
        .iter()
        .filter_map(|row| {
            let verdict = kind.verdict(table, row);
            (!verdict.clean).then(|| (row[0].clone(), verdict.word.to_owned()))
        })
        .collect()
}

/// The `[quick]` keys of a kind's `Q` (a struct of `Option`s named as the keys) parsed out of a
/// study file's text: what `Kind::parse_quick` returns.
pub(in crate::study) fn parse_quick<Q>(
    text: &str,
) -> Result<serde_json::Map<String, serde_json::Value>, toml::de::Error>
where
    Q: serde::de::DeserializeOwned + serde::Serialize + Default,
{
    #[derive(serde::Deserialize)]
    #[serde(bound = "Q: serde::de::DeserializeOwned")]
    struct File<Q> {
        #[serde(default = "Option::default")]
        quick: Option<Q>,
    }
    let file: File<Q> = toml::from_str(text)?;
    Ok(match serde_json::to_value(file.quick.unwrap_or_default()) {
        Ok(serde_json::Value::Object(keys)) => keys,
        _ => serde_json::Map::new(),
    })
}

/// A measured number, shortened for a progress line.
pub(in crate::study) fn number(m: &Measured, name: &str) -> Option<String> {
    m.get(name)
        .and_then(|s| s.parse::<f64>().ok())
        .map(crate::study::vocabulary::format::short)
}
