//! Performance and data profiles of a work-precision study's runs: which methods reach an
//! accuracy on the most problems, and at what cost relative to the best (Dolan & Moré, *Math.
//! Program.* 2002) or in absolute budget (Moré & Wild, *SIAM J. Optim.* 2009).
//!
//! A *problem* is a scene with an accuracy target `τ`; a *solver* is a method (with its linear
//! solver when the table has several for it). A solver solves a problem when one of its runs on
//! the scene completed with `error <= τ`; its cost there is that of its cheapest such run, in
//! wall seconds and in force + Hessian evaluations (hardware-independent). Then, over the
//! problems `P`:
//!
//! - performance profile: `ρ_s(α) = |{p : t_ps <= α min_s' t_ps'}| / |P|`, `α >= 1`;
//!   `ρ_s(1)` is the share of problems where `s` is the cheapest;
//! - data profile: `d_s(β) = |{p : t_ps <= β}| / |P|`, the share solved within a budget `β`.
//!
//! A problem no solver solves counts in `|P|` for every solver. Wall times carry their spread
//! when the study repeated its runs (`wall_seconds_min`/`max`): two solvers whose intervals
//! overlap tie, so "cheapest" counts every solver that ties with the cheapest.

use crate::study::vocabulary::spread;
use crate::study::vocabulary::table::Table;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What the profiles measure cost in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cost {
    /// `wall_seconds` (the median over repeats).
    Wall,
    /// `force_evaluations + hessian_evaluations`.
    Work,
}

impl Cost {
    /// Both, in the order files are written.
    pub const ALL: [Cost; 2] = [Cost::Wall, Cost::Work];

    /// The name in file names and the CSV.
    pub fn name(self) -> &'static str {
        match self {
            Cost::Wall => "wall",
            Cost::Work => "work",
        }
    }

    /// The axis label of a budget in this cost.
    pub fn unit(self) -> &'static str {
        match self {
            Cost::Wall => "wall time [s]",
            Cost::Work => "force + Hessian evaluations",
        }
    }
}

/// Why profiles cannot be computed from a table.
#[derive(Debug, thiserror::Error)]
pub enum ProfilesError {
    #[error("{path}: no runs.csv: profiles are computed from a study's results folder")]
    NotResults { path: PathBuf },
    #[error("{path}: cannot read: {message}")]
    Read { path: PathBuf, message: String },
    #[error(
        "{path}: runs.csv has no column {missing:?}: profiles need a work-precision study's \
         table (scene, method, outcome, error, wall_seconds, force_evaluations, \
         hessian_evaluations)"
    )]
    MissingColumns { path: PathBuf, missing: Vec<String> },
    #[error("{path}: runs.csv has no runs")]
    Empty { path: PathBuf },
    #[error("accuracy target {value}: must be a finite positive number")]
    BadTarget { value: f64 },
}

impl softbench_core::error_class::Classify for ProfilesError {
    /// A results table or a target that profiles cannot be computed from.
    fn class(&self) -> softbench_core::error_class::ErrorClass {
        softbench_core::error_class::ErrorClass::BadInput
    }
}

/// The columns the profiles read.
pub const NEEDED: [&str; 7] = [
    "scene",
    "method",
    "outcome",
    "error",
    "wall_seconds",
    "force_evaluations",
    "hessian_evaluations",
];

/// One solver's cost on one problem: `None` when it did not solve it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Solved {
    /// The cheapest solving run's cost.
    pub cost: f64,
    /// Its spread `[low, high]` over repeats (the cost itself when not repeated): what the
    /// `best` count ties on.
    pub spread: [f64; 2],
    /// A wall time's spread from repeats and the step-time quartiles
    /// ([`spread::wall_seconds`]), as `costs.csv` writes it for the ledger; `None` in
    /// evaluations or when the run records neither.
    pub timing: Option<[f64; 2]>,
}

