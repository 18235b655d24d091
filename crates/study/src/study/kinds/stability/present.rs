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
            "stable_intervals",
            "stable_fraction",
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
         study's), but a coarser scan and searches and no robustness trials, so a narrow band \
         the full scan resolves may be missed"
    }

    /// The `stability` column: clean when the map shows a stable set.
    fn verdict<'a>(&self, runs: &'a Table, row: &'a [String]) -> Verdict<'a> {
        let word = runs.get(row, "stability").unwrap_or_default();
        Verdict {
            word,
            clean: ANSWERED.contains(&word),
        }
    }

    /// A stable set with an unstable step below its top, or whose ends are not robust, is
    /// listed, though it was mapped.
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

    fn report_findings(
        &self,
        out: &mut String,
        runs: &Table,
        _: &crate::study::vocabulary::meta::StudyMeta,
    ) {
        stability_maps(out, runs);
    }

    fn scene_charts(&self, s: &SceneRows, dir: &Path, emit: &mut Emit) -> Result<(), PlotError> {
        scene_charts(s, dir, emit)
    }

    /// The largest step below which every tried step is stable, the stable share of the
    /// range, the same within each error tolerance, and the cost at the largest stable step.
    fn rankings(&self, s: &SceneRows, _: Option<&str>) -> Vec<Ranking> {
        let runs = s.runs;
        let has = |c: &str| runs.column(c).is_some();
        let mut out = Vec::new();
        if has("max_stable_dt") {
            out.extend(findings::ranking(
                s,
                "largest dt below which every tried step is stable (s)".into(),
                Better::Larger,
                &|r| {
                    runs.number(r, "max_stable_dt").ok_or_else(|| {
                        let verdict = runs.get(r, "stability").unwrap_or("no limit found");
                        match runs.get(r, "stable_intervals").filter(|v| !v.is_empty()) {
                            Some(set) => format!("{verdict}: stable in {set}"),
                            None => verdict.to_owned(),
                        }
                    })
                },
            ));
        }
        if has("stable_fraction") {
            out.extend(findings::ranking(
                s,
                "stable share of the judged range (in log dt)".into(),
                Better::Larger,
                &|r| {
                    runs.number(r, "stable_fraction")
                        .ok_or_else(|| "not measured".to_owned())
                },
            ));
        }
        for (k, tolerance) in ERROR_TOLERANCES.iter().enumerate() {
            let column = ERROR_COLUMNS[k][0];
            if has(column) {
                out.extend(findings::ranking(
                    s,
                    format!(
                        "largest dt below which every tried step is stable with a position \
                         error of at most {}% against the reference (s)",
                        tolerance * 100.0
                    ),
                    Better::Larger,
                    &|r| {
                        runs.number(r, column)
                            .ok_or_else(|| "no such step: the smallest misses it".to_owned())
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

/// Cost against error at the largest stable steps, the largest stable step per method and
/// the error against dt of every stable trial.
fn scene_charts(s: &SceneRows, dir: &Path, emit: &mut Emit) -> Result<(), PlotError> {
    if let Some(chart) = error_dt_chart(s, dir) {
        emit(
            format!("error-dt-{}", s.slug),
            "Relative L2 position error against dt of every stable trial of each method \
             (log-log; the scan, its bisections and the error-tolerance searches). A curve that \
             rises as dt shrinks is non-monotone: the step reported within a tolerance is the \
             largest below which every tried step meets it.",
            Chart::Line(chart),
        )?;
    }
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
        "Largest step below which every tried step is stable, per method (log scale); the line \
         is the explicit limit 2/omega_max of the scene at rest. Bars marked >= ceiling were \
         stable at every step judged up to the ceiling (horizon / min_steps); a method stable \
         only above some step or in bands has no bar and says where (the maps in the report).",
        Chart::Bar(stable_dt_chart(s.scene, s.runs, s.params, s.rows)),
    )
}

/// The report's paragraph on the search's settings, and every cap and threshold that can
/// decide a result.
fn report_settings(out: &mut String, file: &StudyFile) {
    if let Some(st) = &settings(file) {
        if let Some(probes) = st.probes {
            // Results written before the stability maps: say how they were searched.
            let _ = writeln!(
                out,
                "Stability search (softbench before the stability maps): first trial at {} s, \
                 bisection down to a presumed-stable {} s or widening up (x4) to the ceiling, to \
                 {}% precision, then {probes} smaller probe(s); steps judged in [{}, {}] s over \
                 a {} s horizon in {} to {} steps; energy limit {} x the energy scale. A \
                 stability study now scans the whole range and bisects every change: rerun it \
                 for its stability maps.\n",
                short(st.dt_max),
                short(st.dt_min),
                st.relative_precision * 100.0,
                short(st.lowest_dt()),
                short(st.highest_dt()),
                short(st.horizon),
                st.min_steps,
                st.max_steps,
                st.energy_factor,
            );
            return;
        }
        let _ = writeln!(
            out,
            "Stability map: every run scans its judged range [{}, {}] s at {} log-spaced steps \
             per decade (and {} s), then bisects every change between stable and unstable to \
             {}% precision{}. A trial is stable when it covers the {} s horizon in {} to {} \
             steps with every step taken and no blow-up: its energy gain beyond the work done on \
             the body never passed {} x the energy the body holds or exchanges while growing \
             ({GROWN:e} x its first half's), did not grow exponentially over the last half (x{} \
             with R^2 >= {}), and did not stay above {} x that scale over the whole last \
             quarter of the horizon (energy invented and kept, `~` in the maps). With no stable \
             trial, `unstable-at-every-dt` needs the three smallest trials' growth rates to \
             follow one positive power of dt below 2/omega_max; a limit whose largest stable \
             trial's excess grew more than {GROWING_BELOW} x, and above which the growth rates \
             follow such a power, is the horizon's and reported as `unstable-at-every-dt` too. \
             With a reference, the largest step below which every tried step meets each error \
             tolerance ({}) is searched to {}% precision; a tried step above it that meets the \
             tolerance again is reported (`dt_error_*_met_again`), not claimed. Newton \
             convergence {}.\n",
            short(st.lowest_dt()),
            short(st.highest_dt()),
            st.scan_per_decade,
            short(st.dt_max),
            st.relative_precision * 100.0,
            if st.robustness_trials {
                format!(
                    ", and a trial {ROBUSTNESS:e} (relative) on each side of each end of the \
                     stable intervals inside the range"
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
            short(st.invented_energy_limit),
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

/// The verdicts that answer the question: a stable set was mapped.
const ANSWERED: [&str; 4] = [
    "limit-found",
    "stable-to-ceiling",
    "stable-only-above",
    "stable-in-bands",
];

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
                    "stable-only-above" | "stable-in-bands" => Some(format!(
                        "{verdict}: {}",
                        runs.get(r, "stable_intervals").unwrap_or("?")
                    )),
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

/// Per scene, each run's scan as one character per scanned step (smallest first) with its
/// stable intervals: the map the verdicts summarize.
fn stability_maps(out: &mut String, runs: &Table) {
    if runs.column("scan_map").is_none() {
        return;
    }
    // The scenes in the order of their first row.
    let mut scenes: Vec<&str> = Vec::new();
    for scene in runs.rows.iter().filter_map(|r| runs.get(r, "scene")) {
        if !scenes.contains(&scene) {
            scenes.push(scene);
        }
    }
    let _ = writeln!(
        out,
        "## Stability maps\n\nOne character per scanned step, smallest first (log-spaced over \
         the judged range): `#` stable, `^` completed but growing on a trend that blows up at \
         every step, `~` energy invented and kept, `x` blew up, `!` any \
         other failure (solver failed, left the material's domain, step cap); then the stable \
         intervals after bisecting every change.\n"
    );
    for scene in scenes {
        let rows: Vec<&Vec<String>> = runs
            .rows
            .iter()
            .filter(|r| runs.get(r, "scene") == Some(scene))
            .collect();
        let Some(first) = rows.first() else { continue };
        let _ = writeln!(
            out,
            "**{scene}**, dt from {} s to {} s, {} steps per decade:\n\n```text",
            runs.get(first, "lowest_dt").unwrap_or("?"),
            runs.get(first, "highest_dt").unwrap_or("?"),
            // The table writes every number in one format ("6e0"); a count reads as one.
            runs.get(first, "scan_per_decade")
                .and_then(|n| n.parse::<f64>().ok())
                .map_or_else(|| "?".to_owned(), |n| n.to_string()),
        );
        let name = |r: &Vec<String>| {
            let id = runs.get(r, "run_id").unwrap_or("?");
            id.strip_prefix(scene)
                .map_or(id, |s| s.trim_start_matches('-'))
                .to_owned()
        };
        let width = rows.iter().map(|r| name(r).len()).max().unwrap_or(0);
        for r in &rows {
            let _ = writeln!(
                out,
                "{:width$}  {}  {}",
                name(r),
                runs.get(r, "scan_map").unwrap_or(""),
                runs.get(r, "stable_intervals")
                    .filter(|v| !v.is_empty())
                    .unwrap_or("nothing stable"),
            );
        }
        let _ = writeln!(out, "```\n");
    }
}

/// The error against dt of every stable trial of each run of a scene, from its trials table.
fn error_dt_chart(s: &SceneRows, dir: &Path) -> Option<LineChart> {
    let series: Vec<Series> = s
        .rows
        .iter()
        .filter_map(|r| {
            let id = s.runs.get(r, "run_id")?;
            let path = dir.join("series").join(format!("{id}-trials.csv"));
            let trials = Table::read(&path).ok().flatten()?;
            let mut points: Vec<(f64, f64)> = trials
                .rows
                .iter()
                .filter(|t| trials.get(t, "stable") == Some("true"))
                .filter_map(|t| Some((trials.number(t, "dt")?, trials.number(t, "error")?)))
                .filter(|p| p.1 > 0.0)
                .collect();
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            points.dedup_by(|a, b| a.0 == b.0);
            (points.len() >= 2).then(|| Series {
                label: label(s.runs, s.params, r, &[]),
                points,
                ended: false,
            })
        })
        .collect();
    (!series.is_empty()).then(|| LineChart {
        title: format!("Error against dt of every stable trial: {}", s.scene),
        x_label: "time step dt (s)".into(),
        y_label: "relative L2 position error".into(),
        x_log: true,
        y_log: true,
        series,
    })
}
