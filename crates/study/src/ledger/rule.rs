//! The rules that turn committed results into a claim's verdict, as a claim file writes them:
//! every rule reads one results table (`runs.csv` of a study, or a CSV the study wrote beside
//! it) and says which cases to count: paired rows (`compare`), runs against another method's
//! work-precision front (`dominates`), a line along a knob (`trend`) or rows against a bound
//! (`bound`). [`super::verdict`] counts them by problem.
//!
//! **Problems.** Cases on one problem are not independent evidence: the accuracy targets of
//! one scene are decided by the same runs (a run within 1e-7 is within 1e-6), the steps,
//! tolerances, cut-off levels and iteration counts of one scene are a ladder of the same
//! motion, and the runs of one `dominates` group are all judged against the same front. So a
//! rule counts *problems*: its cases grouped by the columns `problem_by` names — the
//! scene, its material, a physical setting — and a problem is decided from all its cases
//! ([`super::verdict`]). By default `problem_by` is the columns that key a case (`pair_by`,
//! `group_by`) without the ladder columns ([`is_ladder`]), and `["scene"]` for a `bound`,
//! whose cases are rows; a claim names its own where that is not its problem. An explicit
//! `problem_by` must name some of the columns that key a case (any columns, for a bound).
//!
//! **Times.** A rule that decides on a measured time ([`is_timing`]: `compare`'s metric,
//! `dominates`' cost, `bound`'s metric) compares spreads, not single numbers: two times whose
//! spreads overlap tie, and a time without a spread decides nothing (the verdict counts such
//! cases as timed without a spread) unless the claim says `single_timings = true`. A spread is
//! read from the row ([`super::cases`]); a `trend` of a time is refused unless it opts out.

