//! Log-log charts of a solver-scaling study (`experiments/solver_scaling.toml`) with the
//! fitted slope of each solver: steady time per step (the median of the steps after the
//! first), the first step's setup (its excess over the steady step: ordering, symbolic
//! analysis, AMG build), factorization flops and nnz(L), CG iterations per solve and peak
//! memory against the number of tets, one chart per body family (the
//! scene name's prefix before `-`). Reads only `runs.csv`; writes the charts and
//! `slopes.csv` (least-squares slope of log(time per step) on log(tets) over the fit range)
//! into the study folder.
//!
//! `cargo run --release --example scaling_plot -- results/solver_scaling [min_tets max_tets]`

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, bail};
use softbench::plot::{Chart, LineChart, Series, draw};

/// One run: (family, solver label, tets, metrics by column).
struct Row {
    family: String,
    solver: String,
    tets: f64,
    cells: BTreeMap<String, String>,
}

impl Row {
    fn number(&self, column: &str) -> Option<f64> {
        self.cells
            .get(column)
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|v| v.is_finite() && *v > 0.0)
    }
}

/// The label of a run's solver configuration, from the columns that vary.
fn solver_label(cells: &BTreeMap<String, String>, run_id: &str) -> String {
    let get = |k: &str| cells.get(k).map(String::as_str).unwrap_or("");
    let refactor = get("newton_refactor_every");
    let modified = if refactor != "1" && !refactor.is_empty() {
        format!(" refactor/{refactor}")
    } else {
        String::new()
    };
    if run_id.contains("-auto") {
        return format!("auto{modified}");
    }
    match get("linear_solver_used") {
        "cholesky" => format!("cholesky {}{modified}", get("ordering")),
        "cg" => format!("cg {}{modified}", get("ordering")),
        other => format!("{other}{modified}"),
    }
}

fn read(folder: &Path) -> anyhow::Result<Vec<Row>> {
    let path = folder.join("runs.csv");
    let mut reader =
        csv::Reader::from_path(&path).with_context(|| format!("cannot read {}", path.display()))?;
    let headers = reader.headers()?.clone();
    let mut rows = Vec::new();
    for record in reader.records() {
        let record = record?;
        let cells: BTreeMap<String, String> = headers
            .iter()
            .zip(record.iter())
            .map(|(h, v)| (h.to_owned(), v.to_owned()))
            .collect();
        if cells.get("outcome").map(String::as_str) != Some("completed") {
            continue;
        }
        let scene = cells.get("scene").cloned().unwrap_or_default();
        let run_id = cells.get("run_id").cloned().unwrap_or_default();
        let Some(tets) = cells.get("tets").and_then(|t| t.parse::<f64>().ok()) else {
            continue;
        };
        rows.push(Row {
            family: scene.split('-').next().unwrap_or("").to_owned(),
            solver: solver_label(&cells, &run_id),
            tets,
            cells,
        });
    }
    Ok(rows)
}

/// Least-squares slope of log y on log x.
fn slope(points: &[(f64, f64)]) -> Option<f64> {
    if points.len() < 2 {
        return None;
    }
    let n = points.len() as f64;
    let (lx, ly): (Vec<f64>, Vec<f64>) = points.iter().map(|(x, y)| (x.ln(), y.ln())).unzip();
    let (mx, my) = (lx.iter().sum::<f64>() / n, ly.iter().sum::<f64>() / n);
    let sxx: f64 = lx.iter().map(|x| (x - mx).powi(2)).sum();
    let sxy: f64 = lx.iter().zip(&ly).map(|(x, y)| (x - mx) * (y - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(folder) = args.first() else {
        bail!("usage: scaling_plot <study folder> [min_tets max_tets]");
    };
    let folder = Path::new(folder);
    let parse = |i: usize, default: f64| -> anyhow::Result<f64> {
        args.get(i)
            .map(|v| v.parse::<f64>().with_context(|| format!("bad number {v}")))
            .unwrap_or(Ok(default))
    };
    let (lo, hi) = (parse(1, 1e4)?, parse(2, 3e5)?);
    let rows = read(folder)?;
    if rows.is_empty() {
        bail!("{}: no completed runs with a tets column", folder.display());
    }
    let mut families: Vec<&str> = rows.iter().map(|r| r.family.as_str()).collect();
    families.sort_unstable();
    families.dedup();
    let mut slopes = String::from("family,solver,metric,slope,fit_min_tets,fit_max_tets,points\n");
    let metrics = [
        (
            "step_seconds_median",
            "steady time per step [s]",
            "step_time",
        ),
        ("setup_seconds", "first-step setup [s]", "setup_time"),
        (
            "factor_flops",
            "predicted factorization flops",
            "factor_flops",
        ),
        ("factor_nnz", "nnz(L)", "factor_nnz"),
        (
            "linear_iterations_per_solve",
            "CG iterations per solve",
            "cg_iterations",
        ),
        ("peak_rss_mib", "peak resident memory [MiB]", "peak_memory"),
    ];
    for family in families {
        for (column, label, stem) in metrics {
            let mut by_solver: BTreeMap<&str, Vec<(f64, f64)>> = BTreeMap::new();
            for r in rows.iter().filter(|r| r.family == family) {
                let skip_direct_only = matches!(column, "factor_flops" | "factor_nnz")
                    && !r.solver.starts_with("cholesky");
                let skip_cg_only =
                    column == "linear_iterations_per_solve" && !r.solver.starts_with("cg");
                if skip_direct_only || skip_cg_only {
                    continue;
                }
                if let Some(y) = r.number(column) {
                    by_solver.entry(&r.solver).or_default().push((r.tets, y));
                }
            }
            let mut series = Vec::new();
            for (solver, mut points) in by_solver {
                points.sort_by(|a, b| a.0.total_cmp(&b.0));
                let fit: Vec<(f64, f64)> = points
                    .iter()
                    .copied()
                    .filter(|(x, _)| *x >= lo && *x <= hi)
                    .collect();
                let s = slope(&fit);
                let shown = s.map_or("slope n/a".to_owned(), |s| format!("slope {s:.2}"));
                if let Some(s) = s {
                    slopes.push_str(&format!(
                        "{family},{solver},{column},{s:.3},{lo},{hi},{}\n",
                        fit.len()
                    ));
                }
                series.push(Series {
                    label: format!("{solver} ({shown})"),
                    points,
                    ended: false,
                });
            }
            if series.is_empty() {
                continue;
            }
            let chart = Chart::Line(LineChart {
                title: format!(
                    "{family}: {label} vs tets (slope fitted over {lo:.0}-{hi:.0} tets)"
                ),
                x_label: "tets".into(),
                y_label: label.into(),
                x_log: true,
                y_log: true,
                series,
            });
            draw(&chart, &folder.join(format!("scaling_{family}_{stem}")))?;
        }
    }
    softbench::io::write_atomic(&folder.join("slopes.csv"), |w| {
        w.write_all(slopes.as_bytes())
    })?;
    Ok(())
}
