//! What every chart of a study is drawn from: a drawn plot's record, one scene's rows, run
//! labels and file stems, and where a run sits along its work-precision line. The kinds'
//! charts and the generic ones (`plots.rs`, `pictures.rs`) share these.

use crate::study::vocabulary::table::Table;
use softbench_run::plot::{Chart, PlotError};
use std::collections::BTreeMap;

/// A drawn plot: `<stem>.png` and `<stem>.svg` in the results folder.
#[derive(Clone, Debug)]
pub struct Plot {
    pub stem: String,
    pub title: String,
    /// One sentence on what it shows and how to read it.
    pub caption: String,
}

/// One scene's rows of `runs.csv`, for the charts a kind draws of it.
pub(in crate::study) struct SceneRows<'a> {
    pub scene: &'a str,
    /// The scene's name as it appears in file stems.
    pub slug: &'a str,
    pub runs: &'a Table,
    /// The swept parameters whose values differ among `rows` ([`distinguishing`]), which
    /// tell runs of one method apart in labels.
    pub params: &'a [String],
    pub rows: &'a [&'a Vec<String>],
}

/// Draws a chart: its file stem, its caption, the chart.
pub(in crate::study) type Emit<'e> = dyn FnMut(String, &str, Chart) -> Result<(), PlotError> + 'e;

/// Parameters that set a run's accuracy: the points along one work-precision line (the step,
/// an adaptive tolerance, a Newton tolerance, a local solver's iterations or substeps, a peer
/// method's).
pub(in crate::study) const ACCURACY_KNOBS: [&str; 9] = [
    "run.dt",
    "integrator.adaptive.tolerance",
    "integrator.newton.tolerance",
    "integrator.vbd.iterations",
    "integrator.projective_dynamics.iterations",
    "integrator.xpbd.substeps",
    "integrator.xpbd.iterations",
    "integrator.peer.iterations",
    "integrator.peer.substeps",
];

/// Where a run sits along its work-precision line: larger for smaller steps and tolerances
/// and for more iterations or substeps (the sum of their logs, so a row's knobs combine).
pub(in crate::study) fn accuracy_rank(runs: &Table, row: &[String]) -> f64 {
    ACCURACY_KNOBS
        .iter()
        .filter_map(|k| Some((*k, runs.number(row, k).filter(|v| *v > 0.0)?)))
        .map(|(k, v)| {
            if k.ends_with("iterations") || k.ends_with("substeps") {
                v.ln()
            } else {
                -v.ln()
            }
        })
        .sum()
}

/// One run per work-precision line (its label without the accuracy knobs): the completed run
/// of lowest accuracy (largest dt, then [`accuracy_rank`]), or the lowest-accuracy run when
/// none completed; in the order of `rows`.
pub(in crate::study) fn least_accurate_per_line<'a>(
    runs: &Table,
    params: &[String],
    rows: &[&'a Vec<String>],
) -> Vec<&'a Vec<String>> {
    // Larger is shown first: completed, then less accurate.
    let preference = |r: &[String]| {
        let dt = runs
            .number(r, "dt")
            .filter(|v| *v > 0.0)
            .map_or(0.0, f64::ln);
        let completed = runs.get(r, "outcome") == Some("completed");
        (completed, dt - accuracy_rank(runs, r))
    };
    let mut best: BTreeMap<String, &'a Vec<String>> = BTreeMap::new();
    for r in rows {
        let key = label(runs, params, r, &ACCURACY_KNOBS);
        let better = best.get(&key).is_none_or(|b| {
            let ((rc, ra), (bc, ba)) = (preference(r), preference(b));
            rc.cmp(&bc).then(ra.total_cmp(&ba)).is_gt()
        });
        if better {
            best.insert(key, r);
        }
    }
    rows.iter()
        .copied()
        .filter(|r| best.values().any(|b| std::ptr::eq(*b, *r)))
        .collect()
}

/// Scenes in order of first appearance.
pub(in crate::study) fn scenes(runs: &Table) -> Vec<String> {
    let mut seen = Vec::new();
    for r in &runs.rows {
        if let Some(s) = runs.get(r, "scene")
            && !seen.iter().any(|x: &String| x == s)
        {
            seen.push(s.to_owned());
        }
    }
    seen
}

pub(in crate::study) fn slug(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// The cell of swept parameter `name` in `row`: its own column, or for `run.dt` the `dt`
/// column (kinds with a `dt` column give the time step no parameter column).
pub(in crate::study) fn parameter_value<'t>(
    runs: &'t Table,
    row: &'t [String],
    name: &str,
) -> Option<&'t str> {
    if name == "run.dt" && runs.column(name).is_none() {
        return runs.get(row, "dt");
    }
    runs.get(row, name)
}

/// The swept parameters and the time step whose values differ among `rows`, a run that
/// does not set one counting as a value of its own: what tells the rows of one method apart
/// in a label. A parameter all rows share is left out (a legend or title can say it once).
pub(in crate::study) fn distinguishing(
    runs: &Table,
    params: &[String],
    rows: &[&Vec<String>],
) -> Vec<String> {
    // The step is a candidate wherever the table has it, swept or not (a kind with a `dt`
    // column gives the swept `run.dt` no column, so the study's parameters may omit it).
    let dt = (runs.column("dt").is_some() && !params.iter().any(|p| p == "run.dt"))
        .then(|| "run.dt".to_owned());
    params
        .iter()
        .chain(dt.as_ref())
        .filter(|p| {
            let mut values = rows
                .iter()
                .map(|r| parameter_value(runs, r, p).unwrap_or(""));
            let first = values.next();
            values.any(|v| Some(v) != first)
        })
        .cloned()
        .collect()
}

/// "method / solver" plus the value of every parameter of `params` except `skip` (`run.dt`
/// read from the `dt` column where it has none: see [`parameter_value`]).
pub(in crate::study) fn label(
    runs: &Table,
    params: &[String],
    row: &[String],
    skip: &[&str],
) -> String {
    let mut label = runs.get(row, "method").unwrap_or("?").to_owned();
    if let Some(solver) = runs
        .get(row, "linear_solver")
        .filter(|s| *s != "-" && !s.is_empty())
    {
        label.push_str(" / ");
        label.push_str(solver);
    }
    for name in params.iter().filter(|p| !skip.contains(&p.as_str())) {
        if let Some(value) = parameter_value(runs, row, name).filter(|v| !v.is_empty()) {
            let short = name.rsplit('.').next().unwrap_or(name);
            label.push_str(&format!(" {short}={value}"));
        }
    }
    label
}

/// For work-precision: each line's run at its smallest dt.
pub(in crate::study) fn smallest_dt_rows<'a>(
    runs: &Table,
    params: &[String],
    rows: &[&'a Vec<String>],
) -> Vec<&'a Vec<String>> {
    let mut best: BTreeMap<String, &'a Vec<String>> = BTreeMap::new();
    for r in rows {
        let key = label(runs, params, r, &ACCURACY_KNOBS);
        let dt = runs.number(r, "dt").unwrap_or(f64::INFINITY);
        if best
            .get(&key)
            .is_none_or(|b| runs.number(b, "dt").unwrap_or(f64::INFINITY) > dt)
        {
            best.insert(key, r);
        }
    }
    rows.iter()
        .copied()
        .filter(|r| best.values().any(|b| std::ptr::eq(*b, *r)))
        .collect()
}
