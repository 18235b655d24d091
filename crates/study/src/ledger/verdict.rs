//! A claim's verdict from its rule's cases, counted by problem. The cases ([`super::cases`])
//! are grouped into problems by the rule's `problem_by` columns (see [`super::rule`]), and
//! each problem is decided from all its cases; ties and times without a spread decide
//! nothing:
//!
//! - **held**: every case it decides holds;
//! - **failed**: every case it decides fails;
//! - **split**: some hold and some fail — on part of its ladder (some targets, some steps)
//!   the claim holds and on the rest it does not. A split problem counts as decided but
//!   neither for the claim nor against it: it keeps a claim from being validated *and* from
//!   being refuted, which is what it shows (the claim depends on where on the ladder one
//!   looks). Counting it as a failure would refute a claim that holds on most of every
//!   ladder; leaving it out would validate a claim from the problems where it happened to
//!   hold throughout;
//! - **tied** (every case a tie) and **without a spread** (no case decided, some compare
//!   times without a spread): undecided, reported.
//!
//! The decided problems then decide the claim:
//!
//! - **validated**: it holds on at least `holds_at` of the decided problems (default 0.75);
//! - **refuted**: it fails on at least `holds_at` of them;
//! - **qualified**: in between (splits included); the condition is every stratum (a value of
//!   a `qualify_by` column) where it holds on at least `holds_at` of at least `min_cases`
//!   decided problems, else the shares themselves. A stratum is read per case, so a column
//!   that varies within a problem (a cut-off level) makes the stratum of each value the
//!   problems' cases at that value;
//! - **unmeasured**: fewer than `min_cases` decided problems (default 3).
//!
//! Every verdict says how many problems decided it and the cases behind them. No threshold
//! here is a cap on a measurement: `holds_at` is the claim's own standard of evidence, stated
//! with its verdict.

use super::cases::{self, Case, Outcome, key};
use super::rule::{RuleSpec, Standard};
use crate::study::table::Table;
use std::collections::BTreeMap;

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

/// Cases or problems by outcome.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    pub held: usize,
    pub failed: usize,
    pub split: usize,
    pub tied: usize,
    pub unspread: usize,
}

impl Counts {
    /// Those that decide: held, failed or split.
    pub fn decided(&self) -> usize {
        self.held + self.failed + self.split
    }

    /// All of them.
    pub fn total(&self) -> usize {
        self.decided() + self.tied + self.unspread
    }

    fn of(outcomes: impl Iterator<Item = Outcome>) -> Self {
        let mut out = Self::default();
        for o in outcomes {
            *match o {
                Outcome::Held => &mut out.held,
                Outcome::Failed => &mut out.failed,
                Outcome::Split => &mut out.split,
                Outcome::Tie => &mut out.tied,
                Outcome::Unspread => &mut out.unspread,
            } += 1;
        }
        out
    }
}

/// The problems of one stratum: the cases whose `column` is `value`, grouped by problem.
#[derive(Clone, Debug, PartialEq)]
pub struct Stratum {
    pub column: String,
    pub value: String,
    pub problems: Counts,
}

/// A decided problem shown as evidence: its outcome, its name (the `problem_by` values) and a
/// few of its decided cases.
#[derive(Clone, Debug, PartialEq)]
pub struct Example {
    pub outcome: Outcome,
    pub problem: String,
    /// Up to three decided cases (a split problem's show both outcomes), each with whether
    /// it held.
    pub cases: Vec<(String, Outcome)>,
    /// Its decided cases in all.
    pub decided: usize,
}

/// What a rule found.
#[derive(Clone, Debug, PartialEq)]
pub struct Verdict {
    pub class: Class,
    /// The condition of a qualified verdict, or why a claim is unmeasured.
    pub condition: String,
    /// The problems, by outcome: the decided ones decide the verdict.
    pub problems: Counts,
    /// The cases behind them (never split).
    pub cases: Counts,
    /// The problems of each stratum of the `qualify_by` columns.
    pub strata: Vec<Stratum>,
    /// A few decided problems of each outcome, in table order.
    pub examples: Vec<Example>,
}

