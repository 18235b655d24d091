//! A claim's verdict from its rule's cases. The share of decided cases where the claim holds
//! decides it:
//!
//! - **validated**: it holds in at least `holds_at` of the decided cases (default 0.75);
//! - **refuted**: it holds in at most `1 − holds_at`;
//! - **qualified**: in between; the condition is every stratum (a value of a `qualify_by`
//!   column) where it holds in at least `holds_at` of at least `min_cases` cases, else the
//!   share itself;
//! - **unmeasured**: fewer than `min_cases` decided cases (default 3).
//!
//! Ties (equal values) are reported and decide nothing. No threshold here is a cap on a
//! measurement: `holds_at` is the claim's own standard of evidence, stated with its verdict.

use super::filter::Filter;
use super::rule::{Better, Expect, Rule, RuleSpec, Standard};
use crate::study::table::Table;
use std::collections::BTreeMap;

/// A row of a trend with its x and y.
type Point<'t> = (&'t Vec<String>, f64, f64);

/// A case the rule decided: whether the claim held there, the row its strata are read from,
/// and a label for the evidence.
struct Case<'t> {
    holds: bool,
    row: &'t [String],
    label: String,
}

/// The verdict classes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Class {
    Validated,
    Qualified,
    Refuted,
    Unmeasured,
}

impl Class {
    pub fn name(self) -> &'static str {
        match self {
            Self::Validated => "validated",
            Self::Qualified => "qualified",
            Self::Refuted => "refuted",
            Self::Unmeasured => "unmeasured",
        }
    }
}

/// What a rule found.
#[derive(Clone, Debug, PartialEq)]
pub struct Verdict {
    pub class: Class,
    /// The condition of a qualified verdict, or why a claim is unmeasured.
    pub condition: String,
    /// Cases where it held, decided cases, and ties (undecided).
    pub held: usize,
    pub decided: usize,
    pub ties: usize,
    /// Per stratum: `(column, value, held, decided)`.
    pub strata: Vec<(String, String, usize, usize)>,
    /// A few decided cases, each with whether it held.
    pub examples: Vec<(String, bool)>,
}

fn key(table: &Table, row: &[String], columns: &[String]) -> Vec<String> {
    columns
        .iter()
        .map(|c| table.get(row, c).unwrap_or_default().to_owned())
        .collect()
}

/// Evaluate `spec` on `table`.
pub fn evaluate(spec: &RuleSpec, table: &Table) -> Verdict {
    let (cases, ties) = match &spec.rule {
        Rule::Compare {
            a,
            b,
            both,
            pair_by,
            metric,
            better,
            missing_is_worst,
        } => compared(
            table,
            [a, b, both],
            pair_by,
            metric,
            better,
            *missing_is_worst,
        ),
        Rule::Dominates {
            a,
            b,
            both,
            group_by,
            cost,
            error,
        } => dominated(table, [a, b, both], group_by, cost, error),
        Rule::Trend {
            rows,
            group_by,
            x,
            y,
            expect,
            slope_at_most,
        } => (
            trends(table, rows, group_by, (x, y), *expect, *slope_at_most),
            0,
        ),
        Rule::Bound {
            rows,
            metric,
            at_most,
            at_least,
            one_of,
        } => (
            bounded(
                table,
                rows,
                metric,
                (*at_most, *at_least),
                one_of.as_deref(),
            ),
            0,
        ),
    };
    judge(spec, table, &cases, ties)
}

