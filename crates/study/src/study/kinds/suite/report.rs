//! A suite's report section, from `runs.csv` alone: the problems, per tier and level who
//! solves most and who is cheapest (ties counted), each method's failures by kind, the
//! ordering across levels, the leaders of every stratum and the pairwise counts.

use crate::study::kinds::suite::aggregates::{Cost, Problem, Suite, kendall_tau, pair};
use crate::study::present::profiles::CostTable;
use crate::study::vocabulary::format::short;
use crate::study::vocabulary::meta::StudyMeta;
use crate::study::vocabulary::table::Table;
use std::fmt::Write;

/// The summary lines of the methods in `table`, best first: most solved, then most often the
/// cheapest (ties counted), then ρ(2).
fn ranked(table: &CostTable) -> Vec<crate::study::present::profiles::SolverSummary> {
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
pub(in crate::study) fn report(out: &mut String, runs: &Table, study: &StudyMeta) {
    let suite = Suite::new(runs, &crate::study::kinds::suite::tables::levels_of(study));
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
        "### The problems\n\nA problem is judged on accuracy where its reference's error bar (its \
         difference from the independent solution), twice over, is below its tolerance; else two \
         valid answers differ by more than the tolerance, and a run solves it by reaching the \
         horizon within the budget (judged on robustness).\n\n\
         | problem | tier | difficulty | scenario | material | ν | tets | dt (s) × steps | tolerance | reference error bar | judged on | budget (evaluations, factorizations, s) | solved by ({}) |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|",
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
            "| `{}` | {} | {} | {} | {} | {} | {} | {} × {} | {} | {} | {} | {}, {}, {} | {} of {} |",
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
            if p.accuracy_judged() {
                "accuracy"
            } else {
                "robustness"
            },
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
