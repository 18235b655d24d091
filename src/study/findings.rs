//! What a study found, computed from `runs.csv` alone: per scene, the ranking of the methods by
//! each metric the study measured (largest stable dt, cost per simulated second, error at
//! equal cost, energy drift), the best method per metric, and warnings where a number should
//! not be trusted. `report.md` opens with it; nothing in it is prose the data did not produce.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use super::format::short;
use super::table::Table;
use crate::integrate::Method;
use crate::run::OutcomeKind;

/// How far an observed order may exceed the method's formal order before it is flagged: more
/// than this above theory means the error is not in its asymptotic range (or is at the
/// reference's noise).
pub const ORDER_EXCESS: f64 = 0.5;

/// Whether larger or smaller is better.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Better {
    Larger,
    Smaller,
}

/// One metric's ranking in one scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Ranking {
    pub scene: String,
    /// What is ranked, with its unit and how it was measured.
    pub metric: String,
    pub better: Better,
    /// (run label, value), best first.
    pub ranked: Vec<(String, f64)>,
    /// Runs left out and why.
    pub left_out: Vec<(String, String)>,
}

/// Everything the findings section says.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Findings {
    pub rankings: Vec<Ranking>,
    pub warnings: Vec<String>,
}

/// A run's label: method, linear solver (for implicit methods) and the swept parameters.
fn label(runs: &Table, params: &[String], row: &[String]) -> String {
    super::plots::label(runs, params, row, &[])
}

fn completed(runs: &Table, row: &[String]) -> bool {
    runs.get(row, "outcome") == Some(OutcomeKind::Completed.name())
}

