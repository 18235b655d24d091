//! The solver study kind, presenting: verdicts, report paragraphs, charts and pictures.

use super::{LADDER_COLUMNS, Solver, TOLERANCES, settings, steps_text};
use crate::study::kind::Present;
use crate::study::present::charts::{Emit, SceneRows, label};
use crate::study::present::findings;
use crate::study::present::findings::{Better, Ranking};
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::table::Table;
use softbench_run::plot::{Chart, LineChart, PlotError, Series};
use softbench_run::run::OutcomeKind;
use std::fmt::Write;
use std::path::Path;

impl Present for Solver {
    fn summary_columns(&self) -> &'static [&'static str] {
        &[
            "outcome",
            "criterion",
            "iterations_1e-4",
            "seconds_1e-4",
            "iterations_1e-8",
            "seconds_1e-8",
            "factorizations_1e-8",
            "final_residual",
            "stops",
        ]
    }

    fn sweep_metrics(&self) -> &'static [&'static str] {
        &["iterations_1e-8", "seconds_1e-8"]
    }

    fn quick_notice(&self) -> &'static str {
        "each solve is capped at fewer iterations (tight tolerances may not be reached)"
    }

    fn report_settings(&self, out: &mut String, file: &StudyFile) {
        if let Some(s) = settings(file) {
            let _ = writeln!(
                out,
                "Solver study: the incremental potentials of steps {} of each scene's \
                 trajectory (its scheme with default Newton settings, converged to a \
                 scaled-gradient tolerance of {:e}, at most {} iterations a step, required), \
                 each solved {} time(s) by every run's components to working precision (past \
                 the energy's round-off with full steps, until one no longer lowers the \
                 gradient) or **{} iterations** (a tolerance not reached within them is \
                 empty). `runs.csv`'s ladder is read under `{}`, summed over the steps; \
                 `series/<run>-solves.csv` has every criterion. Wall seconds run from the \
                 start of a solve to the acceptance of the iterate that meets the tolerance \
                 (the median over the repeats, with the lowest and highest); the first solve \
                 of each repeat includes the linear solver's analysis.\n",
                steps_text(&s.steps),
                s.driver_tolerance,
                s.driver_max_iterations,
                s.repeats,
                s.max_iterations,
                s.criterion,
            );
        }
    }

    fn scene_charts(&self, s: &SceneRows, dir: &Path, emit: &mut Emit) -> Result<(), PlotError> {
        scene_charts(s, dir, emit)
    }

    /// Its rows are solves of frozen steps, not steps of a trajectory.
    fn draws_phases(&self) -> bool {
        false
    }

    /// Time and iterations to each tolerance of the ladder.
    fn rankings(&self, s: &SceneRows, _: Option<&str>) -> Vec<Ranking> {
        rankings(s)
    }
}

/// Residual against iterations and against wall time, one chart of each per solved step.
fn scene_charts(s: &SceneRows, dir: &Path, emit: &mut Emit) -> Result<(), PlotError> {
    let runs = s.runs;
    // Each row's log, read back (a run that failed before solving has none).
    let mut logs = Vec::new();
    for r in s.rows {
        let id = runs.get(r, "run_id").unwrap_or_default();
        let path = dir.join("series").join(format!("{id}-iterations.csv"));
        if let Ok(Some(table)) = Table::read(&path) {
            logs.push((label(runs, s.params, r, &[]), table));
        }
    }
    let Some(criterion) = s.rows.first().and_then(|r| runs.get(r, "criterion")) else {
        return Ok(());
    };
    let mut steps: Vec<usize> = Vec::new();
    for (_, t) in &logs {
        for row in &t.rows {
            if let Some(k) = t.get(row, "step").and_then(|v| v.parse().ok())
                && !steps.contains(&k)
            {
                steps.push(k);
            }
        }
    }
    steps.sort_unstable();
    for step in steps {
        for (x_column, x_label, stem) in [
            ("iteration", "Newton iteration", "residual-iterations"),
            (
                "seconds",
                "wall time from the start of the solve [s]",
                "residual-time",
            ),
        ] {
            let series = logs
                .iter()
                .map(|(name, t)| Series {
                    label: name.clone(),
                    points: t
                        .rows
                        .iter()
                        .filter(|row| t.get(row, "step") == Some(&step.to_string()))
                        .filter_map(|row| {
                            Some((t.number(row, x_column)?, t.number(row, "residual")?))
                        })
                        .collect(),
                    ended: t
                        .rows
                        .iter()
                        .rev()
                        .find(|row| t.get(row, "step") == Some(&step.to_string()))
                        .is_some_and(|row| t.get(row, "stop") != Some("roundoff")),
                })
                .collect();
            let chart = LineChart {
                title: format!("{}: step {step}, {criterion} residual", s.scene),
                x_label: x_label.into(),
                y_label: format!("{criterion} residual"),
                x_log: false,
                y_log: true,
                series,
            };
            emit(
                format!("{stem}-{}-step{step}", s.slug),
                &format!(
                    "The {criterion} residual of each iterate of step {step}'s solve against \
                     the {}, one line per run (log scale); a line ends at working precision \
                     (a full step that no longer lowered the gradient), with a large marker \
                     where it ended otherwise (the iteration cap or a failure).",
                    if x_column == "iteration" {
                        "iteration"
                    } else {
                        "wall time from the start of the solve (the iterate's acceptance)"
                    }
                ),
                Chart::Line(chart),
            )?;
        }
    }
    Ok(())
}

/// The ladder's tolerances the findings rank at: a loose one (what graphics runs use) and a
/// tight one; `runs.csv` has them all.
const RANKED: [usize; 2] = [1, 3];

/// At [`RANKED`] tolerances: wall time (with its range over the repeats) and iterations.
fn rankings(s: &SceneRows) -> Vec<Ranking> {
    let runs = s.runs;
    let mut out = Vec::new();
    let criterion = s
        .rows
        .first()
        .and_then(|r| runs.get(r, "criterion"))
        .unwrap_or("the criterion")
        .to_owned();
    let why = |r: &[String]| -> String {
        let outcome = runs.get(r, "outcome").unwrap_or_default();
        if outcome != OutcomeKind::Completed.name() {
            return outcome.to_owned();
        }
        format!(
            "not reached (stops: {}; cap {} iterations)",
            runs.get(r, "stops").unwrap_or_default(),
            runs.get(r, "solve_max_iterations").unwrap_or_default()
        )
    };
    for level in RANKED {
        let tolerance = TOLERANCES[level];
        let [iterations, seconds, low, high, ..] = LADDER_COLUMNS[level];
        out.extend(findings::ranking_with_spread(
            s,
            format!("wall seconds to reach {criterion} <= {tolerance:e}, over the solved steps"),
            Better::Smaller,
            &|r| runs.number(r, seconds).ok_or_else(|| why(r)),
            &|r| Some((runs.number(r, low)?, runs.number(r, high)?)),
        ));
        out.extend(findings::ranking(
            s,
            format!(
                "Newton iterations to reach {criterion} <= {tolerance:e}, over the solved steps"
            ),
            Better::Smaller,
            &|r| runs.number(r, iterations).ok_or_else(|| why(r)),
        ));
    }
    out
}
