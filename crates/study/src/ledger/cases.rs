//! The cases a rule reads from a table, each with its outcome: paired rows (`compare`), runs
//! against another method's work-precision front (`dominates`), a line along a knob
//! (`trend`) or rows against a bound (`bound`). [`super::verdict`] groups them into problems.
//!
//! A rule that decides on a measured time compares spreads ([`spread`]): two whose spreads
//! overlap tie, and a case whose times have no spread is [`Outcome::Unspread`] (it decides
//! nothing) unless the rule says `single_timings = true`.

use super::filter::Filter;
use super::rule::{Better, Expect, Rule, RuleSpec};
use crate::study::spread as run_spread;
use crate::study::table::Table;
use std::collections::BTreeMap;

/// How a case or a problem came out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// The claim holds (on a problem: in every case it decides).
    Held,
    /// It does not (on a problem: in no case it decides).
    Failed,
    /// A problem whose decided cases disagree.
    Split,
    /// Equal values, overlapping spreads, or a run on the other's front.
    Tie,
    /// Times compared without a spread: not decided.
    Unspread,
}

impl From<bool> for Outcome {
    fn from(holds: bool) -> Self {
        if holds { Self::Held } else { Self::Failed }
    }
}

impl Outcome {
    /// How the ledger says it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Held => "holds",
            Self::Failed => "does not hold",
            Self::Split => "split",
            Self::Tie => "tie",
            Self::Unspread => "timed without a spread",
        }
    }
}

/// A row of a trend with its x and y.
type Point<'t> = (&'t Vec<String>, f64, f64);

/// A case the rule read: its outcome (held, failed, tied or timed without a spread), the row
/// its problem and strata are read from, and a label for the evidence.
pub(super) struct Case<'t> {
    pub outcome: Outcome,
    pub row: &'t [String],
    pub label: String,
}

impl<'t> Case<'t> {
    fn decided(holds: bool, row: &'t [String], label: String) -> Self {
        Self {
            outcome: Outcome::from(holds),
            row,
            label,
        }
    }
}

/// A row's cells in `columns` (empty where the table lacks the column): a pair's, a group's
/// or a problem's name.
pub(super) fn key(table: &Table, row: &[String], columns: &[String]) -> Vec<String> {
    columns
        .iter()
        .map(|c| table.get(row, c).unwrap_or_default().to_owned())
        .collect()
}

/// The spread `[low, high]` of the time `metric` in `row`, widened to hold its value:
/// `<metric>_low`/`<metric>_high` where the table has them (a profile's `costs.csv`); for a
/// `<stem>_median`, `<stem>_q1`/`<stem>_q3`; for a run's `wall_seconds`, the spread its
/// repeats and step times give ([`run_spread::wall_seconds`]). `None` without one.
pub fn spread(table: &Table, row: &[String], metric: &str) -> Option<[f64; 2]> {
    let value = table.number(row, metric)?;
    let pair = |lo: &str, hi: &str| Some([table.number(row, lo)?, table.number(row, hi)?]);
    let (low, high) = (format!("{metric}_low"), format!("{metric}_high"));
    let found = if table.column(&low).is_some() {
        pair(&low, &high)
    } else if let Some(stem) = metric.strip_suffix("_median")
        && table.column(&format!("{stem}_q1")).is_some()
    {
        pair(&format!("{stem}_q1"), &format!("{stem}_q3"))
    } else if metric == "wall_seconds" {
        run_spread::wall_seconds(table, row)
    } else {
        None
    };
    found.map(|[lo, hi]| [lo.min(value), hi.max(value)])
}

/// Which of two spreads is smaller: `Some(true)` when `a` lies wholly below `b`,
/// `Some(false)` wholly above, `None` when they overlap.
fn below(a: [f64; 2], b: [f64; 2]) -> Option<bool> {
    if a[1] < b[0] {
        Some(true)
    } else if b[1] < a[0] {
        Some(false)
    } else {
        None
    }
}

fn shown(s: Option<[f64; 2]>) -> String {
    s.map_or(String::new(), |[lo, hi]| format!(" [{lo:.3e}, {hi:.3e}]"))
}

/// The cases of `spec` on `table`.
pub(super) fn of<'t>(spec: &RuleSpec, table: &'t Table) -> Vec<Case<'t>> {
    let timed = spec.spread_needed().is_some();
    match &spec.rule {
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
            (metric, timed),
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
        } => dominated(table, [a, b, both], group_by, (cost, timed), error),
        Rule::Trend {
            rows,
            group_by,
            x,
            y,
            expect,
            slope_at_most,
        } => trends(table, rows, group_by, (x, y), *expect, *slope_at_most),
        Rule::Bound {
            rows,
            metric,
            at_most,
            at_least,
            one_of,
        } => bounded(
            table,
            rows,
            (metric, timed),
            (*at_most, *at_least),
            one_of.as_deref(),
        ),
    }
}