/// `compare`: each row of `a` against the row of `b` with the same `pair_by` values (both
/// meeting `both`); a pair that compares equal is a tie.
fn compared<'t>(
    table: &'t Table,
    [a, b, both]: [&Filter; 3],
    pair_by: &[String],
    metric: &str,
    better: &Better,
    missing_is_worst: bool,
) -> (Vec<Case<'t>>, usize) {
    let side = |f: &Filter| -> BTreeMap<Vec<String>, &'t Vec<String>> {
        table
            .rows
            .iter()
            .filter(|r| f.keeps(table, r) && both.keeps(table, r))
            .map(|r| (key(table, r, pair_by), r))
            .collect()
    };
    let (left, right) = (side(a), side(b));
    let mut out = Vec::new();
    let mut ties = 0;
    for (k, ra) in &left {
        let Some(rb) = right.get(k) else {
            continue;
        };
        let (x, y) = (
            table.get(ra, metric).unwrap_or_default(),
            table.get(rb, metric).unwrap_or_default(),
        );
        match better.compare(x, y, missing_is_worst) {
            Some(holds) => out.push(Case {
                holds,
                row: ra,
                label: format!("{}: {x} against {y}", k.join(", ")),
            }),
            None => ties += 1,
        }
    }
    (out, ties)
}

/// `dominates`: each run of `b` against the runs of `a` in its group, in (cost, error); a `b`
/// run on the front of `a`'s (neither better) is a tie.
fn dominated<'t>(
    table: &'t Table,
    [a, b, both]: [&Filter; 3],
    group_by: &[String],
    cost: &str,
    error: &str,
) -> (Vec<Case<'t>>, usize) {
    let point = |r: &Vec<String>| Some((table.number(r, cost)?, table.number(r, error)?));
    let mut out = Vec::new();
    let mut ties = 0;
    for rb in table
        .rows
        .iter()
        .filter(|r| b.keeps(table, r) && both.keeps(table, r))
    {
        let Some((cb, eb)) = point(rb) else {
            continue;
        };
        let group = key(table, rb, group_by);
        let rivals: Vec<(f64, f64)> = table
            .rows
            .iter()
            .filter(|r| {
                a.keeps(table, r) && both.keeps(table, r) && key(table, r, group_by) == group
            })
            .filter_map(point)
            .collect();
        if rivals.is_empty() {
            continue;
        }
        let beaten = rivals
            .iter()
            .any(|&(c, e)| c <= cb && e <= eb && (c < cb || e < eb));
        let beats = rivals
            .iter()
            .any(|&(c, e)| cb <= c && eb <= e && (cb < c || eb < e));
        if !beaten && !beats {
            // On the other's front: neither is better.
            ties += 1;
            continue;
        }
        out.push(Case {
            holds: beaten,
            row: rb,
            label: format!("{}: {cost} {cb:.3e}, {error} {eb:.3e}", group.join(", ")),
        });
    }
    (out, ties)
}

/// `trend`: within each group of at least three positive points, whether `y` follows the
/// expected shape in `x`.
fn trends<'t>(
    table: &'t Table,
    rows: &Filter,
    group_by: &[String],
    (x, y): (&str, &str),
    expect: Expect,
    slope_at_most: Option<f64>,
) -> Vec<Case<'t>> {
    let mut groups: BTreeMap<Vec<String>, Vec<Point>> = BTreeMap::new();
    for r in table.rows.iter().filter(|r| rows.keeps(table, r)) {
        if let (Some(xv), Some(yv)) = (table.number(r, x), table.number(r, y))
            && xv > 0.0
            && yv > 0.0
        {
            groups
                .entry(key(table, r, group_by))
                .or_default()
                .push((r, xv, yv));
        }
    }
    let mut out = Vec::new();
    for (k, mut points) in groups {
        points.sort_by(|p, q| p.1.total_cmp(&q.1));
        if points.len() < 3 {
            continue;
        }
        let (holds, detail) = trend_holds(&points, expect, slope_at_most);
        out.push(Case {
            holds,
            row: points[0].0,
            label: format!("{}: {detail}", k.join(", ")),
        });
    }
    out
}

