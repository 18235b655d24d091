//! The work-precision study kind, presenting: verdicts, report paragraphs, charts and pictures.

use super::{WorkPrecision, settings};
use crate::study::kind::Present;
use crate::study::present::charts::{ACCURACY_KNOBS, Emit, SceneRows, accuracy_rank, label};
use crate::study::present::findings;
use crate::study::present::findings::{Better, ORDER_EXCESS, Ranking};
use crate::study::present::pictures::PictureRows;
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::format::short;
use crate::study::vocabulary::table::Table;
use softbench_core::integrate::Method;
use softbench_run::plot::{Chart, LineChart, PlotError, Series};
use std::collections::BTreeMap;
use std::fmt::Write;
use std::path::Path;

impl Present for WorkPrecision {
    fn summary_columns(&self) -> &'static [&'static str] {
        &[
            "dt",
            "outcome",
            "error",
            "energy_error",
            "wall_seconds",
            "force_evaluations",
            "hessian_evaluations",
            "factorizations",
            "linear_iterations",
            "newton_unconverged_steps",
        ]
    }

    fn sweep_metrics(&self) -> &'static [&'static str] {
        &["error", "wall_seconds"]
    }

    fn quick_notice(&self) -> &'static str {
        "the horizon and the dt ladders are shortened"
    }

    /// An error within the reference's own accuracy is listed, though the run completed.
    fn flagged(&self, runs: &Table, row: &[String]) -> bool {
        self.unscored(runs, row) && findings::completed(runs, row)
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
        orders(out, runs);
    }

    fn scene_charts(&self, s: &SceneRows, _: &Path, emit: &mut Emit) -> Result<(), PlotError> {
        scene_charts(s, emit)
    }

    /// Cost, energy drift among the runs close to the reference, and error at equal cost.
    fn rankings(&self, s: &SceneRows, damped: Option<&str>) -> Vec<Ranking> {
        let has = |c: &str| s.runs.column(c).is_some();
        let mut out = Vec::new();
        if has("wall_seconds") && has("final_time") {
            out.extend(findings::cost_per_simulated_second(s));
        }
        if has("energy_drift_max") {
            out.extend(drift_near_the_reference(s, damped));
        }
        if has("error") && has("wall_seconds") {
            out.extend(error_at_equal_cost(s.runs, s.params, s.scene, s.rows));
        }
        out
    }

    /// Observed orders more than [`ORDER_EXCESS`] above the method's formal order.
    fn table_warnings(&self, runs: &Table) -> Vec<String> {
        let mut out = Vec::new();
        for (scene, line, order) in observed_orders(runs) {
            let method = line.split(' ').next().unwrap_or_default();
            if let Ok(m) = method.parse::<Method>() {
                let theory = f64::from(m.order());
                if order > theory + ORDER_EXCESS {
                    out.push(format!(
                        "{scene}, {line}: observed order {order:.2} is more than {ORDER_EXCESS} \
                         above its formal order {theory}: its errors are not in the asymptotic \
                         range (or are at the reference's noise), so this order is not a \
                         measurement of the method."
                    ));
                }
            }
        }
        out
    }

    fn unit_notes(&self, _: &Table, shown: &dyn Fn(&str) -> bool) -> Vec<String> {
        shown("error")
            .then(|| "errors relative to the reference's displacement".to_owned())
            .into_iter()
            .collect()
    }

    /// A completed run whose error is below the reference's floor (a run that did not
    /// complete is not scored either, but its warning says it stopped, not this).
    fn unscored(&self, runs: &Table, row: &[String]) -> bool {
        runs.get(row, "scored") == Some("no") && findings::completed(runs, row)
    }

    /// (It draws no time histories, the default: its runs differ only in accuracy.)
    fn phases_at_smallest_dt(&self) -> bool {
        true
    }

    fn picture_rows(&self) -> PictureRows {
        PictureRows::LeastAccuratePerLine
    }
}