/// `compare`: each row of `a` against the row of `b` with the same `pair_by` values (both
/// meeting `both`); a pair that compares equal is a tie, and so is a pair of times whose
/// spreads overlap.
fn compared<'t>(
    table: &'t Table,
    [a, b, both]: [&Filter; 3],
    pair_by: &[String],
    (metric, timed): (&str, bool),
    better: &Better,
    missing_is_worst: bool,
) -> Vec<Case<'t>> {
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
    for (k, ra) in &left {
        let Some(rb) = right.get(k) else {
            continue;
        };
        let (x, y) = (
            table.get(ra, metric).unwrap_or_default(),
            table.get(rb, metric).unwrap_or_default(),
        );
        // Two times are compared by their spreads; a time against no time (a problem not
        // solved) is decided by `missing` as any number is.
        let both_numbers = x.parse::<f64>().is_ok() && y.parse::<f64>().is_ok();
        if timed && both_numbers {
            let (sa, sb) = (spread(table, ra, metric), spread(table, rb, metric));
            let label = format!(
                "{}: {x}{} against {y}{}",
                k.join(", "),
                shown(sa),
                shown(sb)
            );
            let outcome = match (sa, sb) {
                (Some(sa), Some(sb)) => below(sa, sb).map_or(Outcome::Tie, |lower| {
                    Outcome::from(lower == matches!(better, Better::Smaller))
                }),
                _ => Outcome::Unspread,
            };
            out.push(Case {
                outcome,
                row: ra,
                label,
            });
            continue;
        }
        let label = format!("{}: {x} against {y}", k.join(", "));
        out.push(match better.compare(x, y, missing_is_worst) {
            Some(holds) => Case::decided(holds, ra, label),
            None => Case {
                outcome: Outcome::Tie,
                row: ra,
                label,
            },
        });
    }
    out
}

/// A run's place in (cost, error): its cost, the cost's spread, and its error.
struct Placed {
    cost: f64,
    spread: Option<[f64; 2]>,
    error: f64,
}

impl Placed {
    /// How this run's cost compares with `other`'s: by the spreads for a time, where
    /// overlapping spreads are equal costs.
    fn cost_order(&self, other: &Placed, timed: bool) -> std::cmp::Ordering {
        use std::cmp::Ordering;
        match (timed, self.spread, other.spread) {
            (true, Some(a), Some(b)) => match below(a, b) {
                Some(true) => Ordering::Less,
                Some(false) => Ordering::Greater,
                None => Ordering::Equal,
            },
            _ => self.cost.total_cmp(&other.cost),
        }
    }

    /// Whether this run dominates `other`: no larger cost and error, one of them smaller.
    fn dominates(&self, other: &Placed, timed: bool) -> bool {
        let c = self.cost_order(other, timed);
        c.is_le() && self.error <= other.error && (c.is_lt() || self.error < other.error)
    }
}

/// `dominates`: each run of `b` against the runs of `a` in its group, in (cost, error); a `b`
/// run on the front of `a`'s (neither better) is a tie. With a time for cost, costs whose
/// spreads overlap are equal, and a run without a spread (or a group whose `a` runs lack
/// one) decides nothing.
fn dominated<'t>(
    table: &'t Table,
    [a, b, both]: [&Filter; 3],
    group_by: &[String],
    (cost, timed): (&str, bool),
    error: &str,
) -> Vec<Case<'t>> {
    let place = |r: &Vec<String>| {
        Some(Placed {
            cost: table.number(r, cost)?,
            spread: spread(table, r, cost),
            error: table.number(r, error)?,
        })
    };
    let mut out = Vec::new();
    for rb in table
        .rows
        .iter()
        .filter(|r| b.keeps(table, r) && both.keeps(table, r))
    {
        let Some(pb) = place(rb) else {
            continue;
        };
        let group = key(table, rb, group_by);
        let rivals: Vec<Placed> = table
            .rows
            .iter()
            .filter(|r| {
                a.keeps(table, r) && both.keeps(table, r) && key(table, r, group_by) == group
            })
            .filter_map(place)
            .collect();
        if rivals.is_empty() {
            continue;
        }
        let label = format!(
            "{}: {cost} {:.3e}{}, {error} {:.3e}",
            group.join(", "),
            pb.cost,
            shown(pb.spread),
            pb.error
        );
        let outcome = if timed && (pb.spread.is_none() || rivals.iter().any(|r| r.spread.is_none()))
        {
            Outcome::Unspread
        } else if rivals.iter().any(|r| r.dominates(&pb, timed)) {
            Outcome::Held
        } else if rivals.iter().any(|r| pb.dominates(r, timed)) {
            Outcome::Failed
        } else {
            // On the other's front: neither is better.
            Outcome::Tie
        };
        out.push(Case {
            outcome,
            row: rb,
            label,
        });
    }
    out
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
        out.push(Case::decided(
            holds,
            points[0].0,
            format!("{}: {detail}", k.join(", ")),
        ));
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

/// `bound`: every row's `metric` within the bounds, or one of the values. A time is within
/// when its whole spread is, outside when its whole spread is, and a tie when its spread
/// straddles a bound.
fn bounded<'t>(
    table: &'t Table,
    rows: &Filter,
    (metric, timed): (&str, bool),
    (at_most, at_least): (Option<f64>, Option<f64>),
    one_of: Option<&[String]>,
) -> Vec<Case<'t>> {
    let within = |v: f64| at_most.is_none_or(|hi| v <= hi) && at_least.is_none_or(|lo| v >= lo);
    table
        .rows
        .iter()
        .filter(|r| rows.keeps(table, r))
        .map(|r| {
            let cell = table.get(r, metric).unwrap_or_default();
            let mut label = format!(
                "{}: {metric} = {cell}",
                r.first().map_or("", |s| s.as_str())
            );
            let outcome = match (one_of, cell.parse::<f64>()) {
                (Some(values), _) => Outcome::from(values.iter().any(|v| v == cell)),
                (None, Ok(_)) if timed => {
                    let s = spread(table, r, metric);
                    label += &shown(s);
                    match s {
                        None => Outcome::Unspread,
                        Some([lo, hi]) if within(lo) && within(hi) => Outcome::Held,
                        Some([lo, hi])
                            if at_most.is_some_and(|m| lo > m)
                                || at_least.is_some_and(|m| hi < m) =>
                        {
                            Outcome::Failed
                        }
                        Some(_) => Outcome::Tie,
                    }
                }
                (None, v) => Outcome::from(v.is_ok_and(within)),
            };
            Case {
                outcome,
                row: r,
                label,
            }
        })
        .collect()
}
