//! A suite's aggregates, from its `runs.csv` alone: the problems and their strata, each
//! method's cost on each problem at each cut-off level (the tables data and performance
//! profiles (Moré–Wild, Dolan–Moré) are drawn from), pairwise counts and Kendall's τ between
//! orderings. `suite_tables` writes them with their charts, `suite_report` the findings.
//!
//! A *problem* is a suite problem (a scene); a method *solves* it at a level when its run at
//! that level has `solved = yes` (reached the horizon within the budget, error within the
//! tolerance). Its cost there is that run's, in force + Hessian evaluations (the same on any
//! machine) or in wall seconds (with its spread over repeats). A method without a cut-off
//! (explicit methods, Rosenbrock) has one run that stands at every level. Every budget caps a
//! data profile's budget axis: a larger budget only extends the curves, so each fraction shown
//! stays as it is.

use crate::study::present::profiles::{CostTable, Solved};
use crate::study::vocabulary::spread;
use crate::study::vocabulary::table::Table;
use std::collections::{BTreeMap, BTreeSet};

/// The strata a problem belongs to, by column of `runs.csv`.
pub const DIMENSIONS: [&str; 7] = [
    "tier",
    "mesh",
    "difficulty",
    "scenario",
    "material",
    "nu",
    "size",
];

/// What a profile's cost is counted in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cost {
    /// Force + Hessian evaluations (`evaluations`).
    Evaluations,
    /// Wall seconds (the median over repeats, with its spread).
    Wall,
}

impl Cost {
    pub const ALL: [Cost; 2] = [Cost::Evaluations, Cost::Wall];

    pub fn name(self) -> &'static str {
        match self {
            Cost::Evaluations => "evaluations",
            Cost::Wall => "wall",
        }
    }

    pub fn unit(self) -> &'static str {
        match self {
            Cost::Evaluations => "force + Hessian evaluations",
            Cost::Wall => "wall time [s]",
        }
    }

    /// A solving run's cost and spread.
    fn of(self, runs: &Table, row: &[String]) -> Option<Solved> {
        match self {
            Cost::Evaluations => {
                let c = runs.number(row, "evaluations")?;
                Some(Solved {
                    cost: c,
                    spread: [c, c],
                    timing: None,
                })
            }
            Cost::Wall => {
                let w = runs.number(row, "wall_seconds")?;
                let low = runs.number(row, "wall_seconds_min").unwrap_or(w);
                let high = runs.number(row, "wall_seconds_max").unwrap_or(w);
                Some(Solved {
                    cost: w,
                    spread: [low.min(w), high.max(w)],
                    timing: spread::wall_seconds(runs, row),
                })
            }
        }
    }

    /// The budget column that caps this cost.
    fn budget_column(self) -> &'static str {
        match self {
            Cost::Evaluations => "budget_evaluations",
            Cost::Wall => "budget_wall_seconds",
        }
    }
}

/// One problem of the suite: its name and strata.
#[derive(Clone, Debug, PartialEq)]
pub struct Problem {
    pub name: String,
    /// `(dimension, value)` for each of [`DIMENSIONS`].
    pub strata: Vec<(&'static str, String)>,
    pub tolerance: f64,
    /// The reference's error bar (its difference from the independent solution).
    pub reference_difference: f64,
}

impl Problem {
    /// Whether runs of it are judged on accuracy: its reference's error bar, times the floor
    /// factor (2), is below its tolerance. Else two valid answers differ by more than the
    /// tolerance, and a run is judged on reaching the horizon within the budget alone.
    pub fn accuracy_judged(&self) -> bool {
        2.0 * self.reference_difference < self.tolerance
    }

    pub fn stratum(&self, dimension: &str) -> &str {
        self.strata
            .iter()
            .find(|(d, _)| *d == dimension)
            .map_or("", |(_, v)| v.as_str())
    }
}

/// The suite's runs, read for the aggregates.
pub struct Suite<'a> {
    pub runs: &'a Table,
    /// The levels, loosest first, in the order the runs first name them.
    pub levels: Vec<String>,
    pub problems: Vec<Problem>,
    /// Methods with any run, sorted.
    pub methods: Vec<String>,
}

impl<'a> Suite<'a> {
    /// The suite of `runs` (a suite's `runs.csv`).
    pub fn new(runs: &'a Table, levels: &[String]) -> Self {
        let mut levels: Vec<String> = levels.to_vec();
        for r in &runs.rows {
            let l = runs.get(r, "level").unwrap_or_default();
            if l != "-" && !l.is_empty() && !levels.iter().any(|x| x == l) {
                levels.push(l.to_owned());
            }
        }
        let mut problems: Vec<Problem> = Vec::new();
        for r in &runs.rows {
            let name = runs.get(r, "scene").unwrap_or_default();
            if problems.iter().any(|p| p.name == name) {
                continue;
            }
            problems.push(Problem {
                name: name.to_owned(),
                strata: DIMENSIONS
                    .iter()
                    .map(|d| (*d, runs.get(r, d).unwrap_or_default().to_owned()))
                    .collect(),
                tolerance: runs.number(r, "tolerance").unwrap_or(f64::NAN),
                reference_difference: runs.number(r, "reference_difference").unwrap_or(0.0),
            });
        }
        let methods: BTreeSet<String> = runs
            .rows
            .iter()
            .map(|r| runs.get(r, "method").unwrap_or_default().to_owned())
            .collect();
        Self {
            runs,
            levels,
            problems,
            methods: methods.into_iter().collect(),
        }
    }

