//! The study's plots, drawn from `runs.csv` and the series files alone, so `softbench plot`
//! can redraw them: each kind's own charts of a scene (`Kind::scene_charts`), energy and
//! Newton iterations over time, time per step by phase, sweep metrics against the parameter,
//! and the pictures of the bodies.

use crate::study::kind::Present;
pub use crate::study::present::charts::Plot;
use crate::study::present::charts::{
    SceneRows, distinguishing, label, scenes, slug, smallest_dt_rows,
};
use crate::study::vocabulary::config::SWEEP;
use crate::study::vocabulary::meta::StudyMeta;
use crate::study::vocabulary::table::Table;
use softbench_run::plot::{self, Chart, LineChart, PlotError, Series, StackedBarChart};
use std::collections::BTreeMap;
use std::path::Path;

/// Draw every plot of the study into `dir`.
pub fn draw_all(dir: &Path, study: &StudyMeta, runs: &Table) -> Result<Vec<Plot>, PlotError> {
    let mut plots = Vec::new();
    let scenes = scenes(runs);
    // The swept parameters' columns, which distinguish runs of one method in labels.
    let params = &study.parameters;
    let mut emit = |stem: String, caption: &str, chart: Chart| -> Result<(), PlotError> {
        let title = chart.title().to_owned();
        plot::draw(&chart, &dir.join(&stem))?;
        plots.push(Plot {
            stem,
            title,
            caption: caption.to_owned(),
        });
        Ok(())
    };
    // A sweep draws its metrics against the swept parameter whatever its kind: this is about
    // the sweep itself, not a kind, so it stays here.
    let kind = crate::study::kinds::present(&study.kind);
    if study.study == SWEEP {
        for metric in sweep_metrics(study) {
            let line = kind.sweep_line(&metric);
            for chart in sweep_charts(study, runs, &metric, line.reference) {
                let stem = format!("sweep-{}", slug(&metric));
                let note = line.note;
                emit(
                    stem,
                    &format!(
                        "{metric} against {}, one line per method.{note}",
                        study.sweep_parameter.as_deref().unwrap_or("the parameter")
                    ),
                    Chart::Line(chart),
                )?;
            }
        }
        plots.extend(pictures(dir, runs, params, kind.picture_rows())?);
        remove_stale(dir, &plots);
        return Ok(plots);
    }
    kind.study_charts(dir, study, runs, &mut emit)?;
    for scene in &scenes {
        let rows: Vec<&Vec<String>> = runs
            .rows
            .iter()
            .filter(|r| runs.get(r, "scene") == Some(scene))
            .collect();
        let slug = slug(scene);
        let distinct = distinguishing(runs, params, &rows);
        let of_scene = SceneRows {
            scene,
            slug: &slug,
            runs,
            params: &distinct,
            rows: &rows,
        };
        kind.scene_charts(&of_scene, dir, &mut emit)?;
        // Time histories, if the kind draws them.
        if let Some(caption) = kind.energy_caption() {
            for (suffix, group) in by_time_step(kind.by_time_step(), runs, &rows) {
                let (series, common) = load_series(dir, kind, runs, params, &group);
                let mut title = match suffix.strip_prefix('-') {
                    Some(dt) => format!("{scene}, {dt}"),
                    None => scene.clone(),
                };
                if !common.is_empty() && suffix.is_empty() {
                    title.push_str(&format!(" ({common})"));
                }
                emit(
                    format!("energy-{slug}{suffix}"),
                    caption,
                    Chart::Line(energy_chart(&title, &series)),
                )?;
                if let Some(chart) = iterations_chart(&title, &series) {
                    emit(
                        format!("iterations-{slug}{suffix}"),
                        "Newton iterations per step over time, implicit methods.",
                        Chart::Line(chart),
                    )?;
                }
            }
        }
        if kind.draws_phases() {
            let phase_rows: Vec<&Vec<String>> = if kind.phases_at_smallest_dt() {
                smallest_dt_rows(runs, params, &rows)
            } else {
                rows.clone()
            };
            emit(
                format!("phases-{slug}"),
                "Mean wall time per step split by phase (assembly of forces/Hessians, \
                 factorization, solves, contact QPs, everything else).",
                Chart::Stacked(phase_chart(
                    scene,
                    kind.dt_columns(),
                    runs,
                    params,
                    &phase_rows,
                )),
            )?;
        }
    }
    plots.extend(pictures(dir, runs, params, kind.picture_rows())?);
    remove_stale(dir, &plots);
    Ok(plots)
}

