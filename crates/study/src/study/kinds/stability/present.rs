//! The stability study kind, presenting: verdicts, report paragraphs, charts and pictures.

use super::{ERROR_COLUMNS, ERROR_TOLERANCES, GROWING_BELOW, ROBUSTNESS, Stability, settings};
use crate::study::kind::{Present, SweepLine, Verdict};
use crate::study::present::charts::{Emit, SceneRows, label};
use crate::study::present::findings;
use crate::study::present::findings::{Better, Ranking};
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::format::short;
use crate::study::vocabulary::table::Table;
use softbench_run::plot::{Bar, BarChart, Chart, LineChart, PlotError, ReferenceLine, Series};
use softbench_run::run::OutcomeKind;
use softbench_run::run::balance::GROWN;
use std::fmt::Write;
use std::path::Path;

impl Present for Stability {
    fn summary_columns(&self) -> &'static [&'static str] {
        &[
            "stability",
            "max_stable_dt",
            "outcome",
            "first_unstable_dt",
            "stable_over_theory",
            "cost_per_simulated_second",
            "evaluations_per_simulated_second",
            "error_at_stable_dt",
            "non_monotone_dt",
            "energy_growth_rate",
            "growth_exponent",
            "limit_robust",
            "dt_error_1pct",
            "dt_error_10pct",
            "newton_unconverged_steps",
            "trials",
        ]
    }

    fn sweep_metrics(&self) -> &'static [&'static str] {
        &["max_stable_dt", "newton_iterations_per_step"]
    }

    fn quick_notice(&self) -> &'static str {
        "the same horizon, judged range and criterion (a verdict at a step is the full \
         study's, and a run's verdict of the same class), but coarser searches and no \
         robustness trials"
    }

    /// The `stability` column: clean when it answers the question (a limit, or stable up to
    /// the ceiling).
    fn verdict<'a>(&self, runs: &'a Table, row: &'a [String]) -> Verdict<'a> {
        let word = runs.get(row, "stability").unwrap_or_default();
        Verdict {
            word,
            clean: ANSWERED.contains(&word),
        }
    }

    /// A limit below which a smaller step failed, or whose bracket is not robust, is listed,
    /// though it was found.
    fn flagged(&self, runs: &Table, row: &[String]) -> bool {
        runs.get(row, "non_monotone_dt")
            .is_some_and(|v| !v.is_empty())
            || runs.get(row, "limit_robust") == Some("no")
    }

    /// A row's outcome is how its first unstable trial ended; its series is the trial it
    /// reports.
    fn outcome_ends_series(&self) -> bool {
        false
    }

    fn report_settings(&self, out: &mut String, file: &StudyFile) {
        report_settings(out, file);
    }

    fn scene_charts(&self, s: &SceneRows, _: &Path, emit: &mut Emit) -> Result<(), PlotError> {
        scene_charts(s, emit)
    }

    /// The largest stable dt, and the cost per simulated second there.
    fn rankings(&self, s: &SceneRows, _: Option<&str>) -> Vec<Ranking> {
        let runs = s.runs;
        let has = |c: &str| runs.column(c).is_some();
        let mut out = Vec::new();
        if has("max_stable_dt") {
            out.extend(findings::ranking(
                s,
                "largest stable dt (s)".into(),
                Better::Larger,
                &|r| {
                    runs.number(r, "max_stable_dt").ok_or_else(|| {
                        runs.get(r, "stability")
                            .unwrap_or("no limit found")
                            .to_owned()
                    })
                },
            ));
        }
        for (k, tolerance) in ERROR_TOLERANCES.iter().enumerate() {
            let column = ERROR_COLUMNS[k][0];
            if has(column) {
                out.extend(findings::ranking(
                    s,
                    format!(
                        "largest stable dt with a position error of at most {}% against the \
                         reference (s)",
                        tolerance * 100.0
                    ),
                    Better::Larger,
                    &|r| {
                        runs.number(r, column)
                            .ok_or_else(|| "no stable step within it".to_owned())
                    },
                ));
            }
        }
        if has("cost_per_simulated_second") {
            out.extend(findings::ranking_with_spread(
                s,
                "cost per simulated second at the largest stable dt (wall s / simulated s: \
                 median step, quartiles as spread; first step apart)"
                    .into(),
                Better::Smaller,
                &|r| {
                    runs.number(r, "cost_per_simulated_second")
                        .ok_or_else(|| "not measured".into())
                },
                &|r| {
                    Some((
                        runs.number(r, "cost_per_simulated_second_q1")?,
                        runs.number(r, "cost_per_simulated_second_q3")?,
                    ))
                },
            ));
        } else if has("wall_seconds") && has("final_time") {
            out.extend(findings::cost_per_simulated_second(s));
        }
        out
    }

    fn unscored(&self, runs: &Table, row: &[String]) -> bool {
        runs.get(row, "error_scored") == Some("no")
    }

    /// A row's outcome is its first unstable trial's, which is expected; only a trial cut by a
    /// step cap is worth a warning.
    fn stopped_early(&self, runs: &Table, row: &[String]) -> bool {
        runs.get(row, "outcome") == Some(OutcomeKind::HorizonNotReached.name())
    }

    fn energy_caption(&self) -> Option<&'static str> {
        Some(
            "Energy balance over time of each method's trial at its largest stable dt (or its \
             failing trial): |E(t) - E(0) - work done| over the energy the body holds or \
             exchanges, the scale the blow-up check judges it against (log scale); the legend \
             says whether energy was gained or lost.",
        )
    }

    /// The largest stable dt against the parameter comes with the explicit limit.
    fn sweep_line(&self, metric: &str) -> SweepLine {
        if metric != "max_stable_dt" {
            return SweepLine::default();
        }
        SweepLine {
            note: " A line at the top is stable at the largest step judged (the ceiling, \
                   horizon / min_steps).",
            reference: Some(("dt_theory", "2/omega_max (explicit limit)")),
        }
    }

    fn unit_notes(&self, _: &Table, shown: &dyn Fn(&str) -> bool) -> Vec<String> {
        shown("error_at_stable_dt")
            .then(|| "errors relative to the reference's displacement".to_owned())
            .into_iter()
            .collect()
    }

    fn dt_columns(&self) -> &'static [&'static str] {
        &["max_stable_dt", "dt"]
    }
}

