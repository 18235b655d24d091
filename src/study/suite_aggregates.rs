//! A suite's aggregates, from its `runs.csv` alone: data and performance profiles (Moré–Wild,
//! Dolan–Moré) per cut-off level, cost (evaluations, wall time), tier and stratum; pairwise
//! views; failure kinds; the omissions list; and findings computed from them, with ties.
//!
//! A *problem* is a suite problem (a scene); a method *solves* it at a level when its run at
//! that level has `solved = yes` (reached the horizon within the budget, error within the
//! tolerance). Its cost there is that run's, in force + Hessian evaluations (the same on any
//! machine) or in wall seconds (with its spread over repeats). A method without a cut-off
//! (explicit methods, Rosenbrock) has one run that stands at every level. Every budget caps a
//! data profile's budget axis: a larger budget only extends the curves, so each fraction shown
//! stays as it is.

use super::charts::Emit;
use super::format::short;
use super::meta::StudyMeta;
use super::profiles::{CostTable, Solved, Steps};
use super::spec::Omission;
use super::table::Table;
use crate::plot::{Chart, LineChart, PlotError, Series};
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write;
use std::path::Path;

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

    fn unit(self) -> &'static str {
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
                })
            }
            Cost::Wall => {
                let w = runs.number(row, "wall_seconds")?;
                let low = runs.number(row, "wall_seconds_min").unwrap_or(w);
                let high = runs.number(row, "wall_seconds_max").unwrap_or(w);
                Some(Solved {
                    cost: w,
                    spread: [low.min(w), high.max(w)],
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
}

impl Problem {
    fn stratum(&self, dimension: &str) -> &str {
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
    fn budget(&self, cost: Cost, keep: &dyn Fn(&Problem) -> bool) -> Option<f64> {
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
    fn failures(&self, method: &str, level: &str) -> BTreeMap<String, usize> {
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
    fn strata(&self) -> Vec<(&'static str, Vec<String>)> {
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

/// The levels a suite's meta names (`[suite] levels`), else none (the runs give them).
fn levels_of(study: &StudyMeta) -> Vec<String> {
    study.levels.clone()
}

/// A data profile's steps cut at the budget: fractions beyond it are not measured.
fn within(steps: &Steps, budget: Option<f64>) -> Steps {
    match budget {
        None => steps.clone(),
        Some(b) => {
            let mut out: Steps = steps.iter().copied().filter(|(x, _)| *x <= b).collect();
            if let Some(&(_, f)) = out.last() {
                out.push((b, f));
            }
            out
        }
    }
}

/// Write the aggregate tables into `dir/profiles/` and emit the overall profile charts (per
/// level and cost, public tier).
pub(super) fn charts(
    dir: &Path,
    study: &StudyMeta,
    runs: &Table,
    emit: &mut Emit,
) -> Result<(), PlotError> {
    let suite = Suite::new(runs, &levels_of(study));
    let out = dir.join("profiles");
    let io = |path: &Path| {
        let path = path.to_owned();
        move |source| PlotError::Io { path, source }
    };
    std::fs::create_dir_all(&out).map_err(io(&out))?;
    let header = |cols: &[&str]| Table::new(cols.iter().map(|s| s.to_string()).collect());
    let mut profiles = header(&[
        "dimension",
        "stratum",
        "level",
        "cost",
        "profile",
        "method",
        "x",
        "fraction",
    ]);
    let mut summary = header(&[
        "dimension",
        "stratum",
        "level",
        "cost",
        "method",
        "problems",
        "solved",
        "best",
        "rho2",
        "rho10",
        "budget",
    ]);
    let mut costs = header(&[
        "problem",
        "level",
        "method",
        "solved",
        "failure",
        "error",
        "tolerance",
        "evaluations",
        "wall_seconds",
    ]);
    let mut pairwise = header(&[
        "level",
        "cost",
        "a",
        "b",
        "both_solved",
        "a_cheaper",
        "b_cheaper",
        "ties",
        "only_a",
        "only_b",
    ]);
    for level in &suite.levels {
        for p in &suite.problems {
            for m in &suite.methods {
                let Some(r) = suite.row(&p.name, m, level) else {
                    continue;
                };
                let g = |c: &str| runs.get(r, c).unwrap_or_default().to_owned();
                costs.rows.push(vec![
                    p.name.clone(),
                    level.clone(),
                    m.clone(),
                    g("solved"),
                    g("failure"),
                    g("error"),
                    g("tolerance"),
                    g("evaluations"),
                    g("wall_seconds"),
                ]);
            }
        }
        let mut groups: Vec<(&str, String)> = vec![("all", "all".to_owned())];
        for (d, values) in suite.strata() {
            groups.extend(values.into_iter().map(|v| (d, v)));
        }
        for (dimension, value) in &groups {
            let keep = |p: &Problem| *dimension == "all" || p.stratum(dimension) == value;
            for cost in Cost::ALL {
                let table = suite.costs(level, cost, &keep);
                let budget = suite.budget(cost, &keep);
                let perf = table.performance();
                let data = table.data();
                for (s, method) in table.solvers.iter().enumerate() {
                    for (profile, steps) in [
                        ("performance", &perf[s]),
                        ("data", &within(&data[s], budget)),
                    ] {
                        for (x, f) in steps {
                            profiles.rows.push(vec![
                                dimension.to_string(),
                                value.clone(),
                                level.clone(),
                                cost.name().into(),
                                profile.into(),
                                method.clone(),
                                format!("{x}"),
                                format!("{f:.4}"),
                            ]);
                        }
                    }
                }
                for line in table.summary() {
                    summary.rows.push(vec![
                        dimension.to_string(),
                        value.clone(),
                        level.clone(),
                        cost.name().into(),
                        line.solver.clone(),
                        table.problems.len().to_string(),
                        line.solved.to_string(),
                        line.best.to_string(),
                        format!("{:.4}", line.within2),
                        format!("{:.4}", line.within10),
                        budget.map_or(String::new(), |b| format!("{b}")),
                    ]);
                }
                if *dimension == "all" {
                    for a in 0..table.solvers.len() {
                        for b in 0..table.solvers.len() {
                            if a == b {
                                continue;
                            }
                            let x = pair(&table, a, b);
                            pairwise.rows.push(vec![
                                level.clone(),
                                cost.name().into(),
                                table.solvers[a].clone(),
                                table.solvers[b].clone(),
                                x.both.to_string(),
                                x.a_cheaper.to_string(),
                                x.b_cheaper.to_string(),
                                x.ties.to_string(),
                                x.only_a.to_string(),
                                x.only_b.to_string(),
                            ]);
                        }
                    }
                }
            }
        }
        // The charts: the public problems, per cost and profile; and each stratum's data
        // profile at the tightest level (the rest of the strata's profiles are in the CSV).
        let public = |p: &Problem| p.stratum("tier") != "hidden";
        for cost in Cost::ALL {
            for profile in [Profile::Data, Profile::Performance] {
                profile_chart(&suite, level, cost, profile, None, &public, emit)?;
            }
        }
        if Some(level) == suite.levels.last() {
            for (d, values) in suite.strata() {
                if d == "tier" {
                    continue;
                }
                for v in values {
                    let keep = |p: &Problem| public(p) && p.stratum(d) == v;
                    for cost in Cost::ALL {
                        profile_chart(
                            &suite,
                            level,
                            cost,
                            Profile::Data,
                            Some((d, &v)),
                            &keep,
                            emit,
                        )?;
                    }
                }
            }
        }
    }
    for (name, t) in [
        ("profiles.csv", &profiles),
        ("summary.csv", &summary),
        ("costs.csv", &costs),
        ("pairwise.csv", &pairwise),
    ] {
        let path = out.join(name);
        t.write(&path).map_err(io(&path))?;
    }
    let omissions = omissions_page(&suite, &study.omitted);
    let path = dir.join("omissions.md");
    crate::io::write_atomic(&path, |w| w.write_all(omissions.as_bytes())).map_err(io(&path))?;
    Ok(())
}

/// Which profile a chart draws.
#[derive(Clone, Copy, PartialEq)]
enum Profile {
    Data,
    Performance,
}

/// Draw one profile of the problems `keep` selects (a stratum's, when `stratum` names it) at
/// `level` in `cost`. Methods that solve none of them are named in the caption instead of
/// drawn as a line along zero.
fn profile_chart(
    suite: &Suite,
    level: &str,
    cost: Cost,
    profile: Profile,
    stratum: Option<(&str, &str)>,
    keep: &dyn Fn(&Problem) -> bool,
    emit: &mut Emit,
) -> Result<(), PlotError> {
    let table = suite.costs(level, cost, keep);
    let n = table.problems.len();
    if n == 0 {
        return Ok(());
    }
    let budget = suite.budget(cost, keep);
    let lines: Vec<Steps> = match profile {
        Profile::Data => table.data().iter().map(|s| within(s, budget)).collect(),
        Profile::Performance => table.performance(),
    };
    let (solving, none): (Vec<_>, Vec<_>) = table
        .solvers
        .iter()
        .zip(lines)
        .partition(|(_, steps)| steps.iter().any(|(_, f)| *f > 0.0));
    let name = match profile {
        Profile::Data => "Data",
        Profile::Performance => "Performance",
    };
    let which = match stratum {
        Some((d, v)) => format!("{d} = {v}"),
        None => "public".to_owned(),
    };
    let chart = LineChart {
        title: format!("{name} profile: {which}, level {level}, {n} problems"),
        x_label: match profile {
            Profile::Data => format!("budget: {}", cost.unit()),
            Profile::Performance => format!("α: cost / the cheapest's ({})", cost.unit()),
        },
        y_label: "fraction of problems solved".into(),
        x_log: true,
        y_log: false,
        series: solving
            .into_iter()
            .map(|(s, points)| Series {
                label: s.clone(),
                points,
                ended: false,
            })
            .collect(),
    };
    let mut stem = format!(
        "{}-{}-{}",
        name.to_lowercase(),
        cost.name(),
        super::charts::slug(level)
    );
    if let Some((d, v)) = stratum {
        stem.push_str(&format!("-{d}-{}", super::charts::slug(v)));
    }
    let none: Vec<String> = none.iter().map(|(s, _)| format!("`{s}`")).collect();
    emit(
        stem,
        &format!(
            "{} The {which} problems at cut-off level `{level}`, cost in {}.{}",
            match profile {
                Profile::Data =>
                    "Data profile (Moré–Wild): the fraction of problems each method solves within a budget; the axis ends at the largest problem budget, so a larger budget would only extend it.",
                Profile::Performance =>
                    "Performance profile (Dolan–Moré): the fraction of problems each method solves within α times the cheapest method's cost.",
            },
            cost.unit(),
            if none.is_empty() {
                String::new()
            } else {
                format!(" Solving none of them (no line): {}.", none.join(", "))
            }
        ),
        Chart::Line(chart),
    )
}

/// The omissions list: every method left out of a profile and why — left out by the suite,
/// unable to run some problems, problems left out (missing data) — computed from the meta's
/// omissions and the runs.
pub fn omissions_page(suite: &Suite, omitted: &[Omission]) -> String {
    let mut out = String::from(
        "# Omissions\n\nWhat the suite does not run, and why. A method that cannot run a \
         problem counts as not solving it in the profiles that include the problem; a method \
         absent from a stratum's profile is listed under that stratum.\n",
    );
    let whole: Vec<&Omission> = omitted.iter().filter(|o| o.method.is_none()).collect();
    let _ = writeln!(out, "\n## Problems left out\n");
    if whole.is_empty() {
        let _ = writeln!(out, "None.");
    }
    for o in &whole {
        let _ = writeln!(out, "- `{}`: {}", o.scene, o.reason);
    }
    let _ = writeln!(out, "\n## Methods left out of the suite\n");
    let suite_wide: Vec<&Omission> = omitted
        .iter()
        .filter(|o| o.scene.is_empty() && o.method.is_some())
        .collect();
    if suite_wide.is_empty() {
        let _ = writeln!(out, "None.");
    }
    for o in &suite_wide {
        let _ = writeln!(
            out,
            "- `{}`: {}",
            o.method.as_deref().unwrap_or(""),
            o.reason
        );
    }
    let _ = writeln!(out, "\n## Methods that cannot run some problems\n");
    let mut by_method: BTreeMap<&str, Vec<&Omission>> = BTreeMap::new();
    for o in omitted.iter().filter(|o| !o.scene.is_empty()) {
        if let Some(m) = &o.method {
            by_method.entry(m).or_default().push(o);
        }
    }
    if by_method.is_empty() {
        let _ = writeln!(out, "None.");
    }
    for (method, list) in &by_method {
        let reasons: BTreeSet<&str> = list.iter().map(|o| o.reason.as_str()).collect();
        let _ = writeln!(
            out,
            "- `{method}` cannot run {} of the {} problems ({}): {}",
            list.len(),
            suite.problems.len() + whole.len(),
            list.iter()
                .map(|o| format!("`{}`", o.scene))
                .collect::<Vec<_>>()
                .join(", "),
            reasons.into_iter().collect::<Vec<_>>().join("; ")
        );
    }
    let _ = writeln!(out, "\n## Methods absent from a stratum's profiles\n");
    let mut any = false;
    for (d, values) in suite.strata() {
        for v in values {
            let problems: Vec<&Problem> = suite
                .problems
                .iter()
                .filter(|p| p.stratum(d) == v)
                .collect();
            let absent: Vec<&String> = suite
                .methods
                .iter()
                .filter(|m| {
                    !problems.iter().any(|p| {
                        suite
                            .levels
                            .iter()
                            .any(|l| suite.row(&p.name, m, l).is_some())
                    })
                })
                .collect();
            if absent.is_empty() {
                continue;
            }
            any = true;
            let _ = writeln!(
                out,
                "- {d} = `{v}` ({} problems): {} (they cannot run any of its problems; see above)",
                problems.len(),
                absent
                    .iter()
                    .map(|m| format!("`{m}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    if !any {
        let _ = writeln!(
            out,
            "None: every method runs at least one problem of every stratum."
        );
    }
    out
}

/// The summary lines of the methods in `table`, best first: most solved, then most often the
/// cheapest (ties counted), then ρ(2).
fn ranked(table: &CostTable) -> Vec<super::profiles::SolverSummary> {
    let mut s = table.summary();
    s.sort_by(|a, b| {
        b.solved
            .cmp(&a.solved)
            .then(b.best.cmp(&a.best))
            .then(b.within2.total_cmp(&a.within2))
    });
    s
}

/// Names with equal `key` at the top of `lines` (a tie for first).
fn leaders<T>(
    lines: &[T],
    key: impl Fn(&T) -> usize,
    name: impl Fn(&T) -> String,
) -> (Vec<String>, usize) {
    let top = lines.iter().map(&key).max().unwrap_or(0);
    (
        lines.iter().filter(|l| key(l) == top).map(name).collect(),
        top,
    )
}

fn names(list: &[String]) -> String {
    list.iter()
        .map(|m| format!("`{m}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The report's aggregate sections: what was solved, by whom, at what cost, per level and
/// stratum; how the ordering moves between levels; failure kinds; the hidden tier apart.
pub(super) fn report(out: &mut String, runs: &Table, study: &StudyMeta) {
    let suite = Suite::new(runs, &levels_of(study));
    if suite.problems.is_empty() {
        return;
    }
    let public = |p: &Problem| p.stratum("tier") != "hidden";
    let hidden = |p: &Problem| p.stratum("tier") == "hidden";
    let n_public = suite.problems.iter().filter(|p| public(p)).count();
    let n_hidden = suite.problems.len() - n_public;
    let _ = writeln!(
        out,
        "## Suite aggregates\n\n{} problems ({n_public} public, {n_hidden} hidden), {} methods, \
         {} cut-off levels. Profiles, costs and pairwise counts of every method are in \
         `profiles/` (CSV); what is not run is in [omissions.md](omissions.md). Costs in \
         evaluations are force + Hessian evaluations (the same on any machine); wall times are \
         of this machine. Ties: equal evaluation counts, or overlapping wall-time spreads over \
         repeats.\n",
        suite.problems.len(),
        suite.methods.len(),
        suite.levels.len()
    );
    problems_table(out, &suite);
    for (tier, keep) in [
        ("public", &public as &dyn Fn(&Problem) -> bool),
        ("hidden", &hidden as &dyn Fn(&Problem) -> bool),
    ] {
        let count = suite.problems.iter().filter(|p| keep(p)).count();
        if count == 0 {
            continue;
        }
        let _ = writeln!(out, "### The {tier} problems ({count})\n");
        for level in &suite.levels {
            let table = suite.costs(level, Cost::Evaluations, keep);
            let wall = suite.costs(level, Cost::Wall, keep);
            let lines = ranked(&table);
            let (most, solved) = leaders(&lines, |l| l.solved, |l| l.solver.clone());
            let (cheapest, best) = leaders(&lines, |l| l.best, |l| l.solver.clone());
            let wall_lines = wall.summary();
            let (fastest, fast) = leaders(&wall_lines, |l| l.best, |l| l.solver.clone());
            let budget = suite.budget(Cost::Evaluations, keep);
            let _ = writeln!(
                out,
                "**Level `{level}`.** Most problems solved: {} ({solved} of {count}{}). \
                 Cheapest in evaluations most often: {} ({best} problems, ties counted). \
                 Fastest in wall time most often: {} ({fast}).\n",
                names(&most),
                budget.map_or(String::new(), |b| format!(
                    ", each within its problem's budget; the largest is {} evaluations",
                    short(b)
                )),
                names(&cheapest),
                names(&fastest),
            );
            let _ = writeln!(
                out,
                "| method | solved | cheapest (evaluations) | ρ(2) | ρ(10) | fastest (wall) | failures |\n|---|---|---|---|---|---|---|"
            );
            for l in &lines {
                let w = wall_lines.iter().find(|w| w.solver == l.solver);
                let failures = suite
                    .failures(&l.solver, level)
                    .into_iter()
                    .filter(|(k, _)| k != "solved")
                    .map(|(k, n)| format!("{k} {n}"))
                    .collect::<Vec<_>>()
                    .join(", ");
                let _ = writeln!(
                    out,
                    "| `{}` | {} | {} | {:.2} | {:.2} | {} | {} |",
                    l.solver,
                    l.solved,
                    l.best,
                    l.within2,
                    l.within10,
                    w.map_or(0, |w| w.best),
                    failures
                );
            }
            let _ = writeln!(out);
        }
        ordering(out, &suite, keep);
        if tier == "public" {
            strata(out, &suite, keep);
            pairwise_table(out, &suite, keep);
        }
    }
}

/// The problems as the runs state them: strata, size, protocol, tolerance, the reference's
/// error bar, and how many methods solved each at each level.
fn problems_table(out: &mut String, suite: &Suite) {
    let runs = suite.runs;
    let _ = writeln!(
        out,
        "### The problems\n\n| problem | tier | difficulty | scenario | material | ν | tets | dt (s) × steps | tolerance | reference error bar | budget (evaluations, factorizations, s) | solved by ({}) |\n|---|---|---|---|---|---|---|---|---|---|---|---|",
        suite.levels.join(", ")
    );
    for p in &suite.problems {
        let Some(r) = runs
            .rows
            .iter()
            .find(|r| runs.get(r, "scene") == Some(&p.name))
        else {
            continue;
        };
        let g = |c: &str| runs.get(r, c).unwrap_or_default();
        let n = |c: &str| runs.number(r, c).map_or("-".to_owned(), short);
        let solved: Vec<String> = suite
            .levels
            .iter()
            .map(|l| {
                let table = suite.costs(l, Cost::Evaluations, &|q: &Problem| q.name == p.name);
                table
                    .summary()
                    .iter()
                    .filter(|s| s.solved > 0)
                    .count()
                    .to_string()
            })
            .collect();
        let _ = writeln!(
            out,
            "| `{}` | {} | {} | {} | {} | {} | {} | {} × {} | {} | {} | {}, {}, {} | {} of {} |",
            p.name,
            g("tier"),
            g("difficulty"),
            g("scenario"),
            g("material"),
            g("nu"),
            g("tets"),
            n("dt"),
            g("steps"),
            n("tolerance"),
            n("reference_difference"),
            n("budget_evaluations"),
            n("budget_factorizations"),
            n("budget_wall_seconds"),
            solved.join(", "),
            suite
                .methods
                .iter()
                .filter(|m| suite
                    .levels
                    .iter()
                    .any(|l| suite.row(&p.name, m, l).is_some()))
                .count()
        );
    }
    let _ = writeln!(out);
}

/// Whether the ordering by problems solved (then cheapest count) holds across levels.
fn ordering(out: &mut String, suite: &Suite, keep: &dyn Fn(&Problem) -> bool) {
    if suite.levels.len() < 2 {
        return;
    }
    let score = |level: &str| -> Vec<(String, f64)> {
        let table = suite.costs(level, Cost::Evaluations, keep);
        table
            .summary()
            .into_iter()
            .map(|l| (l.solver, l.solved as f64 * 1e3 + l.best as f64))
            .collect()
    };
    let first = &suite.levels[0];
    let last = &suite.levels[suite.levels.len() - 1];
    let (a, b) = (score(first), score(last));
    let common: Vec<&String> = a
        .iter()
        .map(|(m, _)| m)
        .filter(|m| b.iter().any(|(n, _)| n == *m))
        .collect();
    let x: Vec<f64> = common
        .iter()
        .map(|m| a.iter().find(|(n, _)| n == *m).map_or(0.0, |p| p.1))
        .collect();
    let y: Vec<f64> = common
        .iter()
        .map(|m| b.iter().find(|(n, _)| n == *m).map_or(0.0, |p| p.1))
        .collect();
    let rank = |v: &[f64], i: usize| 1 + v.iter().filter(|w| **w > v[i]).count();
    let mut moved: Vec<(String, usize, usize)> = (0..common.len())
        .map(|i| (common[i].clone(), rank(&x, i), rank(&y, i)))
        .filter(|(_, r1, r2)| r1.abs_diff(*r2) >= 3)
        .collect();
    moved.sort_by_key(|(_, r1, r2)| std::cmp::Reverse(r1.abs_diff(*r2)));
    let tau = kendall_tau(&x, &y);
    let _ = writeln!(
        out,
        "**Ordering across levels.** Ranked by problems solved (then by how often cheapest), \
         the orderings at `{first}` and `{last}` have Kendall's τ = {} over {} methods. {}\n",
        tau.map_or("-".into(), |t| format!("{t:.2}")),
        common.len(),
        if moved.is_empty() {
            "No method moves by three ranks or more.".to_owned()
        } else {
            format!(
                "Methods that move by three ranks or more: {}.",
                moved
                    .iter()
                    .map(|(m, r1, r2)| format!("`{m}` {r1} → {r2}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        }
    );
}

/// Per stratum and level: who solves most, who is cheapest most often.
fn strata(out: &mut String, suite: &Suite, keep: &dyn Fn(&Problem) -> bool) {
    let _ = writeln!(
        out,
        "**By stratum** (public problems; most solved, then cheapest in evaluations most often, \
         ties listed together):\n\n| stratum | problems | level | most solved | cheapest most often |\n|---|---|---|---|---|"
    );
    for (d, values) in suite.strata() {
        if d == "tier" {
            continue;
        }
        for v in values {
            let sel = |p: &Problem| keep(p) && p.stratum(d) == v;
            let count = suite.problems.iter().filter(|p| sel(p)).count();
            if count == 0 {
                continue;
            }
            for level in &suite.levels {
                let table = suite.costs(level, Cost::Evaluations, &sel);
                let lines = table.summary();
                let (most, solved) = leaders(&lines, |l| l.solved, |l| l.solver.clone());
                let (cheap, best) = leaders(&lines, |l| l.best, |l| l.solver.clone());
                let show = |list: &[String], n: usize| {
                    if n == 0 {
                        "none".to_owned()
                    } else if list.len() > 6 {
                        format!("{} methods tie ({n})", list.len())
                    } else {
                        format!("{} ({n})", names(list))
                    }
                };
                let _ = writeln!(
                    out,
                    "| {d} = {v} | {count} | {level} | {} | {} |",
                    show(&most, solved),
                    show(&cheap, best)
                );
            }
        }
    }
    let _ = writeln!(out);
}

/// Pairwise counts among the methods that solve the most public problems at the tightest
/// level: wins–losses (ties) on the problems both solve, in evaluations.
fn pairwise_table(out: &mut String, suite: &Suite, keep: &dyn Fn(&Problem) -> bool) {
    let Some(level) = suite.levels.last() else {
        return;
    };
    let table = suite.costs(level, Cost::Evaluations, keep);
    let top: Vec<String> = ranked(&table)
        .into_iter()
        .filter(|l| l.solved > 0)
        .take(8)
        .map(|l| l.solver)
        .collect();
    if top.len() < 2 {
        return;
    }
    let index = |m: &str| table.solvers.iter().position(|s| s == m).expect("listed");
    let _ = writeln!(
        out,
        "**Pairwise** at level `{level}` (public problems), the eight methods that solve the \
         most: a cell is row-method wins – losses (ties) in evaluations on the problems both \
         solve, then + problems only the row method solves / − only the column method. \
         `profiles/pairwise.csv` has every pair at every level and cost.\n"
    );
    let _ = writeln!(
        out,
        "| | {} |\n|---|{}",
        top.iter()
            .map(|m| format!("`{m}`"))
            .collect::<Vec<_>>()
            .join(" | "),
        "---|".repeat(top.len())
    );
    for a in &top {
        let cells: Vec<String> = top
            .iter()
            .map(|b| {
                if a == b {
                    return "—".into();
                }
                let p = pair(&table, index(a), index(b));
                format!(
                    "{}–{} ({}) +{}/−{}",
                    p.a_cheaper, p.b_cheaper, p.ties, p.only_a, p.only_b
                )
            })
            .collect();
        let _ = writeln!(out, "| `{a}` | {} |", cells.join(" | "));
    }
    let _ = writeln!(out);
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
