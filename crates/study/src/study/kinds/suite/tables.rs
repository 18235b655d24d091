//! A suite's tables and charts, written into its results folder from `runs.csv` alone (so
//! `softbench plot` redraws them): `profiles/{profiles,summary,costs,pairwise}.csv`, the
//! profile charts (the public problems' at each level and cost; every stratum's data profile
//! at the tightest level) and `omissions.md`.

use crate::study::kinds::suite::aggregates::{Cost, Problem, Suite, pair};
use crate::study::present::charts::Emit;
use crate::study::present::profiles::{CostTable, Steps};
use crate::study::vocabulary::meta::StudyMeta;
use crate::study::vocabulary::spec::Omission;
use crate::study::vocabulary::spread;
use crate::study::vocabulary::table::Table;
use softbench_run::plot::{Chart, LineChart, PlotError, Series};
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write;
use std::path::Path;

/// The levels a suite's meta names (`[suite] levels`), else none (the runs give them).
pub(in crate::study) fn levels_of(study: &StudyMeta) -> Vec<String> {
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
pub(in crate::study) fn charts(
    dir: &Path,
    study: &StudyMeta,
    runs: &Table,
    emit: &mut Emit,
) -> Result<(), PlotError> {
    let suite = Suite::new(runs, &levels_of(study));
    let out = dir.join("profiles");
    std::fs::create_dir_all(&out).map_err(io(&out))?;
    let mut tables = Aggregates::new();
    for level in &suite.levels {
        tables.add_costs(&suite, runs, level);
        let mut groups: Vec<(&str, String)> = vec![("all", "all".to_owned())];
        for (d, values) in suite.strata() {
            groups.extend(values.into_iter().map(|v| (d, v)));
        }
        for (dimension, value) in &groups {
            let keep = |p: &Problem| *dimension == "all" || p.stratum(dimension) == value;
            for cost in Cost::ALL {
                let table = suite.costs(level, cost, &keep);
                let budget = suite.budget(cost, &keep);
                let group = Group {
                    dimension,
                    value,
                    level,
                    cost,
                };
                tables.add_profiles(&group, &table, budget);
                tables.add_summary(&group, &table, budget);
                if *dimension == "all" {
                    tables.add_pairwise(&group, &table);
                }
            }
        }
        level_charts(&suite, level, emit)?;
    }
    tables.write(&out)?;
    let omissions = omissions_page(&suite, &study.omitted);
    let path = dir.join("omissions.md");
    softbench_run::io::write_atomic(&path, |w| w.write_all(omissions.as_bytes()))
        .map_err(io(&path))?;
    Ok(())
}

/// A failed write of `path`, as a plot error.
fn io(path: &Path) -> impl FnOnce(std::io::Error) -> PlotError + use<> {
    let path = path.to_owned();
    move |source| PlotError::Io { path, source }
}

/// The charts of one level: the public problems, per cost and profile; and at the tightest
/// level each stratum's data profile (the rest of the strata's profiles are in the CSV).
fn level_charts(suite: &Suite, level: &String, emit: &mut Emit) -> Result<(), PlotError> {
    let public = |p: &Problem| p.stratum("tier") != "hidden";
    for cost in Cost::ALL {
        for profile in [Profile::Data, Profile::Performance] {
            profile_chart(suite, level, cost, profile, None, &public, emit)?;
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
                        suite,
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
    Ok(())
}

/// A set of problems an aggregate row is about: a stratum (or all), a level and a cost.
struct Group<'a> {
    dimension: &'a str,
    value: &'a str,
    level: &'a str,
    cost: Cost,
}

/// The tables of `profiles/`: each profile's breakpoints, each method's summary per group,
/// each run's cost, and the pairwise counts.
struct Aggregates {
    profiles: Table,
    summary: Table,
    costs: Table,
    pairwise: Table,
}

impl Aggregates {
    fn new() -> Self {
        let header = |cols: &[&str]| Table::new(cols.iter().map(|s| s.to_string()).collect());
        Self {
            profiles: header(&[
                "dimension",
                "stratum",
                "level",
                "cost",
                "profile",
                "method",
                "x",
                "fraction",
            ]),
            summary: header(&[
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
            ]),
            costs: header(&[
                "problem",
                "level",
                "method",
                "solved",
                "failure",
                "error",
                "tolerance",
                "evaluations",
                "wall_seconds",
                "wall_seconds_low",
                "wall_seconds_high",
            ]),
            pairwise: header(&[
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
            ]),
        }
    }

    /// Each run's cost at `level`, its wall time with the spread the ledger reads
    /// ([`spread::wall_seconds`]).
    fn add_costs(&mut self, suite: &Suite, runs: &Table, level: &str) {
        for p in &suite.problems {
            for m in &suite.methods {
                let Some(r) = suite.row(&p.name, m, level) else {
                    continue;
                };
                let g = |c: &str| runs.get(r, c).unwrap_or_default().to_owned();
                let [low, high] = spread::cells(spread::wall_seconds(runs, r));
                self.costs.rows.push(vec![
                    p.name.clone(),
                    level.to_owned(),
                    m.clone(),
                    g("solved"),
                    g("failure"),
                    g("error"),
                    g("tolerance"),
                    g("evaluations"),
                    g("wall_seconds"),
                    low,
                    high,
                ]);
            }
        }
    }

    /// The breakpoints of each method's performance and data profile over the group.
    fn add_profiles(&mut self, group: &Group, table: &CostTable, budget: Option<f64>) {
        let perf = table.performance();
        let data = table.data();
        for (s, method) in table.solvers.iter().enumerate() {
            for (profile, steps) in [
                ("performance", &perf[s]),
                ("data", &within(&data[s], budget)),
            ] {
                for (x, f) in crate::study::present::profiles::jumps(steps) {
                    self.profiles.rows.push(vec![
                        group.dimension.to_string(),
                        group.value.to_owned(),
                        group.level.to_owned(),
                        group.cost.name().into(),
                        profile.into(),
                        method.clone(),
                        // Six significant digits: a breakpoint, not a measurement (costs.csv
                        // has each run's cost in full).
                        format!("{x:.5e}").parse::<f64>().unwrap_or(x).to_string(),
                        format!("{f:.4}"),
                    ]);
                }
            }
        }
    }

    /// Each method's line of the group's summary.
    fn add_summary(&mut self, group: &Group, table: &CostTable, budget: Option<f64>) {
        for line in table.summary() {
            self.summary.rows.push(vec![
                group.dimension.to_string(),
                group.value.to_owned(),
                group.level.to_owned(),
                group.cost.name().into(),
                line.solver.clone(),
                table.problems.len().to_string(),
                line.solved.to_string(),
                line.best.to_string(),
                format!("{:.4}", line.within2),
                format!("{:.4}", line.within10),
                budget.map_or(String::new(), |b| format!("{b}")),
            ]);
        }
    }

    /// Every ordered pair of methods, counted over the group.
    fn add_pairwise(&mut self, group: &Group, table: &CostTable) {
        for a in 0..table.solvers.len() {
            for b in 0..table.solvers.len() {
                if a == b {
                    continue;
                }
                let x = pair(table, a, b);
                self.pairwise.rows.push(vec![
                    group.level.to_owned(),
                    group.cost.name().into(),
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

    /// Write the tables into `out`.
    fn write(&self, out: &Path) -> Result<(), PlotError> {
        for (name, t) in [
            ("profiles.csv", &self.profiles),
            ("summary.csv", &self.summary),
            ("costs.csv", &self.costs),
            ("pairwise.csv", &self.pairwise),
        ] {
            let path = out.join(name);
            t.write(&path).map_err(io(&path))?;
        }
        Ok(())
    }
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
        title: format!(
            "{name} profile in {}: {which}, level {level}, {n} problem{}",
            match cost {
                Cost::Evaluations => "evaluations",
                Cost::Wall => "wall time",
            },
            if n == 1 { "" } else { "s" }
        ),
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
        crate::study::present::charts::slug(level)
    );
    if let Some((d, v)) = stratum {
        stem.push_str(&format!("-{d}-{}", crate::study::present::charts::slug(v)));
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
    let _ = writeln!(out, "\n## Problems judged on robustness only\n");
    let robust: Vec<&Problem> = suite
        .problems
        .iter()
        .filter(|p| !p.accuracy_judged())
        .collect();
    if robust.is_empty() {
        let _ = writeln!(
            out,
            "None: every reference resolves its problem's tolerance."
        );
    }
    for p in robust {
        let _ = writeln!(
            out,
            "- `{}`: its reference differs from the independent solution by {:.3e}, and twice \
             that reaches its tolerance {}: a run solves it by reaching the horizon within the \
             budget; its error is reported, not judged",
            p.name, p.reference_difference, p.tolerance
        );
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
