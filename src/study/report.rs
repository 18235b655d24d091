//! `report.md`: what was run, on what, a summary table, the plots, and one line per run that
//! did not end well.

use super::config::StudyKind;
use super::format::short;
use super::load::Study;
use super::meta::Meta;
use super::plots::Plot;
use super::table::Table;
use super::work_precision::Reference;
use crate::report::write_atomic;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// The summary table's columns per kind (those present in runs.csv are shown).
fn summary_columns(kind: StudyKind) -> &'static [&'static str] {
    match kind {
        StudyKind::Stability => &[
            "status",
            "max_stable_dt",
            "dt_theory",
            "stable_over_theory",
            "unstable_cause",
            "horizon",
            "newton_iterations_per_step",
            "step_seconds_median",
            "trials",
        ],
        StudyKind::WorkPrecision => &[
            "dt",
            "status",
            "error",
            "energy_error",
            "wall_seconds",
            "force_evaluations",
            "hessian_evaluations",
            "factorizations",
            "linear_iterations",
        ],
        _ => &[
            "dt",
            "status",
            "energy_drift_max",
            "energy_drift_final",
            "momentum_drift",
            "step_seconds_median",
            "step_seconds_p95",
            "newton_iterations_per_step",
        ],
    }
}

/// Write `report.md` into `dir`.
pub fn write(
    dir: &Path,
    study: &Study,
    meta: &Meta,
    runs: &Table,
    plots: &[Plot],
    reused: usize,
    references: &BTreeMap<u64, (String, Reference)>,
) -> std::io::Result<()> {
    let text = render(study, meta, runs, plots, reused, references);
    write_atomic(&dir.join("report.md"), |w| w.write_all(text.as_bytes()))
}

fn render(
    study: &Study,
    meta: &Meta,
    runs: &Table,
    plots: &[Plot],
    reused: usize,
    references: &BTreeMap<u64, (String, Reference)>,
) -> String {
    let s = &meta.study;
    let mut out = String::new();
    let kind = if s.study == StudyKind::Sweep {
        format!(
            "sweep of {} over `{}`",
            s.kind.name(),
            s.sweep_parameter.as_deref().unwrap_or("?")
        )
    } else {
        s.kind.name().to_owned()
    };
    let _ = writeln!(out, "# {}: {kind} study\n", s.name);
    if let Some(d) = &s.description {
        let _ = writeln!(out, "{}\n", d.trim());
    }
    if s.quick {
        let _ = writeln!(
            out,
            "**Quick mode** (`--quick`): horizons and ladders are shortened; these numbers are a \
             smoke test, not results.\n"
        );
    }
    let m = &meta.machine;
    let _ = writeln!(
        out,
        "Study file `{}`; {} runs in `runs.csv` ({reused} reused from an earlier invocation). \
         softbench {} (commit `{}`), {}; {} ({} cores), {}. Started {}, finished {}, {} s.\n",
        s.file.display(),
        runs.rows.len(),
        m.softbench_version,
        m.git_commit,
        m.rustc,
        m.cpu,
        m.cores,
        m.os,
        meta.started,
        meta.finished.as_deref().unwrap_or("-"),
        meta.wall_seconds.map_or("-".into(), |w| format!("{w:.1}")),
    );
    settings(&mut out, study);
    if !references.is_empty() {
        let _ = writeln!(out, "References:\n");
        for (scene, r) in references.values() {
            let _ = writeln!(
                out,
                "- {scene}: {} at dt = {} s; it differs from the solution at twice its step by \
                 {:.3e} (position) and {:.3e} (energy); errors below {} x that are not scored.",
                r.method.name(),
                short(r.dt),
                r.difference,
                r.energy_difference,
                study
                    .file
                    .work_precision
                    .as_ref()
                    .map_or(2.0, |w| w.reference.floor_factor)
            );
        }
        let _ = writeln!(out);
    }
    if s.kind == StudyKind::WorkPrecision {
        orders(&mut out, runs);
    }

    let _ = writeln!(out, "## Runs\n");
    let mut columns: Vec<&str> = vec!["scene", "method", "linear_solver"];
    columns.extend(s.parameters.iter().map(String::as_str));
    columns.extend(
        summary_columns(s.kind)
            .iter()
            .copied()
            .filter(|c| runs.column(c).is_some()),
    );
    let _ = writeln!(out, "| {} |", columns.join(" | "));
    let _ = writeln!(out, "|{}", "---|".repeat(columns.len()));
    for row in &runs.rows {
        let cells: Vec<String> = columns
            .iter()
            .map(|c| {
                let v = runs.get(row, c).unwrap_or_default();
                match v.parse::<f64>() {
                    Ok(x) if v.contains('e') || v.contains('.') => short(x),
                    _ => v.replace('|', "\\|"),
                }
            })
            .collect();
        let _ = writeln!(out, "| {} |", cells.join(" | "));
    }
    let _ = writeln!(
        out,
        "\nUnits: time steps and times in s; drifts relative to the initial internal energy plus \
         the work of gravity; momentum drift in kg m/s (empty where the scene does not conserve \
         momentum); errors relative to the reference's displacement.\n"
    );

    let _ = writeln!(out, "## Plots\n");
    for p in plots {
        let _ = writeln!(
            out,
            "### {}\n\n{}\n\n![{}]({}.png)\n",
            p.title, p.caption, p.title, p.stem
        );
    }

    let _ = writeln!(out, "## Runs that did not finish cleanly\n");
    let mut any = false;
    for row in &runs.rows {
        let status = runs.get(row, "status").unwrap_or_default();
        let message = runs.get(row, "message").unwrap_or_default();
        let unstable_cause = runs.get(row, "unstable_cause").unwrap_or_default();
        let bad = !super::measured::is_clean(status);
        let unscored = runs.get(row, "scored") == Some("no") && status == "ok";
        if bad || unscored {
            any = true;
            let detail = if !message.is_empty() {
                message
            } else {
                unstable_cause
            };
            let _ = writeln!(out, "- `{}`: {status}: {detail}", row[0]);
        }
    }
    if !any {
        let _ = writeln!(out, "None.");
    }
    out
}