/// The costs of every solver on every problem, in one unit.
#[derive(Clone, Debug, PartialEq)]
pub struct CostTable {
    /// Problems as `(scene, target)`.
    pub problems: Vec<(String, f64)>,
    /// Solver labels, sorted.
    pub solvers: Vec<String>,
    /// `costs[p][s]`.
    pub costs: Vec<Vec<Option<Solved>>>,
    /// `(scene, target, floor)`: targets below the scene's reference accuracy
    /// (`floor_factor × reference_difference`), where no run can be judged; left out.
    pub left_out: Vec<(String, f64, f64)>,
}

/// A profile's points: `(x, fraction)` steps of one solver.
pub type Steps = Vec<(f64, f64)>;

fn label(table: &Table, row: &[String], split: &BTreeMap<String, bool>) -> String {
    let method = table.get(row, "method").unwrap_or_default();
    match table.get(row, "linear_solver") {
        Some(solver) if split.get(method).copied().unwrap_or(false) && !solver.is_empty() => {
            format!("{method} / {solver}")
        }
        _ => method.to_string(),
    }
}

impl CostTable {
    /// The costs in `cost` of the runs of `table` for the accuracy `targets`. A target below
    /// a scene's reference accuracy (`floor_factor` times its `reference_difference`) cannot
    /// be judged there and is left out; a run whose error was within that accuracy
    /// (`error_unscored`) solves every target that is judged.
    pub fn new(table: &Table, targets: &[f64], cost: Cost, floor_factor: f64) -> Self {
        // A method run with several linear solvers is one solver per linear solver.
        let mut solvers_of: BTreeMap<String, std::collections::BTreeSet<String>> = BTreeMap::new();
        for row in &table.rows {
            let method = table.get(row, "method").unwrap_or_default().to_string();
            let solver = table
                .get(row, "linear_solver")
                .unwrap_or_default()
                .to_string();
            solvers_of.entry(method).or_default().insert(solver);
        }
        let split: BTreeMap<String, bool> = solvers_of
            .iter()
            .map(|(m, s)| (m.clone(), s.len() > 1))
            .collect();
        let mut solvers: Vec<String> = table.rows.iter().map(|r| label(table, r, &split)).collect();
        solvers.sort();
        solvers.dedup();
        let mut scenes: Vec<String> = table
            .rows
            .iter()
            .map(|r| table.get(r, "scene").unwrap_or_default().to_string())
            .collect();
        scenes.sort();
        scenes.dedup();
        let floor = |scene: &str| -> f64 {
            table
                .rows
                .iter()
                .filter(|r| table.get(r, "scene") == Some(scene))
                .filter_map(|r| table.number(r, "reference_difference"))
                .fold(0.0f64, f64::max)
                * floor_factor
        };
        let mut problems = Vec::new();
        let mut left_out = Vec::new();
        for scene in &scenes {
            let f = floor(scene);
            for &t in targets {
                if t >= f {
                    problems.push((scene.clone(), t));
                } else {
                    left_out.push((scene.clone(), t, f));
                }
            }
        }
        let mut costs = vec![vec![None; solvers.len()]; problems.len()];
        for row in &table.rows {
            if table.get(row, "outcome") != Some("completed") {
                continue;
            }
            let Some(error) = table
                .number(row, "error")
                .or_else(|| table.number(row, "error_unscored"))
            else {
                continue;
            };
            let (value, spread, timing) = match cost {
                Cost::Wall => {
                    let Some(w) = table.number(row, "wall_seconds") else {
                        continue;
                    };
                    let low = table.number(row, "wall_seconds_min").unwrap_or(w);
                    let high = table.number(row, "wall_seconds_max").unwrap_or(w);
                    (
                        w,
                        [low.min(w), high.max(w)],
                        spread::wall_seconds(table, row),
                    )
                }
                Cost::Work => {
                    let (Some(f), Some(h)) = (
                        table.number(row, "force_evaluations"),
                        table.number(row, "hessian_evaluations"),
                    ) else {
                        continue;
                    };
                    (f + h, [f + h, f + h], None)
                }
            };
            let scene = table.get(row, "scene").unwrap_or_default();
            let s = solvers
                .iter()
                .position(|x| *x == label(table, row, &split))
                .expect("every row's label is listed");
            for (p, (problem_scene, target)) in problems.iter().enumerate() {
                if problem_scene != scene || error > *target {
                    continue;
                }
                let slot = &mut costs[p][s];
                if slot.is_none_or(|old: Solved| value < old.cost) {
                    *slot = Some(Solved {
                        cost: value,
                        spread,
                        timing,
                    });
                }
            }
        }
        Self {
            problems,
            solvers,
            costs,
            left_out,
        }
    }