/// Cost against error at the largest stable steps, and the largest stable step per method.
fn scene_charts(s: &SceneRows, emit: &mut Emit) -> Result<(), PlotError> {
    if let Some(chart) = cost_error_chart(s.scene, s.runs, s.params, s.rows) {
        emit(
            format!("cost-error-{}", s.slug),
            "Wall seconds per simulated second against the relative L2 position error, both at \
             each method's largest stable dt (log-log): lower left is better. Methods with no \
             stable dt in range are absent.",
            Chart::Line(chart),
        )?;
    }
    emit(
        format!("stable-dt-{}", s.slug),
        "Largest stable time step per method (log scale); the line is the explicit limit \
         2/omega_max of the scene at rest. Bars marked >= ceiling were stable at the largest \
         step judged (horizon / min_steps).",
        Chart::Bar(stable_dt_chart(s.scene, s.runs, s.params, s.rows)),
    )
}

/// The report's paragraph on the search's settings, and every cap and threshold that can
/// decide a result.
fn report_settings(out: &mut String, file: &StudyFile) {
    if let Some(st) = &settings(file) {
        let _ = writeln!(
            out,
            "Stability search: first trial at {} s, bisection down to a presumed-stable {} s or \
             widening up (x4) to the ceiling, to {}% precision, then {} smaller probe(s){}. A trial is \
             stable when it covers the {} s horizon in {} to {} steps with every step taken and \
             no blow-up: its energy gain beyond the work done on the body never passed {} x the \
             energy the body holds or exchanges while growing ({GROWN:e} x its first half's) \
             and did not grow exponentially over the last half (x{} with R^2 >= {}); so only steps in [{}, {}] s are judged. With no stable trial, \
             `unstable-at-every-dt` needs the three smallest trials' growth rates to follow \
             one positive power of dt below 2/omega_max; a bracket whose largest stable trial's \
             excess grew more than {GROWING_BELOW} x, and above which the growth rates follow \
             such a power, is the horizon's and reported as `unstable-at-every-dt` too. With a \
             reference, the largest stable \
             step within each error tolerance ({}) is searched to {}% precision. Newton \
             convergence {}.\n",
            short(st.dt_max),
            short(st.dt_min),
            st.relative_precision * 100.0,
            st.probes,
            if st.robustness_trials {
                format!(
                    " and a trial {ROBUSTNESS:e} (relative) on each side of each end of the \
                     bracket"
                )
            } else {
                " (no robustness trials: `limit_robust` is `not-checked`)".to_owned()
            },
            short(st.horizon),
            st.min_steps,
            st.max_steps,
            st.energy_factor,
            softbench_run::run::growth::SUSTAINED_GROWTH,
            softbench_run::run::growth::MIN_FIT_R2,
            short(st.lowest_dt()),
            short(st.highest_dt()),
            ERROR_TOLERANCES
                .iter()
                .map(|t| format!("{}%", t * 100.0))
                .collect::<Vec<_>>()
                .join(", "),
            st.error_dt_precision * 100.0,
            if st.require_newton_convergence {
                "is required (an unconverged step fails as solver-failed)"
            } else {
                "is **not** required: unconverged steps are accepted and counted \
                 (`newton_unconverged_steps`)"
            }
        );
    }
}