/// Error against wall time, time per step, cost and dt (and local-solver iterations where
/// there are any), one line per method.
fn scene_charts(s: &SceneRows, emit: &mut Emit) -> Result<(), PlotError> {
    let iterative = s.rows.iter().any(|r| {
        s.runs
            .number(r, "local_iterations_per_step")
            .is_some_and(|n| n > 0.0)
    });
    // One step for every run: error against dt would be a vertical line of points.
    let mut dts = s.rows.iter().filter_map(|r| s.runs.number(r, "dt"));
    let first = dts.next();
    let one_dt = dts.all(|dt| Some(dt) == first);
    for (x, x_label, what) in [
        ("wall_seconds", "wall time (s)", "time"),
        (
            "step_seconds_median",
            "median wall time per step (s)",
            "step-time",
        ),
        ("cost", "force + Hessian evaluations", "cost"),
        ("dt", "time step dt (s)", "dt"),
        (
            "local_iterations_per_step",
            "local-solver iterations per step",
            "iterations",
        ),
    ] {
        if what == "iterations" && !iterative {
            continue;
        }
        if what == "dt" && one_dt {
            continue;
        }
        emit(
            format!("work-precision-{what}-{}", s.slug),
            &format!(
                "Position error against the reference versus {x_label} (log-log), one line per \
                 method; unscored and failed runs are left out."
            ),
            Chart::Line(work_precision_chart(
                s.scene, s.runs, s.params, s.rows, x, x_label,
            )),
        )?;
    }
    Ok(())
}

/// The report's paragraph on the work-precision settings.
fn report_settings(out: &mut String, file: &StudyFile) {
    if let Some(w) = &settings(file) {
        let _ = writeln!(
            out,
            "Work-precision: horizon {} s, errors at {} sample times (the largest is reported, \
             and the final one as `error_final`); wall time the median of {} run(s). \
             Newton convergence {}.\n",
            short(w.horizon),
            w.samples,
            w.repeats,
            if w.require_newton_convergence {
                "is required"
            } else {
                "is **not** required: unconverged steps are accepted and counted"
            }
        );
    }
}

/// Observed order of each line of a work-precision study: the slope of log(error) against
/// log(dt) between its two smallest scored time steps.
/// Next to it, the order in the lowest modes' error (`modal_error`) where it was measured.
fn orders(out: &mut String, runs: &Table) {
    let modal: BTreeMap<(String, String), f64> = observed_orders_in(runs, "modal_error")
        .into_iter()
        .map(|(scene, method, order)| ((scene, method), order))
        .collect();
    let mut text = String::new();
    for (scene, method, order) in observed_orders(runs) {
        let in_modes = modal
            .get(&(scene.clone(), method.clone()))
            .map_or("-".to_owned(), |o| format!("{o:.2}"));
        let _ = writeln!(text, "| {scene} | {method} | {order:.2} | {in_modes} |");
    }
    if !text.is_empty() {
        // Each scene's body has its own modes: the count and the highest frequency kept.
        let mut per_scene: BTreeMap<String, (String, f64)> = BTreeMap::new();
        for r in &runs.rows {
            if let (Some(scene), Some(n), Some(w)) = (
                runs.get(r, "scene"),
                runs.get(r, "modal_modes"),
                runs.number(r, "modal_omega_cutoff"),
            ) {
                per_scene
                    .entry(scene.to_owned())
                    .or_insert_with(|| (n.to_owned(), w));
            }
        }
        let modes = if per_scene.is_empty() {
            String::new()
        } else {
            let list: Vec<String> = per_scene
                .iter()
                .map(|(scene, (n, w))| format!("{n} up to {w:.3e} rad/s on {scene}"))
                .collect();
            format!(
                "; in the lowest modes: the same in the error of the lowest vibration modes of \
                 the body at rest ({}), which leaves out the ringing of the higher modes",
                list.join(", ")
            )
        };
        let _ = writeln!(
            out,
            "Observed order (slope of log error against log dt between the two smallest scored \
             steps; adaptive methods, whose dt is only an output interval, are left out{modes}):\n\n\
             | scene | method | order | in the lowest modes |\n|---|---|---|---|\n{text}"
        );
    }
}