    /// The cheapest cost on problem `p`, if any solver solved it.
    fn best(&self, p: usize) -> Option<Solved> {
        self.costs[p]
            .iter()
            .flatten()
            .copied()
            .min_by(|a, b| a.cost.total_cmp(&b.cost))
    }

    /// The performance profile of every solver: `(α, ρ(α))` steps from `α = 1`, ending at the
    /// largest finite ratio any solver has.
    pub fn performance(&self) -> Vec<Steps> {
        let ratios: Vec<Vec<f64>> = (0..self.solvers.len())
            .map(|s| {
                let mut r: Vec<f64> = (0..self.problems.len())
                    .filter_map(|p| Some(self.costs[p][s]?.cost / self.best(p)?.cost))
                    .collect();
                r.sort_by(f64::total_cmp);
                r
            })
            .collect();
        let end = ratios.iter().flatten().copied().fold(1.0f64, f64::max);
        ratios
            .iter()
            .map(|r| steps(r, 1.0, end, self.problems.len()))
            .collect()
    }

    /// The data profile of every solver: `(β, d(β))` steps over the budgets the runs used.
    pub fn data(&self) -> Vec<Steps> {
        let all: Vec<f64> = self
            .costs
            .iter()
            .flatten()
            .flatten()
            .map(|c| c.cost)
            .collect();
        let start = all.iter().copied().fold(f64::INFINITY, f64::min);
        let end = all.iter().copied().fold(0.0f64, f64::max);
        (0..self.solvers.len())
            .map(|s| {
                let mut c: Vec<f64> = (0..self.problems.len())
                    .filter_map(|p| Some(self.costs[p][s]?.cost))
                    .collect();
                c.sort_by(f64::total_cmp);
                if start.is_finite() {
                    steps(&c, start, end, self.problems.len())
                } else {
                    Vec::new()
                }
            })
            .collect()
    }

    /// Per solver: problems solved, problems where it is the cheapest or ties with the
    /// cheapest (spreads overlapping), and `ρ(2)`, `ρ(10)`.
    pub fn summary(&self) -> Vec<SolverSummary> {
        (0..self.solvers.len())
            .map(|s| {
                let mut solved = 0;
                let mut best = 0;
                let (mut within2, mut within10) = (0, 0);
                for p in 0..self.problems.len() {
                    let (Some(mine), Some(top)) = (self.costs[p][s], self.best(p)) else {
                        continue;
                    };
                    solved += 1;
                    if mine.spread[0] <= top.spread[1] {
                        best += 1;
                    }
                    let ratio = mine.cost / top.cost;
                    within2 += usize::from(ratio <= 2.0);
                    within10 += usize::from(ratio <= 10.0);
                }
                let n = self.problems.len().max(1) as f64;
                SolverSummary {
                    solver: self.solvers[s].clone(),
                    solved,
                    best,
                    within2: within2 as f64 / n,
                    within10: within10 as f64 / n,
                }
            })
            .collect()
    }
}

/// One solver's line in a profile summary.
#[derive(Clone, Debug, PartialEq)]
pub struct SolverSummary {
    pub solver: String,
    pub solved: usize,
    /// Problems where it is the cheapest or ties with it.
    pub best: usize,
    /// `ρ(2)` and `ρ(10)`.
    pub within2: f64,
    pub within10: f64,
}