/// `n` and a noun, singular for one.
pub fn count(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

impl Verdict {
    /// A claim that could not be evaluated, and why.
    pub fn unmeasured(why: String) -> Self {
        Self {
            class: Class::Unmeasured,
            condition: why,
            problems: Counts::default(),
            cases: Counts::default(),
            strata: Vec::new(),
            examples: Vec::new(),
        }
    }

    /// How many problems decided it, in a line: "3 of 5 problems held (1 failed, 1 split; 2
    /// more tied); 14 cases".
    pub fn tally(&self) -> String {
        let p = &self.problems;
        let mut out = format!("{} of {} held", p.held, count(p.decided(), "problem"));
        let decided: Vec<String> = [(p.failed, "failed"), (p.split, "split")]
            .iter()
            .filter(|(n, _)| *n > 0)
            .map(|(n, what)| format!("{n} {what}"))
            .collect();
        let undecided: Vec<String> = [(p.tied, "tied"), (p.unspread, "timed without a spread")]
            .iter()
            .filter(|(n, _)| *n > 0)
            .map(|(n, what)| format!("{n} more {what}"))
            .collect();
        let parts: Vec<String> = [decided.join(", "), undecided.join(", ")]
            .into_iter()
            .filter(|s| !s.is_empty())
            .collect();
        if !parts.is_empty() {
            out += &format!(" ({})", parts.join("; "));
        }
        out + &format!("; {}", count(self.cases.total(), "case"))
    }
}

/// One problem: its name and its cases, in table order.
struct Problem<'c, 't> {
    name: Vec<String>,
    cases: Vec<&'c Case<'t>>,
}

impl Problem<'_, '_> {
    fn outcome(&self) -> Outcome {
        let has = |o: Outcome| self.cases.iter().any(|c| c.outcome == o);
        match (has(Outcome::Held), has(Outcome::Failed)) {
            (true, false) => Outcome::Held,
            (false, true) => Outcome::Failed,
            (true, true) => Outcome::Split,
            _ if has(Outcome::Unspread) => Outcome::Unspread,
            _ => Outcome::Tie,
        }
    }
}

/// `cases` grouped by the values of `problem_by`, in order of first appearance.
fn problems<'c, 't>(
    table: &Table,
    cases: impl Iterator<Item = &'c Case<'t>>,
    problem_by: &[String],
) -> Vec<Problem<'c, 't>> {
    let mut out: Vec<Problem> = Vec::new();
    let mut index: BTreeMap<Vec<String>, usize> = BTreeMap::new();
    for c in cases {
        let name = key(table, c.row, problem_by);
        let i = *index.entry(name.clone()).or_insert_with(|| {
            out.push(Problem {
                name,
                cases: Vec::new(),
            });
            out.len() - 1
        });
        out[i].cases.push(c);
    }
    out
}

/// Evaluate `spec` on `table`.
pub fn evaluate(spec: &RuleSpec, table: &Table) -> Verdict {
    let cases = cases::of(spec, table);
    judge(spec, table, &cases)
}

/// The problems of each value of each `qualify_by` column.
fn strata(spec: &RuleSpec, table: &Table, cases: &[Case]) -> Vec<Stratum> {
    let mut out = Vec::new();
    for column in &spec.qualify_by {
        let mut by: BTreeMap<String, Vec<&Case>> = BTreeMap::new();
        for c in cases {
            let v = table.get(c.row, column).unwrap_or_default().to_owned();
            by.entry(v).or_default().push(c);
        }
        out.extend(by.into_iter().map(|(value, cs)| {
            let ps = problems(table, cs.into_iter(), &spec.problem_by);
            Stratum {
                column: column.clone(),
                value,
                problems: Counts::of(ps.iter().map(Problem::outcome)),
            }
        }));
    }
    out
}

/// The verdict of the `cases`, counted by problem.
fn judge(spec: &RuleSpec, table: &Table, cases: &[Case]) -> Verdict {
    let Standard {
        holds_at,
        min_cases,
    } = spec.standard;
    let all = problems(table, cases.iter(), &spec.problem_by);
    let p = Counts::of(all.iter().map(Problem::outcome));
    let c = Counts::of(cases.iter().map(|c| c.outcome));
    let strata = strata(spec, table, cases);
    let n = p.decided();
    let share = |k: usize| k as f64 >= holds_at * n as f64;
    let (class, condition) = if n < min_cases {
        (Class::Unmeasured, too_few(spec, &p, &c))
    } else if share(p.held) {
        (Class::Validated, String::new())
    } else if share(p.failed) {
        (Class::Refuted, String::new())
    } else {
        let holding: Vec<String> = strata
            .iter()
            .filter(|s| {
                let d = s.problems.decided();
                d >= min_cases && s.problems.held as f64 >= holds_at * d as f64
            })
            .map(|s| {
                format!(
                    "{} = {} ({} of {})",
                    s.column,
                    s.value,
                    s.problems.held,
                    count(s.problems.decided(), "problem")
                )
            })
            .collect();
        let condition = if holding.is_empty() {
            format!(
                "holds on {} of {} ({:.0} %{}), in no stratum of {} on {:.0} % or more",
                p.held,
                count(n, "problem"),
                100.0 * p.held as f64 / n as f64,
                if p.split > 0 {
                    format!("; {} split", p.split)
                } else {
                    String::new()
                },
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
    Verdict {
        class,
        condition,
        problems: p,
        cases: c,
        strata,
        examples: examples(&all),
    }
}

/// Why too few problems decided: the count, the undecided ones, and for times without a
/// spread what would give them one.
fn too_few(spec: &RuleSpec, p: &Counts, c: &Counts) -> String {
    let mut undecided = Vec::new();
    if p.tied > 0 {
        undecided.push(format!("{} more tied", p.tied));
    }
    if p.unspread > 0 {
        undecided.push(format!("{} more timed without a spread", p.unspread));
    }
    undecided.push(count(c.total(), "case"));
    let mut out = format!(
        "{} decided ({}): fewer than the {} the rule needs",
        count(p.decided(), "problem"),
        undecided.join(", "),
        spec.standard.min_cases
    );
    if c.unspread > 0
        && let Some(m) = spec.spread_needed()
    {
        out += &format!(
            "; timings without a spread decide nothing: {} compare `{m}` with no \
             `{m}_low`/`{m}_high`, repeats or step-time quartiles in their rows \
             (`single_timings = true` would compare single timings)",
            count(c.unspread, "case")
        );
    }
    out
}

/// Up to four decided problems of each outcome, in table order, each with a few cases.
fn examples(all: &[Problem]) -> Vec<Example> {
    let mut out = Vec::new();
    for want in [Outcome::Held, Outcome::Failed, Outcome::Split] {
        for problem in all.iter().filter(|p| p.outcome() == want).take(4) {
            let decided: Vec<&Case> = problem
                .cases
                .iter()
                .copied()
                .filter(|c| matches!(c.outcome, Outcome::Held | Outcome::Failed))
                .collect();
            // A split problem shows its first case of each outcome first.
            let mut shown: Vec<&Case> = Vec::new();
            for o in [Outcome::Held, Outcome::Failed] {
                if want == Outcome::Split
                    && let Some(c) = decided.iter().find(|c| c.outcome == o)
                {
                    shown.push(c);
                }
            }
            for c in &decided {
                if shown.len() >= 3 {
                    break;
                }
                if !shown.iter().any(|s| std::ptr::eq(*s, *c)) {
                    shown.push(c);
                }
            }
            out.push(Example {
                outcome: want,
                problem: if problem.name.is_empty() {
                    "every case".to_owned()
                } else {
                    problem.name.join(", ")
                },
                cases: shown.iter().map(|c| (c.label.clone(), c.outcome)).collect(),
                decided: decided.len(),
            });
        }
    }
    out
}