/// Error against `x` (a column, or `cost`: force + Hessian evaluations), one line per
/// method from its cheapest setting to its most accurate.
fn work_precision_chart(
    scene: &str,
    runs: &Table,
    params: &[String],
    rows: &[&Vec<String>],
    x: &str,
    x_label: &str,
) -> LineChart {
    // Points carry their accuracy rank, so a line runs from the cheapest setting to the most
    // accurate one whatever the noise in its x (wall times on a busy machine).
    let mut lines: BTreeMap<String, Vec<(f64, f64, f64)>> = BTreeMap::new();
    for r in rows {
        let Some(error) = runs.number(r, "error") else {
            continue;
        };
        let xv = if x == "cost" {
            runs.number(r, "force_evaluations")
                .zip(runs.number(r, "hessian_evaluations"))
                .map(|(f, h)| f + h)
        } else {
            runs.number(r, x)
        };
        if let Some(xv) = xv {
            lines
                .entry(label(runs, params, r, &ACCURACY_KNOBS))
                .or_default()
                .push((accuracy_rank(runs, r), xv, error));
        }
    }
    LineChart {
        title: format!("Work-precision, error against {x_label}: {scene}"),
        x_label: x_label.into(),
        y_label: "relative position error".into(),
        x_log: true,
        y_log: true,
        series: lines
            .into_iter()
            .map(|(label, mut points)| {
                points.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
                let points = points.into_iter().map(|(_, x, e)| (x, e)).collect();
                Series {
                    label,
                    points,
                    ended: false,
                }
            })
            .collect(),
    }
}

/// The observed order of each (scene, method, solver) line of a work-precision study: the
/// slope of log error against log dt between the two smallest steps with a scored error.
/// Adaptive methods (dt is only their output interval) are left out.
pub(in crate::study) fn observed_orders(runs: &Table) -> Vec<(String, String, f64)> {
    observed_orders_in(runs, "error")
}

/// [`observed_orders`] of the error in `column`.
fn observed_orders_in(runs: &Table, column: &str) -> Vec<(String, String, f64)> {
    let mut lines: BTreeMap<(String, String), Vec<(f64, f64)>> = BTreeMap::new();
    for r in &runs.rows {
        let method = runs.get(r, "method").unwrap_or_default();
        if Method::from_name(method).is_ok_and(|m| m.is_adaptive()) {
            continue;
        }
        if let (Some(dt), Some(e)) = (runs.number(r, "dt"), runs.number(r, column)) {
            let solver = runs.get(r, "linear_solver").unwrap_or_default();
            let name = if solver.is_empty() || solver == "-" {
                method.to_owned()
            } else {
                format!("{method} {solver}")
            };
            let scene = runs.get(r, "scene").unwrap_or_default().to_owned();
            lines.entry((scene, name)).or_default().push((dt, e));
        }
    }
    let mut out = Vec::new();
    for ((scene, method), mut points) in lines {
        if points.len() < 2 {
            continue;
        }
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        // Points at one dt differ by another knob (iterations, a tolerance): no order in dt.
        if points.windows(2).any(|w| w[0].0 == w[1].0) {
            continue;
        }
        let ((d1, e1), (d2, e2)) = (points[0], points[1]);
        out.push((scene, method, (e2 / e1).ln() / (d2 / d1).ln()));
    }
    out
}