/// A step function over sorted values: the fraction of `n` at or below x, from `start` to
/// `end`.
fn steps(sorted: &[f64], start: f64, end: f64, n: usize) -> Steps {
    let n = n.max(1) as f64;
    let below = sorted.iter().filter(|v| **v <= start).count();
    let mut out = vec![(start, below as f64 / n)];
    let mut count = below;
    for v in sorted.iter().copied().filter(|v| *v > start) {
        out.push((v, count as f64 / n));
        count += 1;
        out.push((v, count as f64 / n));
    }
    if end > out.last().map_or(start, |p| p.0) {
        out.push((end, count as f64 / n));
    }
    out
}

/// The points of a step function that a table needs: the first and each where the fraction
/// changes. The fraction at x is that of the last point at or before x; the corners a chart
/// draws between them, and the axis end it draws to, follow from these.
pub fn jumps(steps: &[(f64, f64)]) -> impl Iterator<Item = (f64, f64)> + '_ {
    steps
        .iter()
        .enumerate()
        .filter(|&(i, &(_, f))| i == 0 || f != steps[i - 1].1)
        .map(|(_, p)| *p)
}

/// The default accuracy targets: every decade from 1e-1 to 1e-8.
pub const DEFAULT_TARGETS: [f64; 8] = [1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8];

/// The reference's `floor_factor` a results folder's meta.json records (2, the default, when
/// it records none).
pub fn floor_factor(dir: &Path) -> f64 {
    std::fs::read(dir.join("meta.json"))
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        .and_then(|m| m["config"]["work_precision"]["reference"]["floor_factor"].as_f64())
        .unwrap_or(2.0)
}

/// Read a results folder's runs.csv and check it has what the profiles need.
pub fn read_runs(dir: &Path) -> Result<Table, ProfilesError> {
    let path = dir.join("runs.csv");
    let table = match Table::read(&path) {
        Ok(Some(t)) => t,
        Ok(None) => {
            return Err(ProfilesError::NotResults {
                path: dir.to_owned(),
            });
        }
        Err(e) => {
            return Err(ProfilesError::Read {
                path,
                message: e.to_string(),
            });
        }
    };
    let missing: Vec<String> = NEEDED
        .iter()
        .filter(|c| table.column(c).is_none())
        .map(|c| c.to_string())
        .collect();
    if !missing.is_empty() {
        return Err(ProfilesError::MissingColumns { path, missing });
    }
    if table.rows.is_empty() {
        return Err(ProfilesError::Empty { path });
    }
    Ok(table)
}

/// Check accuracy targets.
pub fn check_targets(targets: &[f64]) -> Result<(), ProfilesError> {
    match targets.iter().find(|t| !(t.is_finite() && **t > 0.0)) {
        Some(&value) => Err(ProfilesError::BadTarget { value }),
        None => Ok(()),
    }
}

/// What [`write`] wrote.
#[derive(Clone, Debug, Default)]
pub struct Written {
    /// Every file, in the order written.
    pub files: Vec<PathBuf>,
    /// Problems (scenes × targets) and solvers.
    pub problems: usize,
    pub solvers: usize,
}

/// Why the profiles could not be written.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    #[error("{path}: cannot write: {error}")]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error(transparent)]
    Plot(#[from] softbench_run::plot::PlotError),
}

impl softbench_core::error_class::Classify for WriteError {
    fn class(&self) -> softbench_core::error_class::ErrorClass {
        softbench_core::error_class::ErrorClass::Failure
    }
}

fn fraction(x: f64) -> String {
    format!("{x:.4}")
}

