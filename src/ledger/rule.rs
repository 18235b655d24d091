//! The rules that turn committed results into a claim's verdict. Every rule reads one results
//! table (`runs.csv` of a study, or a CSV the study wrote beside it) and counts how often the
//! claimed relation holds: between paired rows (`compare`), between work-precision fronts
//! (`dominates`), along a knob (`trend`) or against a bound (`bound`). The share of cases
//! where it holds decides the verdict:
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
use crate::study::table::Table;
use std::collections::BTreeMap;

/// Which way a metric is better.
#[derive(Clone, Debug, PartialEq)]
pub enum Better {
    Smaller,
    Larger,
    /// Categories, best first (`a|b` ranks alternatives together); a value not listed is
    /// worse than every listed one.
    Ranked(Vec<String>),
}

impl Better {
    fn parse(value: &toml::Value) -> Result<Self, String> {
        match value {
            toml::Value::String(s) if s == "smaller" => Ok(Self::Smaller),
            toml::Value::String(s) if s == "larger" => Ok(Self::Larger),
            toml::Value::Array(a) => a
                .iter()
                .map(|v| {
                    v.as_str()
                        .map(str::to_owned)
                        .ok_or("`better`: a list of category names".to_owned())
                })
                .collect::<Result<Vec<_>, _>>()
                .map(Self::Ranked),
            other => Err(format!(
                "`better`: `smaller`, `larger` or a list of categories best first, found {other}"
            )),
        }
    }

    /// `Some(true)` when `a` is better than `b`, `Some(false)` when worse, `None` for a tie.
    /// A cell that is not a number where one is needed is a tie, or with `missing_is_worst`
    /// (a cost of a problem not solved) worse than any number.
    fn compare(&self, a: &str, b: &str, missing_is_worst: bool) -> Option<bool> {
        match self {
            Self::Smaller | Self::Larger => {
                let (x, y) = match (a.parse::<f64>().ok(), b.parse::<f64>().ok()) {
                    (Some(x), Some(y)) => (x, y),
                    (Some(_), None) if missing_is_worst => return Some(true),
                    (None, Some(_)) if missing_is_worst => return Some(false),
                    _ => return None,
                };
                if x == y {
                    return None;
                }
                Some((x < y) == matches!(self, Self::Smaller))
            }
            Self::Ranked(order) => {
                // An entry `a|b` ranks its alternatives together.
                let rank = |v: &str| {
                    order
                        .iter()
                        .position(|o| o.split('|').any(|x| x == v))
                        .unwrap_or(order.len())
                };
                let (x, y) = (rank(a), rank(b));
                (x != y).then_some(x < y)
            }
        }
    }

    fn describe(&self) -> String {
        match self {
            Self::Smaller => "smaller is better".into(),
            Self::Larger => "larger is better".into(),
            Self::Ranked(o) => format!("{} ranked best first, anything else last", o.join(" > ")),
        }
    }
}

/// What a trend expects of `y` along `x`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Expect {
    /// `y` never grows from one `x` to the next (and, with `slope_at_most`, its log-log slope
    /// from the first to the last point is at most that).
    Decreasing,
    /// `y` falls faster (in log-log slope) over the first half of the points than over the
    /// last half: fast early, slow late.
    EarlyFaster,
}

/// A claim's rule.
#[derive(Clone, Debug, PartialEq)]
pub enum Rule {
    /// Rows of `a` against rows of `b` paired by `pair_by` (both meeting `both`): `a`'s
    /// `metric` is better.
    Compare {
        a: Filter,
        b: Filter,
        both: Filter,
        pair_by: Vec<String>,
        metric: String,
        better: Better,
        /// An empty or non-numeric cell is worse than any number (a problem not solved has no
        /// cost), instead of a tie. Default false.
        missing_is_worst: bool,
    },
    /// `a`'s runs dominate `b`'s in (cost, error), within each group: a `b` run is beaten when
    /// some `a` run of its group costs no more and errs no more (one of them strictly).
    Dominates {
        a: Filter,
        b: Filter,
        both: Filter,
        group_by: Vec<String>,
        cost: String,
        error: String,
    },
    /// Along `x`, `y` behaves as `expect`, in each group of `rows`.
    Trend {
        rows: Filter,
        group_by: Vec<String>,
        x: String,
        y: String,
        expect: Expect,
        slope_at_most: Option<f64>,
    },
    /// Every row of `rows` has `metric` within the bound.
    Bound {
        rows: Filter,
        metric: String,
        at_most: Option<f64>,
        at_least: Option<f64>,
        one_of: Option<Vec<String>>,
    },
}