/// The study's pictures of the bodies (see [`crate::study::present::pictures`]).
fn pictures(
    dir: &Path,
    runs: &Table,
    params: &[String],
    which: crate::study::present::pictures::PictureRows,
) -> Result<Vec<Plot>, PlotError> {
    crate::study::present::pictures::draw(
        dir,
        runs,
        params,
        which,
        softbench_run::render::Coloring::VolumeRatio,
    )
    .map_err(|e| PlotError::Draw(e.to_string()))
}

/// The stem prefixes of every file the plots and pictures of a study write. Only such files
/// are ever removed as stale: a figure a user (or an example such as `scaling_plot`) put in
/// the folder is theirs.
const OWN_PREFIXES: [&str; 8] = [
    "cost-error-",
    "energy-",
    "iterations-",
    "phases-",
    "pictures-",
    "stable-dt-",
    "sweep-",
    "work-precision-",
];

/// Remove plots of an earlier invocation that this one did not draw (a scene or time step
/// no longer in the study), so the folder holds exactly what report.md shows.
fn remove_stale(dir: &Path, drawn: &[Plot]) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        let is_plot = path
            .extension()
            .is_some_and(|e| e == "png" || e == "svg" || e == "gif");
        let Some(stem) = path.file_stem().map(|s| s.to_string_lossy().into_owned()) else {
            continue;
        };
        let ours = OWN_PREFIXES.iter().any(|p| stem.starts_with(p));
        if is_plot && ours && !drawn.iter().any(|p| p.stem == stem) {
            let _ = std::fs::remove_file(&path);
        }
    }
}

/// A run's series file, with its label.
struct RunSeries {
    label: String,
    table: Table,
    /// The run ended early (not `completed`; never for a kind whose outcome is not how its
    /// series ended, see `Kind::outcome_ends_series`).
    ended: bool,
}

/// The series of `rows`, each labelled by what varies among them (method, and the linear
/// solver, swept parameters and dt only where they differ), and a note of what they share
/// (for the title), so legends do not repeat a constant.
fn load_series(
    dir: &Path,
    kind: &dyn Present,
    runs: &Table,
    params: &[String],
    rows: &[&Vec<String>],
) -> (Vec<RunSeries>, String) {
    let varies = |column: &str| {
        let mut values = rows
            .iter()
            .filter_map(|r| runs.get(r, column))
            .filter(|v| !v.is_empty() && *v != "-");
        let first = values.next();
        values.any(|v| Some(v) != first)
    };
    let shared = |column: &str| {
        rows.iter()
            .filter_map(|r| runs.get(r, column))
            .find(|v| !v.is_empty() && *v != "-")
            .map(str::to_owned)
    };
    let dt_column = kind
        .dt_columns()
        .iter()
        .copied()
        .find(|c| runs.column(c).is_some())
        .unwrap_or("dt");
    let varying: Vec<String> = params
        .iter()
        .filter(|p| varies(p) && p.as_str() != "run.dt")
        .cloned()
        .collect();
    let (solver_varies, dt_varies) = (varies("linear_solver"), varies(dt_column));
    let mut common = Vec::new();
    if !dt_varies
        && dt_column == "dt"
        && let Some(dt) = shared("dt").and_then(|d| d.parse::<f64>().ok())
    {
        common.push(format!(
            "dt = {} s",
            crate::study::vocabulary::format::short(dt)
        ));
    }
    if !solver_varies && let Some(solver) = shared("linear_solver") {
        common.push(solver);
    }
    let series = rows
        .iter()
        .filter_map(|r| {
            let id = runs.get(r, "run_id")?;
            // Run ids are file names (see study::load); a hand-edited one that is not stays
            // unread rather than reaching outside series/.
            if id.is_empty() || id.contains(['/', '\\']) || id.starts_with("..") {
                return None;
            }
            let path = dir.join("series").join(format!("{id}.csv"));
            let table = Table::read(&path).ok().flatten()?;
            let mut label = runs.get(r, "method").unwrap_or("?").to_owned();
            if solver_varies
                && let Some(solver) = runs
                    .get(r, "linear_solver")
                    .filter(|s| *s != "-" && !s.is_empty())
            {
                label.push_str(&format!(" / {solver}"));
            }
            for name in &varying {
                if let Some(value) = runs.get(r, name).filter(|v| !v.is_empty()) {
                    let short = name.rsplit('.').next().unwrap_or(name);
                    label.push_str(&format!(" {short}={value}"));
                }
            }
            if dt_varies
                && let Some(dt) = runs.get(r, dt_column).and_then(|d| d.parse::<f64>().ok())
            {
                label.push_str(&format!(
                    " dt={}",
                    crate::study::vocabulary::format::short(dt)
                ));
            }
            let ended = kind.outcome_ends_series()
                && runs
                    .get(r, "outcome")
                    .is_some_and(|o| o != softbench_run::run::OutcomeKind::Completed.name());
            Some(RunSeries {
                label,
                table,
                ended,
            })
        })
        .collect();
    (series, common.join(", "))
}