use super::filter::Filter;

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
    pub(super) fn compare(&self, a: &str, b: &str, missing_is_worst: bool) -> Option<bool> {
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

/// The columns a default `problem_by` leaves out: how finely one problem is solved — its
/// accuracy target, the suite's cut-off level, the step — rather than which problem it is.
/// An integrator setting that ends in `tolerance`, `iterations` or `substeps`
/// (`integrator.newton.tolerance`, `integrator.vbd.iterations`) is a ladder column too.
pub const LADDER_COLUMNS: [&str; 6] = ["target", "level", "cutoff", "tolerance", "dt", "run.dt"];

/// Whether `column` is a rung of a ladder on one problem (see [`LADDER_COLUMNS`]).
pub fn is_ladder(column: &str) -> bool {
    LADDER_COLUMNS.contains(&column)
        || column.strip_prefix("integrator.").is_some_and(|setting| {
            let last = setting.rsplit('.').next().unwrap_or(setting);
            ["tolerance", "iterations", "substeps"]
                .iter()
                .any(|s| last.ends_with(s))
        })
}

/// Whether `column` is a measured time: `wall_*`, `*_seconds` or `*_seconds_*`.
pub fn is_timing(column: &str) -> bool {
    column.starts_with("wall") || column.ends_with("_seconds") || column.contains("_seconds_")
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

/// A rule with its standard, its problems and where it looks for strata.
#[derive(Clone, Debug, PartialEq)]
pub struct RuleSpec {
    pub rule: Rule,
    /// The table it reads, relative to the study's results folder. Default `runs.csv`.
    pub table: String,
    pub standard: Standard,
    /// The columns whose values name a case's problem (see the module documentation): as
    /// written, or the default.
    pub problem_by: Vec<String>,
    /// Whether `problem_by` is the default (not written in the claim file).
    pub problem_by_default: bool,
    pub qualify_by: Vec<String>,
    /// Compare times as single numbers, without their spread (`single_timings = true`).
    pub single_timings: bool,
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

/// The row filter `key` names (every row without one).
fn filter(table: &toml::Table, key: &str) -> Result<Filter, String> {
    match table.get(key) {
        None => Ok(Filter::default()),
        Some(toml::Value::Table(t)) => Filter::from_toml(t).map_err(|e| format!("`{key}`: {e}")),
        Some(other) => Err(format!(
            "`{key}`: a table of conditions, found {}",
            other.type_str()
        )),
    }
}

/// The column `key` names.
fn text(table: &toml::Table, key: &str) -> Result<String, String> {
    table
        .get(key)
        .and_then(toml::Value::as_str)
        .map(str::to_owned)
        .ok_or(format!("`{key}`: a column name is needed"))
}

/// The number `key` gives, if any.
fn number(table: &toml::Table, key: &str) -> Result<Option<f64>, String> {
    match table.get(key) {
        None => Ok(None),
        Some(toml::Value::Float(x)) => Ok(Some(*x)),
        Some(toml::Value::Integer(i)) => Ok(Some(*i as f64)),
        Some(other) => Err(format!("`{key}`: a number, found {}", other.type_str())),
    }
}

/// The rule of `kind` as `table` writes it (its keys already checked).
fn rule_of(kind: &str, table: &toml::Table) -> Result<Rule, String> {
    Ok(match kind {
        "compare" => Rule::Compare {
            a: filter(table, "a")?,
            b: filter(table, "b")?,
            both: filter(table, "both")?,
            pair_by: strings(table.get("pair_by"), "pair_by")?,
            metric: text(table, "metric")?,
            better: Better::parse(table.get("better").ok_or("`better` is needed")?)?,
            missing_is_worst: match table.get("missing").and_then(toml::Value::as_str) {
                None if !table.contains_key("missing") => false,
                Some("tie") => false,
                Some("worst") => true,
                _ => return Err("`missing`: `tie` or `worst`".into()),
            },
        },
        "dominates" => Rule::Dominates {
            a: filter(table, "a")?,
            b: filter(table, "b")?,
            both: filter(table, "both")?,
            group_by: strings(table.get("group_by"), "group_by")?,
            cost: text(table, "cost")?,
            error: text(table, "error")?,
        },
        "trend" => Rule::Trend {
            rows: filter(table, "rows")?,
            group_by: strings(table.get("group_by"), "group_by")?,
            x: text(table, "x")?,
            y: text(table, "y")?,
            expect: match table.get("expect").and_then(toml::Value::as_str) {
                Some("decreasing") => Expect::Decreasing,
                Some("early-faster") => Expect::EarlyFaster,
                _ => return Err("`expect`: `decreasing` or `early-faster`".into()),
            },
            slope_at_most: number(table, "slope_at_most")?,
        },
        _ => {
            let one_of = match table.get("one_of") {
                None => None,
                Some(v) => Some(strings(Some(v), "one_of")?),
            };
            let (at_most, at_least) = (number(table, "at_most")?, number(table, "at_least")?);
            if at_most.is_none() && at_least.is_none() && one_of.is_none() {
                return Err("a bound needs `at_most`, `at_least` or `one_of`".into());
            }
            Rule::Bound {
                rows: filter(table, "rows")?,
                metric: text(table, "metric")?,
                at_most,
                at_least,
                one_of,
            }
        }
    })
}

/// The rule's `problem_by`, as written (checked against the columns that key a case) or its
/// default, and whether it is the default.
fn problems(rule: &Rule, written: Option<&toml::Value>) -> Result<(Vec<String>, bool), String> {
    let keyed: Option<(&str, &[String])> = match rule {
        Rule::Compare { pair_by, .. } => Some(("pair_by", pair_by)),
        Rule::Dominates { group_by, .. } | Rule::Trend { group_by, .. } => {
            Some(("group_by", group_by))
        }
        Rule::Bound { .. } => None,
    };
    let Some(written) = written else {
        let default = match keyed {
            Some((_, key)) => key.iter().filter(|c| !is_ladder(c)).cloned().collect(),
            None => vec!["scene".to_owned()],
        };
        return Ok((default, true));
    };
    let columns = strings(Some(written), "problem_by")?;
    if columns.is_empty() {
        return Err(
            "`problem_by`: name at least one column (an empty list would make every case one \
             problem; leave the key out for the default)"
                .into(),
        );
    }
    for (i, c) in columns.iter().enumerate() {
        if columns[..i].contains(c) {
            return Err(format!("`problem_by`: `{c}` is named twice"));
        }
        if let Some((name, key)) = keyed
            && !key.contains(c)
        {
            return Err(format!(
                "`problem_by`: `{c}` is not one of the columns that key a case (`{name}` = [{}]): \
                 a problem is a set of cases, named by some of those columns",
                key.iter()
                    .map(|k| format!("\"{k}\""))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
    }
    Ok((columns, false))
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
                return Err(softbench_core::names::unknown_name_message(
                    "rule kind",
                    other,
                    &["compare", "dominates", "trend", "bound"],
                ));
            }
        };
        let shared = [
            "kind",
            "table",
            "holds_at",
            "min_cases",
            "qualify_by",
            "problem_by",
            "single_timings",
        ];
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
        let rule = rule_of(kind, table)?;
        let single_timings = match table.get("single_timings") {
            None => false,
            Some(toml::Value::Boolean(b)) => *b,
            Some(other) => {
                return Err(format!(
                    "`single_timings`: true or false, found {}",
                    other.type_str()
                ));
            }
        };
        if let Rule::Trend { y, .. } = &rule
            && is_timing(y)
            && !single_timings
        {
            return Err(format!(
                "`y`: `{y}` is a time, and a trend is not judged against the spread of its \
                 points; set `single_timings = true` to judge it on the single values"
            ));
        }
        let (problem_by, problem_by_default) = problems(&rule, table.get("problem_by"))?;
        let holds_at = number(table, "holds_at")?.unwrap_or(0.75);
        if !(0.5..=1.0).contains(&holds_at) || holds_at == 0.5 {
            return Err(format!(
                "`holds_at`: a share above 0.5 and at most 1 (got {holds_at}): at 0.5 a claim \
                 and its opposite would both hold"
            ));
        }
        let min_cases = number(table, "min_cases")?.unwrap_or(3.0);
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
            problem_by,
            problem_by_default,
            qualify_by: strings(table.get("qualify_by"), "qualify_by")?,
            single_timings,
        })
    }

    /// The measured time the rule decides on, if its spread is required (no
    /// `single_timings`).
    pub fn spread_needed(&self) -> Option<&str> {
        self.timing_column().filter(|_| !self.single_timings)
    }

    /// The measured time the rule decides on (`compare`'s numeric metric, `dominates`' cost,
    /// `bound`'s numeric metric), if it is one.
    pub fn timing_column(&self) -> Option<&str> {
        let column = match &self.rule {
            Rule::Compare {
                metric,
                better: Better::Smaller | Better::Larger,
                ..
            } => metric,
            Rule::Dominates { cost, .. } => cost,
            Rule::Bound {
                metric,
                one_of: None,
                ..
            } => metric,
            _ => return None,
        };
        is_timing(column).then_some(column.as_str())
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
        let problems = if self.problem_by.is_empty() {
            "every case in one problem".to_owned()
        } else {
            format!("a problem per {}", self.problem_by.join(" × "))
        };
        let timing = match (self.timing_column(), self.single_timings) {
            (Some(m), false) => format!(
                " `{m}` is a time: two whose spreads overlap tie, and a time without a spread \
                 decides nothing."
            ),
            (Some(m), true) => format!(
                " `{m}` is a time, compared as a single number without its spread \
                 (`single_timings`)."
            ),
            (None, _) => String::new(),
        };
        format!(
            "{body}. Counted by problem ({problems}{}): a problem holds when every case it \
             decides holds, fails when none does, and is split otherwise.{timing} Validated \
             when it holds on at least {:.0} % of at least {} decided problems, refuted when it \
             fails on at least {:.0} %.",
            if self.problem_by_default {
                ", the default"
            } else {
                ""
            },
            100.0 * self.standard.holds_at,
            self.standard.min_cases,
            100.0 * self.standard.holds_at
        )
    }

    /// Whether the verdict rests on a measured time ([`is_timing`]), so it holds for the
    /// device its rows ran on.
    pub fn reads_time(&self) -> bool {
        self.columns().iter().any(|c| is_timing(c))
    }

    /// The columns the rule reads (checked against the table before it is evaluated).
    pub fn columns(&self) -> Vec<String> {
        let mut out: Vec<String> = self.qualify_by.clone();
        out.extend(self.problem_by.iter().cloned());
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