/// The standard of evidence every rule shares.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Standard {
    pub holds_at: f64,
    pub min_cases: usize,
}

/// A rule with its standard and where it looks for strata.
#[derive(Clone, Debug, PartialEq)]
pub struct RuleSpec {
    pub rule: Rule,
    /// The table it reads, relative to the study's results folder. Default `runs.csv`.
    pub table: String,
    pub standard: Standard,
    pub qualify_by: Vec<String>,
}

fn strings(v: Option<&toml::Value>, key: &str) -> Result<Vec<String>, String> {
    match v {
        None => Ok(Vec::new()),
        Some(toml::Value::Array(a)) => a
            .iter()
            .map(|x| {
                x.as_str()
                    .map(str::to_owned)
                    .ok_or(format!("`{key}`: a list of column names"))
            })
            .collect(),
        Some(other) => Err(format!(
            "`{key}`: a list of column names, found {}",
            other.type_str()
        )),
    }
}

impl RuleSpec {
    /// Parse `[rule]`; errors name the key.
    pub fn parse(table: &toml::Table) -> Result<Self, String> {
        let kind = table
            .get("kind")
            .and_then(toml::Value::as_str)
            .ok_or("`kind`: one of compare, dominates, trend, bound")?;
        let known: &[&str] = match kind {
            "compare" => &["a", "b", "both", "pair_by", "metric", "better", "missing"],
            "dominates" => &["a", "b", "both", "group_by", "cost", "error"],
            "trend" => &["rows", "group_by", "x", "y", "expect", "slope_at_most"],
            "bound" => &["rows", "metric", "at_most", "at_least", "one_of"],
            other => {
                return Err(crate::names::unknown_name_message(
                    "rule kind",
                    other,
                    &["compare", "dominates", "trend", "bound"],
                ));
            }
        };
        let shared = ["kind", "table", "holds_at", "min_cases", "qualify_by"];
        if let Some(k) = table
            .keys()
            .find(|k| !known.contains(&k.as_str()) && !shared.contains(&k.as_str()))
        {
            return Err(format!(
                "`{k}` is not a key of a `{kind}` rule (expected: {})",
                known
                    .iter()
                    .chain(&shared)
                    .copied()
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        let filter = |key: &str| -> Result<Filter, String> {
            match table.get(key) {
                None => Ok(Filter::default()),
                Some(toml::Value::Table(t)) => {
                    Filter::from_toml(t).map_err(|e| format!("`{key}`: {e}"))
                }
                Some(other) => Err(format!(
                    "`{key}`: a table of conditions, found {}",
                    other.type_str()
                )),
            }
        };
        let text = |key: &str| -> Result<String, String> {
            table
                .get(key)
                .and_then(toml::Value::as_str)
                .map(str::to_owned)
                .ok_or(format!("`{key}`: a column name is needed"))
        };
        let number = |key: &str| -> Result<Option<f64>, String> {
            match table.get(key) {
                None => Ok(None),
                Some(toml::Value::Float(x)) => Ok(Some(*x)),
                Some(toml::Value::Integer(i)) => Ok(Some(*i as f64)),
                Some(other) => Err(format!("`{key}`: a number, found {}", other.type_str())),
            }
        };
        let rule = match kind {
            "compare" => Rule::Compare {
                a: filter("a")?,
                b: filter("b")?,
                both: filter("both")?,
                pair_by: strings(table.get("pair_by"), "pair_by")?,
                metric: text("metric")?,
                better: Better::parse(table.get("better").ok_or("`better` is needed")?)?,
                missing_is_worst: match table.get("missing").and_then(toml::Value::as_str) {
                    None if !table.contains_key("missing") => false,
                    Some("tie") => false,
                    Some("worst") => true,
                    _ => return Err("`missing`: `tie` or `worst`".into()),
                },
            },
            "dominates" => Rule::Dominates {
                a: filter("a")?,
                b: filter("b")?,
                both: filter("both")?,
                group_by: strings(table.get("group_by"), "group_by")?,
                cost: text("cost")?,
                error: text("error")?,
            },
            "trend" => Rule::Trend {
                rows: filter("rows")?,
                group_by: strings(table.get("group_by"), "group_by")?,
                x: text("x")?,
                y: text("y")?,
                expect: match table.get("expect").and_then(toml::Value::as_str) {
                    Some("decreasing") => Expect::Decreasing,
                    Some("early-faster") => Expect::EarlyFaster,
                    _ => return Err("`expect`: `decreasing` or `early-faster`".into()),
                },
                slope_at_most: number("slope_at_most")?,
            },
            _ => {
                let one_of = match table.get("one_of") {
                    None => None,
                    Some(v) => Some(strings(Some(v), "one_of")?),
                };
                let (at_most, at_least) = (number("at_most")?, number("at_least")?);
                if at_most.is_none() && at_least.is_none() && one_of.is_none() {
                    return Err("a bound needs `at_most`, `at_least` or `one_of`".into());
                }
                Rule::Bound {
                    rows: filter("rows")?,
                    metric: text("metric")?,
                    at_most,
                    at_least,
                    one_of,
                }
            }
        };
        let holds_at = number("holds_at")?.unwrap_or(0.75);
        if !(0.5..=1.0).contains(&holds_at) || holds_at == 0.5 {
            return Err(format!(
                "`holds_at`: a share above 0.5 and at most 1 (got {holds_at}): at 0.5 a claim \
                 and its opposite would both hold"
            ));
        }
        let min_cases = number("min_cases")?.unwrap_or(3.0);
        if !(min_cases >= 1.0 && min_cases.fract() == 0.0) {
            return Err(format!(
                "`min_cases`: a whole number >= 1 (got {min_cases})"
            ));
        }
        Ok(Self {
            rule,
            table: table
                .get("table")
                .and_then(toml::Value::as_str)
                .unwrap_or("runs.csv")
                .to_owned(),
            standard: Standard {
                holds_at,
                min_cases: min_cases as usize,
            },
            qualify_by: strings(table.get("qualify_by"), "qualify_by")?,
        })
    }

    /// The rule in words, for the ledger.
    pub fn describe(&self) -> String {
        let body = match &self.rule {
            Rule::Compare {
                a,
                b,
                both,
                pair_by,
                metric,
                better,
                missing_is_worst,
            } => format!(
                "rows with {} against rows with {}, paired by equal {}{}: `{metric}` of the \
                 first is better ({}{})",
                a.describe(),
                b.describe(),
                pair_by.join(", "),
                if both.0.is_empty() {
                    String::new()
                } else {
                    format!(", both with {}", both.describe())
                },
                better.describe(),
                if *missing_is_worst {
                    "; an empty cell is worse than any number"
                } else {
                    "; an empty cell ties"
                }
            ),
            Rule::Dominates {
                a,
                b,
                both,
                group_by,
                cost,
                error,
            } => format!(
                "within each {}: a run with {} is beaten when a run with {} has `{cost}` and \
                 `{error}` no larger (one smaller){}; the claim holds for a run of the second \
                 that is beaten",
                group_by.join(" and "),
                b.describe(),
                a.describe(),
                if both.0.is_empty() {
                    String::new()
                } else {
                    format!("; both with {}", both.describe())
                },
            ),
            Rule::Trend {
                rows,
                group_by,
                x,
                y,
                expect,
                slope_at_most,
            } => format!(
                "rows with {}, in each {}: `{y}` against `{x}` {}{}",
                rows.describe(),
                group_by.join(" and "),
                match expect {
                    Expect::Decreasing => "never grows as x grows",
                    Expect::EarlyFaster =>
                        "falls faster (log-log slope) over the first half of the x values than over the last half",
                },
                slope_at_most.map_or(String::new(), |s| format!(
                    ", with a log-log slope from the first to the last point of at most {s}"
                ))
            ),
            Rule::Bound {
                rows,
                metric,
                at_most,
                at_least,
                one_of,
            } => format!(
                "rows with {}: `{metric}` {}",
                rows.describe(),
                match (at_least, at_most, one_of) {
                    (_, _, Some(v)) => format!("is one of {}", v.join(", ")),
                    (Some(lo), Some(hi), _) => format!("is within [{lo}, {hi}]"),
                    (Some(lo), None, _) => format!("is at least {lo}"),
                    (None, Some(hi), _) => format!("is at most {hi}"),
                    _ => String::new(),
                }
            ),
        };
        format!(
            "{body}. Validated when it holds in at least {:.0} % of at least {} decided cases, \
             refuted when in at most {:.0} %.",
            100.0 * self.standard.holds_at,
            self.standard.min_cases,
            100.0 * (1.0 - self.standard.holds_at)
        )
    }

    /// The columns the rule reads (checked against the table before it is evaluated).
    pub fn columns(&self) -> Vec<String> {
        let mut out: Vec<String> = self.qualify_by.clone();
        let mut add = |f: &Filter| out.extend(f.columns().map(str::to_owned));
        match &self.rule {
            Rule::Compare { a, b, both, .. } | Rule::Dominates { a, b, both, .. } => {
                add(a);
                add(b);
                add(both);
            }
            Rule::Trend { rows, .. } | Rule::Bound { rows, .. } => add(rows),
        }
        match &self.rule {
            Rule::Compare {
                pair_by, metric, ..
            } => {
                out.extend(pair_by.iter().cloned());
                out.push(metric.clone());
            }
            Rule::Dominates {
                group_by,
                cost,
                error,
                ..
            } => {
                out.extend(group_by.iter().cloned());
                out.push(cost.clone());
                out.push(error.clone());
            }
            Rule::Trend { group_by, x, y, .. } => {
                out.extend(group_by.iter().cloned());
                out.push(x.clone());
                out.push(y.clone());
            }
            Rule::Bound { metric, .. } => out.push(metric.clone()),
        }
        out.sort();
        out.dedup();
        out
    }
}

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
    let mut ties = 0;
    let cases: Vec<Case> = match &spec.rule {
        Rule::Compare {
            a,
            b,
            both,
            pair_by,
            metric,
            better,
            missing_is_worst,
        } => {
            let side = |f: &Filter| -> BTreeMap<Vec<String>, &Vec<String>> {
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
                match better.compare(x, y, *missing_is_worst) {
                    Some(holds) => out.push(Case {
                        holds,
                        row: ra,
                        label: format!("{}: {x} against {y}", k.join(", ")),
                    }),
                    None => ties += 1,
                }
            }
            out
        }
        Rule::Dominates {
            a,
            b,
            both,
            group_by,
            cost,
            error,
        } => {
            let point = |r: &Vec<String>| Some((table.number(r, cost)?, table.number(r, error)?));
            let mut out = Vec::new();
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
                        a.keeps(table, r)
                            && both.keeps(table, r)
                            && key(table, r, group_by) == group
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
            out
        }
        Rule::Trend {
            rows,
            group_by,
            x,
            y,
            expect,
            slope_at_most,
        } => {
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
                let slope = |p: &Point, q: &Point| (q.2.ln() - p.2.ln()) / (q.1.ln() - p.1.ln());
                let n = points.len();
                let overall = slope(&points[0], &points[n - 1]);
                let (holds, detail) = match expect {
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
                            format!(
                                "slope {early:.2} over the first half, {late:.2} over the last"
                            ),
                        )
                    }
                };
                out.push(Case {
                    holds,
                    row: points[0].0,
                    label: format!("{}: {detail}", k.join(", ")),
                });
            }
            out
        }
        Rule::Bound {
            rows,
            metric,
            at_most,
            at_least,
            one_of,
        } => table
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
            .collect(),
    };
    judge(spec, table, &cases, ties)
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