/// Write the profiles of `table` for `targets` into `out` (created if needed):
/// `profiles.csv` (every step of every profile), `costs.csv` (each solver's cost on each
/// problem, empty where it did not solve it, with the wall time's spread
/// `wall_seconds_low`/`wall_seconds_high` from [`spread::wall_seconds`]), `profiles.md` (the summary per solver and cost)
/// and the four charts `performance-{wall,work}` and `data-{wall,work}` (PNG and SVG).
pub fn write(
    table: &Table,
    targets: &[f64],
    floor_factor: f64,
    out: &Path,
) -> Result<Written, WriteError> {
    let io = |path: &Path| {
        let path = path.to_owned();
        move |error| WriteError::Io { path, error }
    };
    std::fs::create_dir_all(out).map_err(io(out))?;
    let mut written = Written::default();
    let mut steps_table = Table::new(
        ["profile", "cost", "solver", "x", "fraction"]
            .iter()
            .map(|s| s.to_string())
            .collect(),
    );
    let mut costs_table = Table::new(
        [
            "scene",
            "target",
            "solver",
            "wall_seconds",
            "evaluations",
            "wall_seconds_low",
            "wall_seconds_high",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect(),
    );
    let mut md = String::from(
        "# Profiles\n\nA problem is a scene with an accuracy target; a method solves it when one of \
         its runs completed with an error at or below the target, at the cost of the cheapest \
         such run. `best` counts the problems where it is the cheapest or its wall-time spread \
         overlaps the cheapest's; `ρ(2)` and `ρ(10)` are the shares of problems it solves within \
         2× and 10× of the cheapest (Dolan–Moré).\n",
    );
    let tables: Vec<(Cost, CostTable)> = Cost::ALL
        .iter()
        .map(|&c| (c, CostTable::new(table, targets, c, floor_factor)))
        .collect();
    let (_, wall) = &tables[0];
    let (_, work) = &tables[1];
    for (p, (scene, target)) in wall.problems.iter().enumerate() {
        for (s, solver) in wall.solvers.iter().enumerate() {
            let cell =
                |c: &CostTable| c.costs[p][s].map_or(String::new(), |x| format!("{}", x.cost));
            let [low, high] = spread::cells(wall.costs[p][s].and_then(|x| x.timing));
            costs_table.rows.push(vec![
                scene.clone(),
                format!("{target:e}"),
                solver.clone(),
                cell(wall),
                cell(work),
                low,
                high,
            ]);
        }
    }
    written.problems = wall.problems.len();
    written.solvers = wall.solvers.len();
    let targets_text: Vec<String> = targets.iter().map(|t| format!("{t:e}")).collect();
    md.push_str(&format!(
        "\n{} problems: the scenes × targets {}.\n",
        wall.problems.len(),
        targets_text.join(", ")
    ));
    for (scene, target, floor) in &wall.left_out {
        md.push_str(&format!(
            "\nLeft out: {scene} at {target:e}, below its reference's accuracy ({floor_factor} × \
             its reference difference = {floor:.3e}): no run can be judged there.\n"
        ));
    }
    for (cost, c) in &tables {
        md.push_str(&format!(
            "\n## Cost in {}\n\n| method | solved | best | ρ(2) | ρ(10) |\n|---|---|---|---|---|\n",
            cost.unit()
        ));
        let mut summary = c.summary();
        summary.sort_by(|a, b| b.best.cmp(&a.best).then(b.within2.total_cmp(&a.within2)));
        for s in &summary {
            md.push_str(&format!(
                "| `{}` | {} | {} | {:.2} | {:.2} |\n",
                s.solver, s.solved, s.best, s.within2, s.within10
            ));
        }
        for (profile, lines, x_label, x_log) in [
            (
                "performance",
                c.performance(),
                format!("α: cost / the cheapest's ({})", cost.unit()),
                true,
            ),
            ("data", c.data(), format!("budget: {}", cost.unit()), true),
        ] {
            let mut chart = softbench_run::plot::LineChart {
                title: format!(
                    "{} profile, cost in {}, {} problems",
                    if profile == "data" {
                        "Data"
                    } else {
                        "Performance"
                    },
                    cost.unit(),
                    c.problems.len()
                ),
                x_label,
                y_label: "fraction of problems solved".into(),
                x_log,
                y_log: false,
                series: Vec::new(),
            };
            for (solver, steps) in c.solvers.iter().zip(&lines) {
                for (x, f) in steps {
                    steps_table.rows.push(vec![
                        profile.into(),
                        cost.name().into(),
                        solver.clone(),
                        format!("{x}"),
                        fraction(*f),
                    ]);
                }
                chart.series.push(softbench_run::plot::Series {
                    label: solver.clone(),
                    points: steps.clone(),
                    ended: false,
                });
            }
            let stem = out.join(format!("{profile}-{}", cost.name()));
            written.files.extend(softbench_run::plot::draw(
                &softbench_run::plot::Chart::Line(chart),
                &stem,
            )?);
        }
    }
    for (name, t) in [("profiles.csv", &steps_table), ("costs.csv", &costs_table)] {
        let path = out.join(name);
        t.write(&path).map_err(io(&path))?;
        written.files.push(path);
    }
    let path = out.join("profiles.md");
    softbench_run::io::write_atomic(&path, |w| w.write_all(md.as_bytes())).map_err(io(&path))?;
    written.files.push(path);
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jumps_keep_the_first_point_and_every_change() {
        // Three problems solved at costs 2, 2 and 5, drawn from 1 to 8.
        let drawn = steps(&[2.0, 2.0, 5.0], 1.0, 8.0, 3);
        let kept: Vec<(f64, f64)> = jumps(&drawn).collect();
        assert_eq!(
            kept,
            vec![(1.0, 0.0), (2.0, 1.0 / 3.0), (2.0, 2.0 / 3.0), (5.0, 1.0)]
        );
        // The fraction at any x is the last kept point's at or before it, as drawn.
        for x in [1.0, 1.5, 2.0, 3.0, 5.0, 7.0, 8.0] {
            let at = |pts: &[(f64, f64)]| pts.iter().rev().find(|p| p.0 <= x).unwrap().1;
            assert_eq!(at(&kept), at(&drawn), "x = {x}");
        }
    }

    fn table(rows: &[(&str, &str, &str, f64, f64, f64)]) -> Table {
        let mut t = Table::new(NEEDED.iter().map(|s| s.to_string()).collect());
        for (scene, method, outcome, error, wall, work) in rows {
            t.rows.push(vec![
                scene.to_string(),
                method.to_string(),
                outcome.to_string(),
                error.to_string(),
                wall.to_string(),
                work.to_string(),
                "0".into(),
            ]);
        }
        t
    }

    #[test]
    fn costs_are_the_cheapest_run_that_meets_each_target() {
        let t = table(&[
            ("a", "x", "completed", 1e-2, 1.0, 10.0),
            ("a", "x", "completed", 1e-4, 4.0, 40.0),
            ("a", "y", "completed", 1e-3, 2.0, 20.0),
            ("a", "y", "blew-up", 1e-9, 0.1, 1.0),
            ("b", "y", "completed", 1e-5, 3.0, 30.0),
        ]);
        let c = CostTable::new(&t, &[1e-2, 1e-4], Cost::Wall, 2.0);
        assert_eq!(c.solvers, ["x", "y"]);
        let cost = |p: usize, s: usize| c.costs[p][s].map(|x| x.cost);
        // a@1e-2: x 1.0, y 2.0; a@1e-4: x 4.0, y none (its 1e-9 run blew up); b: y only.
        assert_eq!((cost(0, 0), cost(0, 1)), (Some(1.0), Some(2.0)));
        assert_eq!((cost(1, 0), cost(1, 1)), (Some(4.0), None));
        assert_eq!((cost(2, 0), cost(3, 1)), (None, Some(3.0)));
        let perf = c.performance();
        // x: ratio 1 on a@1e-2 and a@1e-4, unsolved on b's two: ρ(1) = 2/4.
        assert_eq!(perf[0][0], (1.0, 0.5));
        // y: ratio 1 on b's two, 2 on a@1e-2: ρ(1) = 2/4, ρ(2) = 3/4.
        assert_eq!(perf[1][0], (1.0, 0.5));
        assert!(perf[1].contains(&(2.0, 0.75)));
        let data = c.data();
        // Budget 1 solves x's a@1e-2 only; at 4 it has both of its problems.
        assert_eq!(data[0][0], (1.0, 0.25));
        assert_eq!(*data[0].last().unwrap(), (4.0, 0.5));
        let summary = c.summary();
        assert_eq!((summary[0].solved, summary[0].best), (2, 2));
        assert_eq!((summary[1].solved, summary[1].best), (3, 2));
        assert_eq!(summary[1].within2, 0.75);
    }

    #[test]
    fn overlapping_wall_time_spreads_tie() {
        let mut t = table(&[
            ("a", "x", "completed", 1e-3, 1.0, 10.0),
            ("a", "y", "completed", 1e-3, 1.1, 10.0),
        ]);
        t.header.push("wall_seconds_min".into());
        t.header.push("wall_seconds_max".into());
        t.rows[0].extend(["0.9".into(), "1.2".into()]);
        t.rows[1].extend(["1.05".into(), "1.3".into()]);
        let c = CostTable::new(&t, &[1e-2], Cost::Wall, 2.0);
        let s = c.summary();
        assert_eq!((s[0].best, s[1].best), (1, 1), "the spreads overlap: a tie");
        // In evaluations they are equal: both cheapest.
        let w = CostTable::new(&t, &[1e-2], Cost::Work, 2.0).summary();
        assert_eq!((w[0].best, w[1].best), (1, 1));
    }

    #[test]
    fn a_wall_cost_carries_the_spread_of_the_run_that_gave_it() {
        let mut t = table(&[
            ("a", "x", "completed", 1e-3, 3.0, 10.0),
            ("a", "x", "completed", 1e-3, 2.0, 10.0),
            ("a", "y", "completed", 1e-3, 1.0, 10.0),
        ]);
        t.header.extend(
            [
                "steps",
                "step_seconds_median",
                "step_seconds_q1",
                "step_seconds_q3",
            ]
            .map(String::from),
        );
        // x's cheaper run: 11 steps, the ten steady ones 0.19 s (0.18 to 0.21); y: one step.
        t.rows[0].extend(["11", "0.29", "0.28", "0.3"].map(String::from));
        t.rows[1].extend(["11", "0.19", "0.18", "0.21"].map(String::from));
        t.rows[2].extend(["1", "0", "0", "0"].map(String::from));
        let c = CostTable::new(&t, &[1e-2], Cost::Wall, 2.0);
        let x = c.costs[0][0].unwrap();
        assert_eq!(x.cost, 2.0);
        let [lo, hi] = x.timing.unwrap();
        assert!(
            (lo - 1.9).abs() < 1e-9 && (hi - 2.2).abs() < 1e-9,
            "{lo} {hi}"
        );
        assert_eq!(c.costs[0][1].unwrap().timing, None, "one step: no spread");
        assert_eq!(
            CostTable::new(&t, &[1e-2], Cost::Work, 2.0).costs[0][0]
                .unwrap()
                .timing,
            None
        );
    }

    #[test]
    fn targets_below_the_reference_accuracy_are_left_out_and_unscored_runs_solve_the_rest() {
        let mut t = table(&[
            ("a", "x", "completed", 1e-3, 1.0, 10.0),
            ("a", "y", "completed", 0.0, 2.0, 20.0),
        ]);
        t.header
            .extend(["error_unscored".into(), "reference_difference".into()]);
        t.rows[0].extend(["".into(), "1e-7".into()]);
        // y's error is within the reference's accuracy: not scored, its value kept apart.
        t.rows[1][3] = String::new();
        t.rows[1].extend(["5e-8".into(), "1e-7".into()]);
        let c = CostTable::new(&t, &[1e-2, 1e-6, 1e-7], Cost::Wall, 2.0);
        assert_eq!(
            c.problems,
            [("a".to_string(), 1e-2), ("a".to_string(), 1e-6)]
        );
        assert_eq!(c.left_out, [("a".to_string(), 1e-7, 2e-7)]);
        assert_eq!(c.costs[1][1].map(|x| x.cost), Some(2.0), "y solves 1e-6");
        assert_eq!(c.costs[1][0], None, "x does not");
    }

    #[test]
    fn bad_targets_are_refused() {
        assert!(check_targets(&[1e-3, 0.0]).is_err());
        assert!(check_targets(&[f64::NAN]).is_err());
        assert!(check_targets(&[1e-3]).is_ok());
    }
}