/// Whether sorted `points` (at least three) follow `expect`, and the evidence.
fn trend_holds(points: &[Point], expect: Expect, slope_at_most: Option<f64>) -> (bool, String) {
    let slope = |p: &Point, q: &Point| (q.2.ln() - p.2.ln()) / (q.1.ln() - p.1.ln());
    let n = points.len();
    let overall = slope(&points[0], &points[n - 1]);
    match expect {
        Expect::Decreasing => {
            let monotone = points.windows(2).all(|w| w[1].2 <= w[0].2);
            let steep = slope_at_most.is_none_or(|s| overall <= s);
            (
                monotone && steep,
                format!(
                    "{} from {:.3e} to {:.3e}, slope {overall:.2}",
                    if monotone {
                        "falls"
                    } else {
                        "does not fall throughout"
                    },
                    points[0].2,
                    points[n - 1].2
                ),
            )
        }
        Expect::EarlyFaster => {
            let mid = n / 2;
            let early = slope(&points[0], &points[mid]);
            let late = slope(&points[mid], &points[n - 1]);
            (
                early < late,
                format!("slope {early:.2} over the first half, {late:.2} over the last"),
            )
        }
    }
}

/// `bound`: every row's `metric` within the bounds, or one of the values.
fn bounded<'t>(
    table: &'t Table,
    rows: &Filter,
    metric: &str,
    (at_most, at_least): (Option<f64>, Option<f64>),
    one_of: Option<&[String]>,
) -> Vec<Case<'t>> {
    table
        .rows
        .iter()
        .filter(|r| rows.keeps(table, r))
        .map(|r| {
            let cell = table.get(r, metric).unwrap_or_default();
            let holds = match one_of {
                Some(values) => values.iter().any(|v| v == cell),
                None => cell.parse::<f64>().is_ok_and(|v| {
                    at_most.is_none_or(|hi| v <= hi) && at_least.is_none_or(|lo| v >= lo)
                }),
            };
            Case {
                holds,
                row: r,
                label: format!(
                    "{}: {metric} = {cell}",
                    r.first().map_or("", |s| s.as_str())
                ),
            }
        })
        .collect()
}

/// The verdict of the decided `cases`.
fn judge(spec: &RuleSpec, table: &Table, cases: &[Case], ties: usize) -> Verdict {
    let Standard {
        holds_at,
        min_cases,
    } = spec.standard;
    let held = cases.iter().filter(|c| c.holds).count();
    let decided = cases.len();
    let mut strata = Vec::new();
    for column in &spec.qualify_by {
        let mut by: BTreeMap<String, (usize, usize)> = BTreeMap::new();
        for c in cases {
            let v = table.get(c.row, column).unwrap_or_default().to_owned();
            let e = by.entry(v).or_default();
            e.0 += usize::from(c.holds);
            e.1 += 1;
        }
        strata.extend(by.into_iter().map(|(v, (h, n))| (column.clone(), v, h, n)));
    }
    let share = held as f64 / decided.max(1) as f64;
    let (class, condition) = if decided < min_cases {
        (
            Class::Unmeasured,
            format!(
                "{decided} decided case(s) ({ties} ties): fewer than the {min_cases} the rule needs"
            ),
        )
    } else if share >= holds_at {
        (Class::Validated, String::new())
    } else if share <= 1.0 - holds_at {
        (Class::Refuted, String::new())
    } else {
        let holding: Vec<String> = strata
            .iter()
            .filter(|(_, _, h, n)| *n >= min_cases && *h as f64 >= holds_at * *n as f64)
            .map(|(c, v, h, n)| format!("{c} = {v} ({h} of {n})"))
            .collect();
        let condition = if holding.is_empty() {
            format!(
                "holds in {held} of {decided} cases ({:.0} %), in no stratum of {} on {:.0} % or more",
                100.0 * share,
                if spec.qualify_by.is_empty() {
                    "(none named)".to_owned()
                } else {
                    spec.qualify_by.join(", ")
                },
                100.0 * holds_at
            )
        } else {
            format!("holds where {}", holding.join("; "))
        };
        (Class::Qualified, condition)
    };
    // A few of each outcome, in table order.
    let mut examples: Vec<(String, bool)> = Vec::new();
    for want in [true, false] {
        examples.extend(
            cases
                .iter()
                .filter(|c| c.holds == want)
                .take(4)
                .map(|c| (c.label.clone(), c.holds)),
        );
    }
    Verdict {
        class,
        condition,
        held,
        decided,
        ties,
        strata,
        examples,
    }
}