/// The kind's settings, one line.
fn settings(out: &mut String, study: &Study) {
    if let (StudyKind::Stability, Some(st)) = (study.kind, &study.file.stability) {
        let _ = writeln!(
            out,
            "Stability search: dt in [{}, {}] s (widened down to {} s if needed), horizon {} s \
             per trial (at most {} steps), unstable when kinetic + elastic energy exceeds {} x its \
             initial value plus the work done, or a step fails; bisection to {}% .\n",
            short(st.dt_min),
            short(st.dt_max),
            short(st.floor()),
            short(st.horizon),
            st.max_steps,
            st.energy_factor,
            st.relative_precision * 100.0
        );
    }
    if let (StudyKind::WorkPrecision, Some(w)) = (study.kind, &study.file.work_precision) {
        let _ = writeln!(
            out,
            "Work-precision: horizon {} s, errors at {} sample times (the largest is reported).\n",
            short(w.horizon),
            w.samples
        );
    }
}

/// Observed order of each line of a work-precision study: the slope of log(error) against
/// log(dt) between its two smallest scored time steps.
fn orders(out: &mut String, runs: &Table) {
    let mut lines: BTreeMap<(String, String), Vec<(f64, f64)>> = BTreeMap::new();
    for r in &runs.rows {
        // Adaptive methods choose their own steps: dt is only their output interval.
        let method = runs.get(r, "method").unwrap_or_default();
        if method.starts_with("adaptive-") || method == "dopri5" {
            continue;
        }
        if let (Some(dt), Some(e)) = (runs.number(r, "dt"), runs.number(r, "error")) {
            let key = (
                runs.get(r, "scene").unwrap_or_default().to_owned(),
                format!(
                    "{} {}",
                    runs.get(r, "method").unwrap_or_default(),
                    runs.get(r, "linear_solver").unwrap_or_default()
                ),
            );
            lines.entry(key).or_default().push((dt, e));
        }
    }
    let mut text = String::new();
    for ((scene, method), mut points) in lines {
        if points.len() < 2 {
            continue;
        }
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        let ((d1, e1), (d2, e2)) = (points[0], points[1]);
        let order = (e2 / e1).ln() / (d2 / d1).ln();
        let _ = writeln!(
            text,
            "| {scene} | {} | {order:.2} |",
            method.trim_end_matches(" -")
        );
    }
    if !text.is_empty() {
        let _ = writeln!(
            out,
            "Observed order (slope of log error against log dt between the two smallest scored \
             steps; adaptive methods, whose dt is only an output interval, are left out):\n\n| scene | method | order |\n|---|---|---|\n{text}"
        );
    }
}