/// The energy balance of each run over time, `|excess| / scale` on a log axis, with the sign
/// in the legend: a run whose excess kept one sign is one line, "(gained)" or "(lost)"; one
/// whose excess changed sign is two lines, ", gained" and ", lost", each broken where the
/// other holds (so a log axis still shows which way the energy went).
fn energy_chart(scene: &str, series: &[RunSeries]) -> LineChart {
    let mut lines = Vec::new();
    for s in series {
        let t = &s.table;
        let signed: Vec<(f64, f64)> =
            match ["t", "energy_excess", "energy_scale"].map(|c| t.column(c)) {
                [Some(ct), Some(ce), Some(cb)] => {
                    let num = |r: &Vec<String>, c: usize| r[c].parse::<f64>().unwrap_or(f64::NAN);
                    t.rows
                        .iter()
                        .skip(1)
                        .map(|r| (num(r, ct), num(r, ce) / num(r, cb)))
                        .collect()
                }
                _ => Vec::new(),
            };
        let gained = |y: f64| y > 0.0;
        let lost = |y: f64| y < 0.0;
        let has = |sign: &dyn Fn(f64) -> bool| signed.iter().any(|p| sign(p.1));
        let part = |sign: &dyn Fn(f64) -> bool| -> Vec<(f64, f64)> {
            signed
                .iter()
                .map(|&(x, y)| (x, if sign(y) { y.abs() } else { f64::NAN }))
                .collect()
        };
        let (label, ended) = (&s.label, s.ended);
        match (has(&gained), has(&lost)) {
            (true, true) => {
                lines.push(Series {
                    label: format!("{label}, gained"),
                    points: part(&gained),
                    ended: false,
                });
                lines.push(Series {
                    label: format!("{label}, lost"),
                    points: part(&lost),
                    ended: false,
                });
                // The end marker goes on the sign the run ended with.
                let last_gained = signed
                    .iter()
                    .rev()
                    .find(|p| p.1 != 0.0)
                    .is_some_and(|p| p.1 > 0.0);
                let n = lines.len();
                lines[if last_gained { n - 2 } else { n - 1 }].ended = ended;
            }
            (g, l) => lines.push(Series {
                label: match (g, l) {
                    (true, _) => format!("{label} (gained)"),
                    (_, true) => format!("{label} (lost)"),
                    _ => label.clone(),
                },
                points: signed.iter().map(|&(x, y)| (x, y.abs())).collect(),
                ended,
            }),
        }
    }
    LineChart {
        title: format!("Energy balance over time: {scene}"),
        x_label: "time t (s)".into(),
        y_label: "|E(t) - E(0) - work| / energy held or exchanged (sign in the legend)".into(),
        x_log: spans_decades(series),
        y_log: true,
        series: lines,
    }
}