/// The observed order of each (scene, method, solver) line of a work-precision study: the
/// slope of log error against log dt between the two smallest steps with a scored error.
/// Adaptive methods (dt is only their output interval) are left out.
pub fn observed_orders(runs: &Table) -> Vec<(String, String, f64)> {
    let mut lines: BTreeMap<(String, String), Vec<(f64, f64)>> = BTreeMap::new();
    for r in &runs.rows {
        let method = runs.get(r, "method").unwrap_or_default();
        if method.starts_with("adaptive-") || method == "dopri5" {
            continue;
        }
        if let (Some(dt), Some(e)) = (runs.number(r, "dt"), runs.number(r, "error")) {
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

/// The findings of `runs`; `damped` names the scenes with damping (and how), whose energy
/// loss is the damping's as much as the method's.
pub fn compute(runs: &Table, params: &[String], damped: &BTreeMap<String, String>) -> Findings {
    let mut f = Findings::default();
    let mut scenes: Vec<String> = Vec::new();
    for r in &runs.rows {
        let s = runs.get(r, "scene").unwrap_or_default().to_owned();
        if !scenes.contains(&s) {
            scenes.push(s);
        }
    }
    let outcome = |r: &[String]| runs.get(r, "outcome").unwrap_or("?").to_owned();
    let has = |c: &str| runs.column(c).is_some();
    for scene in &scenes {
        let rows: Vec<&Vec<String>> = runs
            .rows
            .iter()
            .filter(|r| runs.get(r, "scene") == Some(scene))
            .collect();
        let mut rank =
            |metric: String, better: Better, value: &dyn Fn(&[String]) -> Result<f64, String>| {
                if rows.iter().all(|r| value(r).is_err()) {
                    return;
                }
                let mut ranked = Vec::new();
                let mut left_out = Vec::new();
                for r in &rows {
                    match value(r) {
                        Ok(v) if v.is_finite() => ranked.push((label(runs, params, r), v)),
                        Ok(v) => left_out.push((label(runs, params, r), format!("value {v}"))),
                        Err(why) => left_out.push((label(runs, params, r), why)),
                    }
                }
                ranked.sort_by(|a, b| match better {
                    Better::Larger => b.1.total_cmp(&a.1),
                    Better::Smaller => a.1.total_cmp(&b.1),
                });
                f.rankings.push(Ranking {
                    scene: scene.clone(),
                    metric,
                    better,
                    ranked,
                    left_out,
                });
            };
        if has("max_stable_dt") {
            rank("largest stable dt (s)".into(), Better::Larger, &|r| {
                runs.number(r, "max_stable_dt").ok_or_else(|| {
                    runs.get(r, "stability")
                        .unwrap_or("no limit found")
                        .to_owned()
                })
            });
        }
        // Cost per simulated second: a stability study measures it at the largest stable dt;
        // a trajectory's is its wall time over its simulated time.
        if has("cost_per_simulated_second") {
            rank(
                "cost per simulated second at the largest stable dt (wall s / simulated s)".into(),
                Better::Smaller,
                &|r| {
                    runs.number(r, "cost_per_simulated_second")
                        .ok_or_else(|| "not measured".into())
                },
            );
        } else if has("wall_seconds") && has("final_time") {
            rank(
                "cost per simulated second (wall s / simulated s)".into(),
                Better::Smaller,
                &|r| {
                    if !completed(runs, r) {
                        return Err(outcome(r));
                    }
                    match (runs.number(r, "wall_seconds"), runs.number(r, "final_time")) {
                        (Some(w), Some(t)) if t > 0.0 => Ok(w / t),
                        _ => Err("no time measured".into()),
                    }
                },
            );
        }
        if has("energy_drift_max") && !has("max_stable_dt") {
            let note = if damped.contains_key(scene) {
                "energy change incl. the damping's loss, max abs(E(t) - E(0)) / scale"
            } else {
                "energy drift, max abs(E(t) - E(0)) / scale"
            };
            rank(note.into(), Better::Smaller, &|r| {
                if !completed(runs, r) {
                    return Err(outcome(r));
                }
                runs.number(r, "energy_drift_max")
                    .ok_or_else(|| "not measured".into())
            });
        }
        if has("error")
            && has("wall_seconds")
            && let Some(r) = error_at_equal_cost(runs, params, scene, &rows)
        {
            f.rankings.push(r);
        }
        if let Some(how) = damped.get(scene)
            && has("energy_drift_max")
        {
            f.warnings.push(format!(
                "{scene} is damped ({how}): its energy drift includes the energy damping \
                 removes, so it measures the damping as much as the method."
            ));
        }
    }
    // Orders above theory.
    for (scene, line, order) in observed_orders(runs) {
        let method = line.split(' ').next().unwrap_or_default();
        if let Ok(m) = method.parse::<Method>() {
            let theory = f64::from(m.order());
            if order > theory + ORDER_EXCESS {
                f.warnings.push(format!(
                    "{scene}, {line}: observed order {order:.2} is more than {ORDER_EXCESS} above \
                     its formal order {theory}: its errors are not in the asymptotic range (or \
                     are at the reference's noise), so this order is not a measurement of the \
                     method."
                ));
            }
        }
    }
    // Per-run warnings.
    for r in &runs.rows {
        let id = &r[0];
        let unscored =
            runs.get(r, "scored") == Some("no") || runs.get(r, "error_scored") == Some("no");
        if unscored {
            f.warnings.push(format!(
                "`{id}`: its error is at the reference's noise floor (not scored): the \
                 reference is not accurate enough to measure it."
            ));
        }
        if let Some(n) = runs
            .number(r, "newton_unconverged_steps")
            .filter(|n| *n > 0.0)
        {
            f.warnings.push(format!(
                "`{id}`: Newton stopped unconverged at its cap ({} iterations, required: {}) \
                 in {n} steps.",
                runs.get(r, "newton_max_iterations").unwrap_or("?"),
                runs.get(r, "newton_required").unwrap_or("?"),
            ));
        }
        let outcome = runs.get(r, "outcome").unwrap_or_default();
        let stability = runs.get(r, "stability");
        let not_reached = match stability {
            // A stability run's outcome is its first unstable trial's: expected.
            Some(_) => outcome == OutcomeKind::HorizonNotReached.name(),
            None => !outcome.is_empty() && outcome != OutcomeKind::Completed.name(),
        };
        if not_reached {
            let at = runs
                .number(r, "final_time")
                .map(|t| format!(" (stopped at t = {} s)", short(t)))
                .unwrap_or_default();
            f.warnings
                .push(format!("`{id}`: did not reach its horizon: {outcome}{at}."));
        }
    }
    f
}

/// Error at equal cost in one scene: every method line's log error interpolated (in log cost)
/// at one cost inside all lines' cost ranges, the geometric middle of their overlap.
fn error_at_equal_cost(
    runs: &Table,
    params: &[String],
    scene: &str,
    rows: &[&Vec<String>],
) -> Option<Ranking> {
    let knobs: Vec<String> = params
        .iter()
        .filter(|p| !matches!(p.as_str(), "run.dt" | "integrator.adaptive.tolerance"))
        .cloned()
        .collect();
    let mut lines: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    let mut left_out = Vec::new();
    for r in rows {
        let name = label(runs, &knobs, r);
        match (runs.number(r, "wall_seconds"), runs.number(r, "error")) {
            (Some(c), Some(e)) if c > 0.0 && e > 0.0 && completed(runs, r) => {
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
    let lo = ranges.iter().map(|r| r.0).fold(f64::NEG_INFINITY, f64::max);
    let hi = ranges.iter().map(|r| r.1).fold(f64::INFINITY, f64::min);
    if ranges.len() < 2 || lo > hi {
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
            "error at equal cost (interpolated in log-log at {} s of wall time, inside every \
             line's measured range)",
            short(cost)
        ),
        better: Better::Smaller,
        ranked,
        left_out,
    })
}

/// Writes the findings as the report's opening section.
pub fn write(out: &mut String, f: &Findings) {
    let _ = writeln!(out, "## Findings\n");
    if f.rankings.is_empty() && f.warnings.is_empty() {
        let _ = writeln!(out, "No metric could be ranked.\n");
        return;
    }
    if !f.rankings.is_empty() {
        let _ = writeln!(
            out,
            "| scene | metric | best | ranking (best first) |\n|---|---|---|---|"
        );
        for r in &f.rankings {
            let best = r
                .ranked
                .first()
                .map_or("-".to_owned(), |(l, v)| format!("{l} ({})", short(*v)));
            let mut list: Vec<String> = r
                .ranked
                .iter()
                .map(|(l, v)| format!("{l} {}", short(*v)))
                .collect();
            for (l, why) in &r.left_out {
                list.push(format!("*{l}: not ranked, {why}*"));
            }
            let _ = writeln!(
                out,
                "| {} | {} ({} is better) | {} | {} |",
                r.scene,
                r.metric.replace('|', "\\|"),
                match r.better {
                    Better::Larger => "larger",
                    Better::Smaller => "smaller",
                },
                best.replace('|', "\\|"),
                list.join("; ").replace('|', "\\|")
            );
        }
        let _ = writeln!(out);
    }
    if !f.warnings.is_empty() {
        let _ = writeln!(out, "Warnings:\n");
        for w in &f.warnings {
            let _ = writeln!(out, "- {w}");
        }
        let _ = writeln!(out);
    }
}