/// The verdicts that answer the question (a limit, or stable up to the ceiling).
const ANSWERED: [&str; 2] = ["limit-found", "stable-to-ceiling"];

/// The largest stable step per method, with 2/omega_max as a line (or a tick per bar when
/// the physics differ).
fn stable_dt_chart(
    scene: &str,
    runs: &Table,
    params: &[String],
    rows: &[&Vec<String>],
) -> BarChart {
    // Each physics (a swept stiffness, say) has its own 2/omega_max: every bar carries its
    // own as a tick, and one reference line is drawn only when they all agree.
    let theories: Vec<f64> = rows
        .iter()
        .filter_map(|r| runs.number(r, "dt_theory"))
        .collect();
    let theory = theories
        .first()
        .copied()
        .filter(|t| theories.iter().all(|u| (u / t - 1.0).abs() < 1e-9));
    let per_bar = theory.is_none() && !theories.is_empty();
    BarChart {
        title: format!("Largest stable time step: {scene}"),
        y_label: "largest stable dt (s)".into(),
        y_log: true,
        bars: rows
            .iter()
            .map(|r| {
                let value = runs.number(r, "max_stable_dt");
                let verdict = runs.get(r, "stability").unwrap_or_default();
                let mut label = label(runs, params, r, &[]);
                if verdict == "stable-to-ceiling" {
                    // The bar is the ceiling of the search, not a limit that was found.
                    label.push_str(" (>= ceiling)");
                }
                if runs
                    .get(r, "non_monotone_dt")
                    .is_some_and(|v| !v.is_empty())
                {
                    label.push_str(" (non-monotone)");
                }
                let note = match verdict {
                    "unstable-at-every-dt" => Some(match runs.number(r, "energy_growth_rate") {
                        Some(rate) => format!(
                            "unstable at every dt (energy e-folds at {}/s)",
                            crate::study::vocabulary::format::short(rate)
                        ),
                        None => "unstable at every dt".into(),
                    }),
                    _ if value.is_none() => Some(format!(
                        "no stable dt in range ({})",
                        runs.get(r, "outcome").unwrap_or("?")
                    )),
                    _ => None,
                };
                Bar {
                    label,
                    value,
                    marker: if per_bar {
                        runs.number(r, "dt_theory")
                    } else {
                        None
                    },
                    note,
                }
            })
            .collect(),
        marker_label: per_bar.then(|| "2/omega_max of the bar's physics".to_owned()),
        reference: theory.map(|t| ReferenceLine {
            label: format!(
                "2/omega_max = {} s",
                crate::study::vocabulary::format::short(t)
            ),
            value: t,
        }),
    }
}

/// Cost per simulated second against the error at the largest stable step: one point per
/// method, the headline of a stability study.
fn cost_error_chart(
    scene: &str,
    runs: &Table,
    params: &[String],
    rows: &[&Vec<String>],
) -> Option<LineChart> {
    let series: Vec<Series> = rows
        .iter()
        .filter_map(|r| {
            let error = runs.number(r, "error_at_stable_dt")?;
            let cost = runs.number(r, "cost_per_simulated_second")?;
            let mut label = label(runs, params, r, &[]);
            if let Some(dt) = runs.number(r, "max_stable_dt") {
                label.push_str(&format!(
                    " dt={}",
                    crate::study::vocabulary::format::short(dt)
                ));
            }
            if runs.get(r, "error_scored") == Some("no") {
                label.push_str(" (error within reference accuracy)");
            }
            Some(Series {
                label,
                points: vec![(error, cost)],
                ended: false,
            })
        })
        .collect();
    (!series.is_empty()).then(|| LineChart {
        title: format!("Cost against error at the largest stable step: {scene}"),
        x_label: "relative L2 position error at the largest stable dt".into(),
        y_label: "wall seconds per simulated second".into(),
        x_log: true,
        y_log: true,
        series,
    })
}