/// Whether the runs' end times span more than a decade (an explicit run that blew up early
/// beside implicit ones that ran the horizon): then the time axis is logarithmic, or the short
/// runs are a blob at t = 0.
fn spans_decades(series: &[RunSeries]) -> bool {
    let ends: Vec<f64> = series
        .iter()
        .filter_map(|s| {
            let c = s.table.column("t")?;
            s.table.rows.last()?.get(c)?.parse::<f64>().ok()
        })
        .filter(|t| *t > 0.0)
        .collect();
    let (lo, hi) = ends.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &t| {
        (lo.min(t), hi.max(t))
    });
    hi > 10.0 * lo
}

fn iterations_chart(scene: &str, series: &[RunSeries]) -> Option<LineChart> {
    let lines: Vec<Series> = series
        .iter()
        .filter_map(|s| {
            let t = &s.table;
            let (ct, ci, cs) = (
                t.column("t")?,
                t.column("newton_iterations")?,
                t.column("steps")?,
            );
            let points: Vec<(f64, f64)> = t
                .rows
                .iter()
                .skip(1)
                .filter_map(|r| {
                    let steps: f64 = r[cs].parse().ok()?;
                    (steps > 0.0).then(|| {
                        (
                            r[ct].parse().unwrap_or(f64::NAN),
                            r[ci].parse::<f64>().unwrap_or(f64::NAN) / steps,
                        )
                    })
                })
                .collect();
            points.iter().any(|p| p.1 > 0.0).then(|| Series {
                label: s.label.clone(),
                points,
                ended: s.ended,
            })
        })
        .collect();
    (!lines.is_empty()).then(|| LineChart {
        title: format!("Newton iterations per step: {scene}"),
        x_label: "time t (s)".into(),
        y_label: "Newton iterations per step (mean over each sample interval)".into(),
        x_log: false,
        y_log: false,
        series: lines,
    })
}