/// Error at equal cost in one scene: every method line's (its label without the accuracy
/// knobs: [`ACCURACY_KNOBS`]) log error interpolated in log cost at one cost, the geometric
/// middle of the cost interval that the most lines' measured ranges share; a line whose range
/// misses it is left out with its range. `None` when no two lines share a cost.
fn error_at_equal_cost(
    runs: &Table,
    params: &[String],
    scene: &str,
    rows: &[&Vec<String>],
) -> Option<Ranking> {
    let mut lines: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    let mut left_out = Vec::new();
    for r in rows {
        let name = label(runs, params, r, &ACCURACY_KNOBS);
        match (runs.number(r, "wall_seconds"), runs.number(r, "error")) {
            (Some(c), Some(e)) if c > 0.0 && e > 0.0 && findings::completed(runs, r) => {
                lines.entry(name).or_default().push((c, e))
            }
            _ => {
                lines.entry(name).or_default();
            }
        }
    }
    let mut ranges = Vec::new();
    for (name, pts) in &mut lines {
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        if pts.len() < 2 {
            left_out.push((name.clone(), "fewer than two scored runs".to_owned()));
        } else {
            ranges.push((pts[0].0, pts[pts.len() - 1].0));
        }
    }
    // The interval between consecutive range ends that the most ranges cover (the cheapest
    // of equals), and its geometric middle.
    let mut ends: Vec<f64> = ranges.iter().flat_map(|r| [r.0, r.1]).collect();
    ends.sort_by(f64::total_cmp);
    let covering = |lo: f64, hi: f64| ranges.iter().filter(|r| r.0 <= lo && hi <= r.1).count();
    let (lo, hi) = ends
        .windows(2)
        .map(|w| (w[0], w[1]))
        .chain(ends.iter().map(|&e| (e, e)))
        // Most lines, then an interval rather than a single cost, then the cheapest.
        .max_by_key(|&(lo, hi)| (covering(lo, hi), hi > lo, std::cmp::Reverse(lo.to_bits())))?;
    if covering(lo, hi) < 2 {
        return None;
    }
    let cost = (lo * hi).sqrt();
    let mut ranked = Vec::new();
    for (name, pts) in &lines {
        if pts.len() < 2 {
            continue;
        }
        let Some(i) = pts
            .windows(2)
            .position(|w| w[0].0 <= cost && cost <= w[1].0)
        else {
            left_out.push((
                name.clone(),
                format!(
                    "its runs cost {} to {} s, not {} s",
                    short(pts[0].0),
                    short(pts[pts.len() - 1].0),
                    short(cost)
                ),
            ));
            continue;
        };
        let ((c0, e0), (c1, e1)) = (pts[i], pts[i + 1]);
        let s = if c1 > c0 {
            (cost / c0).ln() / (c1 / c0).ln()
        } else {
            0.0
        };
        ranked.push((name.clone(), (e0.ln() + s * (e1.ln() - e0.ln())).exp()));
    }
    ranked.sort_by(|a, b| a.1.total_cmp(&b.1));
    Some(Ranking {
        scene: scene.to_owned(),
        metric: format!(
            "error at equal cost (interpolated in log-log at {} s of wall time, inside the \
             measured range of every line ranked)",
            short(cost)
        ),
        better: Better::Smaller,
        spreads: vec![None; ranked.len()],
        ranked,
        left_out,
    })
}

/// How far (relative position and energy error) a run may be from the reference for its
/// energy drift to be ranked: a method that conserves energy while converging to another
/// answer (XPBD at 14 % from the converged step) is not "best" by drift.
pub const DRIFT_RANKED_WITHIN: f64 = 0.01;

/// Energy drift among the runs whose scored errors against the reference, position and
/// energy, are both within [`DRIFT_RANKED_WITHIN`]; the others are left out with their error.
fn drift_near_the_reference(s: &SceneRows, damped: Option<&str>) -> Option<Ranking> {
    let runs = s.runs;
    let among = format!(
        ", among runs within {} of the reference (position and energy)",
        short(DRIFT_RANKED_WITHIN)
    );
    findings::energy_drift_of(s, damped, &among, &|r| {
        if runs.get(r, "scored") == Some("no") {
            return Ok(());
        }
        let error = |c: &str| runs.number(r, c);
        match (error("error"), error("energy_error")) {
            (Some(e), _) if e > DRIFT_RANKED_WITHIN => {
                Err(format!("error {} from the reference", short(e)))
            }
            (_, Some(e)) if e > DRIFT_RANKED_WITHIN => {
                Err(format!("energy error {} from the reference", short(e)))
            }
            (None, _) => Err("error not measured".into()),
            _ => Ok(()),
        }
    })
}