    /// The row of `method` on `problem` at `level` (its level's run, or its only run when it
    /// has no cut-off).
    pub fn row(&self, problem: &str, method: &str, level: &str) -> Option<&'a Vec<String>> {
        let runs = self.runs;
        let mut any = None;
        for r in &runs.rows {
            if runs.get(r, "scene") != Some(problem) || runs.get(r, "method") != Some(method) {
                continue;
            }
            match runs.get(r, "level") {
                Some(l) if l == level => return Some(r),
                Some("-") => any = Some(r),
                _ => {}
            }
        }
        any
    }

    /// The costs of every method on the problems `keep` selects, at `level`.
    pub fn costs(&self, level: &str, cost: Cost, keep: &dyn Fn(&Problem) -> bool) -> CostTable {
        let problems: Vec<&Problem> = self.problems.iter().filter(|p| keep(p)).collect();
        let solvers: Vec<String> = self
            .methods
            .iter()
            .filter(|m| {
                problems
                    .iter()
                    .any(|p| self.row(&p.name, m, level).is_some())
            })
            .cloned()
            .collect();
        let costs = problems
            .iter()
            .map(|p| {
                solvers
                    .iter()
                    .map(|m| {
                        let r = self.row(&p.name, m, level)?;
                        (self.runs.get(r, "solved") == Some("yes"))
                            .then(|| cost.of(self.runs, r))
                            .flatten()
                    })
                    .collect()
            })
            .collect();
        CostTable {
            problems: problems
                .iter()
                .map(|p| (p.name.clone(), p.tolerance))
                .collect(),
            solvers,
            costs,
            left_out: Vec::new(),
        }
    }

    /// The largest budget of `cost` over the problems `keep` selects (the end of the data
    /// profile's budget axis), if every one of them has one.
    pub fn budget(&self, cost: Cost, keep: &dyn Fn(&Problem) -> bool) -> Option<f64> {
        let mut most: Option<f64> = None;
        for p in self.problems.iter().filter(|p| keep(p)) {
            let b = self
                .runs
                .rows
                .iter()
                .find(|r| self.runs.get(r, "scene") == Some(&p.name))
                .and_then(|r| self.runs.number(r, cost.budget_column()))?;
            most = Some(most.map_or(b, |m: f64| m.max(b)));
        }
        most
    }

    /// Failure kinds of `method` at `level` over every problem: kind -> count (`solved`
    /// included).
    pub fn failures(&self, method: &str, level: &str) -> BTreeMap<String, usize> {
        let mut out = BTreeMap::new();
        for p in &self.problems {
            if let Some(r) = self.row(&p.name, method, level) {
                let f = self.runs.get(r, "failure").unwrap_or_default();
                let word = if f.is_empty() { "solved" } else { f };
                *out.entry(word.to_owned()).or_insert(0) += 1;
            }
        }
        out
    }

    /// The values each dimension takes, in first-seen order.
    pub fn strata(&self) -> Vec<(&'static str, Vec<String>)> {
        DIMENSIONS
            .iter()
            .map(|d| {
                let mut values: Vec<String> = Vec::new();
                for p in &self.problems {
                    let v = p.stratum(d).to_owned();
                    if !values.contains(&v) {
                        values.push(v);
                    }
                }
                values.sort();
                (*d, values)
            })
            .collect()
    }
}

/// How two methods compare on the problems of a cost table: both solved (and of those, how
/// many each was cheaper on, and ties), solved by one only.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Pair {
    pub both: usize,
    pub a_cheaper: usize,
    pub b_cheaper: usize,
    pub ties: usize,
    pub only_a: usize,
    pub only_b: usize,
}

/// `a` against `b` in `table` (indices into its solvers). Costs tie when their spreads
/// overlap (equal evaluation counts; wall-time ranges over repeats).
pub fn pair(table: &CostTable, a: usize, b: usize) -> Pair {
    let mut out = Pair::default();
    for row in &table.costs {
        match (row[a], row[b]) {
            (Some(x), Some(y)) => {
                out.both += 1;
                if x.spread[1] < y.spread[0] {
                    out.a_cheaper += 1;
                } else if y.spread[1] < x.spread[0] {
                    out.b_cheaper += 1;
                } else {
                    out.ties += 1;
                }
            }
            (Some(_), None) => out.only_a += 1,
            (None, Some(_)) => out.only_b += 1,
            (None, None) => {}
        }
    }
    out
}

/// Kendall's τ_b between two rankings given as scores (higher is better) of the same items.
pub fn kendall_tau(x: &[f64], y: &[f64]) -> Option<f64> {
    let n = x.len().min(y.len());
    let (mut concordant, mut discordant, mut tied_x, mut tied_y) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for i in 0..n {
        for j in i + 1..n {
            let dx = (x[i] - x[j]).signum() * f64::from(x[i] != x[j]);
            let dy = (y[i] - y[j]).signum() * f64::from(y[i] != y[j]);
            match (dx == 0.0, dy == 0.0) {
                (true, true) => {}
                (true, false) => tied_x += 1.0,
                (false, true) => tied_y += 1.0,
                (false, false) if dx == dy => concordant += 1.0,
                _ => discordant += 1.0,
            }
        }
    }
    let denominator =
        ((concordant + discordant + tied_x) * (concordant + discordant + tied_y)).sqrt();
    (denominator > 0.0).then(|| (concordant - discordant) / denominator)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kendall_tau_of_equal_and_reversed_rankings() {
        assert_eq!(kendall_tau(&[3.0, 2.0, 1.0], &[3.0, 2.0, 1.0]), Some(1.0));
        assert_eq!(kendall_tau(&[3.0, 2.0, 1.0], &[1.0, 2.0, 3.0]), Some(-1.0));
        assert_eq!(kendall_tau(&[1.0, 1.0], &[1.0, 1.0]), None);
    }
}