/// The rows of a scene grouped by time step when `by_dt` and it has several (with a stem
/// suffix `-dt=…`), else all in one group.
fn by_time_step<'a>(
    by_dt: bool,
    runs: &Table,
    rows: &[&'a Vec<String>],
) -> Vec<(String, Vec<&'a Vec<String>>)> {
    let mut groups: Vec<(String, Vec<&'a Vec<String>>)> = Vec::new();
    for r in rows {
        let dt = if by_dt {
            runs.get(r, "dt").unwrap_or_default()
        } else {
            ""
        };
        match groups.iter_mut().find(|(d, _)| d == dt) {
            Some((_, g)) => g.push(r),
            None => groups.push((dt.to_owned(), vec![r])),
        }
    }
    if groups.len() <= 1 {
        return vec![(String::new(), rows.to_vec())];
    }
    groups
        .into_iter()
        .map(|(dt, g)| {
            let dt = dt
                .parse()
                .map_or(dt.clone(), crate::study::vocabulary::format::short);
            (format!("-dt={dt}"), g)
        })
        .collect()
}

fn phase_chart(
    scene: &str,
    dt_columns: &[&str],
    runs: &Table,
    params: &[String],
    rows: &[&Vec<String>],
) -> StackedBarChart {
    let parts = [
        "force_seconds",
        "mass_solve_seconds",
        "assemble_seconds",
        "factor_seconds",
        "solve_seconds",
        "qp_seconds",
    ];
    let names = [
        "forces",
        "mass solves",
        "assembly",
        "factorization",
        "linear solves",
        "contact QP",
        "other",
    ];
    let mut values: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    let mut categories = Vec::new();
    for r in rows {
        let steps = runs.number(r, "steps").unwrap_or(0.0);
        let wall = runs.number(r, "wall_seconds");
        let (true, Some(wall)) = (steps > 0.0, wall) else {
            continue;
        };
        // The step is named once, from the kind's dt column.
        let mut label = label(runs, params, r, &["run.dt"]);
        if let Some(dt) = dt_columns.iter().find_map(|c| runs.number(r, c)) {
            label.push_str(&format!(
                " dt={}",
                crate::study::vocabulary::format::short(dt)
            ));
        }
        categories.push(label);
        let mut rest = wall;
        for (k, p) in parts.iter().enumerate() {
            let v = runs.number(r, p).unwrap_or(0.0);
            rest -= v;
            values[k].push(v / steps);
        }
        values[parts.len()].push(rest.max(0.0) / steps);
    }
    StackedBarChart {
        title: format!("Time per step by phase: {scene}"),
        y_label: "mean wall time per step (s); no bar: phase not used".into(),
        y_log: true,
        categories,
        parts: names
            .iter()
            .zip(values)
            .map(|(n, v)| ((*n).to_owned(), v))
            .collect(),
    }
}

/// The metrics a sweep plots: the configured ones, or the kind's defaults.
pub fn sweep_metrics(study: &StudyMeta) -> Vec<String> {
    if !study.sweep_metrics.is_empty() {
        return study.sweep_metrics.clone();
    }
    crate::study::kinds::present(&study.kind)
        .sweep_metrics()
        .iter()
        .map(|m| (*m).to_owned())
        .collect()
}

/// The charts of `metric` against the swept parameter, one line per method, with the
/// `reference` column (and its label) as a line of its own when the kind draws one.
fn sweep_charts(
    study: &StudyMeta,
    runs: &Table,
    metric: &str,
    reference: Option<(&str, &str)>,
) -> Vec<LineChart> {
    let Some(parameter) = study.sweep_parameter.as_deref() else {
        return Vec::new();
    };
    let params = &study.parameters;
    let mut lines: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    let mut theory: Vec<(f64, f64)> = Vec::new();
    let several_scenes = scenes(runs).len() > 1;
    for r in &runs.rows {
        let (Some(x), Some(y)) = (runs.number(r, parameter), runs.number(r, metric)) else {
            continue;
        };
        let mut key = label(runs, params, r, &[parameter]);
        if several_scenes {
            key = format!("{}: {key}", runs.get(r, "scene").unwrap_or_default());
        }
        lines.entry(key).or_default().push((x, y));
        if let Some((column, _)) = reference
            && let Some(t) = runs.number(r, column)
            && !theory.iter().any(|p| p.0 == x)
        {
            theory.push((x, t));
        }
    }
    let mut series: Vec<Series> = lines
        .into_iter()
        // A metric that is zero throughout (Newton iterations of explicit methods) is noise.
        .filter(|(_, points)| points.iter().any(|p| p.1 != 0.0))
        .map(|(label, mut points)| {
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            Series {
                label,
                points,
                ended: false,
            }
        })
        .collect();
    if !theory.is_empty() {
        theory.sort_by(|a, b| a.0.total_cmp(&b.0));
        series.push(Series {
            label: reference.map_or_else(String::new, |(_, label)| label.to_owned()),
            points: theory,
            ended: false,
        });
    }
    let wide = |values: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = values.fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
        lo > 0.0 && hi / lo > 20.0
    };
    let x_log = wide(&mut series.iter().flat_map(|s| s.points.iter().map(|p| p.0)));
    let y_log = wide(&mut series.iter().flat_map(|s| s.points.iter().map(|p| p.1)));
    vec![LineChart {
        title: format!("{metric} against {parameter}"),
        x_label: unit_label(parameter),
        y_label: unit_label(metric),
        x_log,
        y_log,
        series,
    }]
}

/// A metric's axis label with its unit.
fn unit_label(metric: &str) -> String {
    let last = metric.rsplit('.').next().unwrap_or(metric);
    match last {
        m if m == "dt" || m.ends_with("_dt") || m.starts_with("dt_") || m == "horizon" => {
            format!("{metric} (s)")
        }
        "youngs_modulus" | "mu" | "lambda" | "c" | "d" => format!("{metric} (Pa)"),
        "density" => format!("{metric} (kg/m^3)"),
        "stiffness" => format!("{metric} (N/m)"),
        m if m.ends_with("_seconds") || m.contains("seconds_") => format!("{m} (s)"),
        m => m.to_owned(),
    }
}
