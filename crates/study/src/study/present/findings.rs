//! What a study found, computed from `runs.csv` alone: per scene, the ranking of the methods by
//! each metric its kind measures, the best method per metric, and warnings where a number
//! should not be trusted. `report.md` opens with it; nothing in it is prose the data did not
//! produce. This file holds the vocabulary (rankings, the rankings and warnings every kind
//! shares, the section's text); each kind ranks its own metrics (`Kind::rankings`).

use std::fmt::Write as _;

use crate::study::present::charts::SceneRows;
use crate::study::vocabulary::format::short;
use crate::study::vocabulary::table::Table;
use softbench_run::run::OutcomeKind;

/// How far an observed order may exceed the method's formal order before it is flagged: more
/// than this above theory means the error is not in its asymptotic range (or is at the
/// reference's noise).
pub const ORDER_EXCESS: f64 = 0.5;

/// Whether larger or smaller is better.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Better {
    Larger,
    Smaller,
}

/// One metric's ranking in one scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Ranking {
    pub scene: String,
    /// What is ranked, with its unit and how it was measured.
    pub metric: String,
    pub better: Better,
    /// (run label, value), best first.
    pub ranked: Vec<(String, f64)>,
    /// The spread of each ranked value where it was measured (`spreads[i]` is `ranked[i]`'s:
    /// the interquartile range of a timing); two neighbours whose spreads overlap are tied.
    pub spreads: Vec<Option<(f64, f64)>>,
    /// Runs left out and why.
    pub left_out: Vec<(String, String)>,
}

/// Everything the findings section says.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Findings {
    pub rankings: Vec<Ranking>,
    pub warnings: Vec<String>,
}

/// A run's label: method, linear solver (for implicit methods) and the swept parameters.
pub(in crate::study) fn label(runs: &Table, params: &[String], row: &[String]) -> String {
    crate::study::present::charts::label(runs, params, row, &[])
}

/// Whether a row's run completed.
pub(in crate::study) fn completed(runs: &Table, row: &[String]) -> bool {
    runs.get(row, "outcome") == Some(OutcomeKind::Completed.name())
}

/// One scene's ranking by `metric`: every row's `value`, or why it is left out; `None` when
/// no row has a value.
pub(in crate::study) fn ranking(
    s: &SceneRows,
    metric: String,
    better: Better,
    value: &dyn Fn(&[String]) -> Result<f64, String>,
) -> Option<Ranking> {
    ranking_with_spread(s, metric, better, value, &|_| None)
}

/// A row's spread `(low, high)`, when measured.
pub(in crate::study) type Spread<'a> = dyn Fn(&[String]) -> Option<(f64, f64)> + 'a;

/// [`ranking`] with each value's spread (`(low, high)`, e.g. a timing's quartiles), so
/// neighbours whose spreads overlap are reported tied.
pub(in crate::study) fn ranking_with_spread(
    s: &SceneRows,
    metric: String,
    better: Better,
    value: &dyn Fn(&[String]) -> Result<f64, String>,
    spread: &Spread<'_>,
) -> Option<Ranking> {
    let (runs, params) = (s.runs, s.params);
    if s.rows.iter().all(|r| value(r).is_err()) {
        return None;
    }
    let mut ranked = Vec::new();
    let mut left_out = Vec::new();
    for r in s.rows {
        match value(r) {
            Ok(v) if v.is_finite() => ranked.push((label(runs, params, r), v, spread(r))),
            Ok(v) => left_out.push((label(runs, params, r), format!("value {v}"))),
            Err(why) => left_out.push((label(runs, params, r), why)),
        }
    }
    ranked.sort_by(|a, b| match better {
        Better::Larger => b.1.total_cmp(&a.1),
        Better::Smaller => a.1.total_cmp(&b.1),
    });
    Some(Ranking {
        scene: s.scene.to_owned(),
        metric,
        better,
        spreads: ranked.iter().map(|r| r.2).collect(),
        ranked: ranked.into_iter().map(|(l, v, _)| (l, v)).collect(),
        left_out,
    })
}

impl Ranking {
    /// Whether the `i`-th ranked run is tied with the one before it: both spreads measured
    /// and overlapping.
    pub fn tied_with_previous(&self, i: usize) -> bool {
        match (
            i.checked_sub(1)
                .and_then(|p| self.spreads.get(p).copied().flatten()),
            self.spreads.get(i).copied().flatten(),
        ) {
            (Some(a), Some(b)) => a.0 <= b.1 && b.0 <= a.1,
            _ => false,
        }
    }
}

/// The outcome of a row, for why it is left out of a ranking.
pub(in crate::study) fn outcome(runs: &Table, row: &[String]) -> String {
    runs.get(row, "outcome").unwrap_or("?").to_owned()
}

/// Cost per simulated second of the completed runs: the median step's wall time times the
/// steps per simulated second (the first step's setup apart), with the quartiles as its
/// spread; wall time over simulated time where the step times are not in the table.
pub(in crate::study) fn cost_per_simulated_second(s: &SceneRows) -> Option<Ranking> {
    let runs = s.runs;
    let per_second = |r: &[String]| match (runs.number(r, "steps"), runs.number(r, "final_time")) {
        (Some(n), Some(t)) if t > 0.0 => Some(n / t),
        _ => None,
    };
    let median = |r: &[String]| Some(runs.number(r, "step_seconds_median")? * per_second(r)?);
    ranking_with_spread(
        s,
        "cost per simulated second (wall s / simulated s: median step, quartiles as spread; \
         first step apart)"
            .into(),
        Better::Smaller,
        &|r| {
            if !completed(runs, r) {
                return Err(outcome(runs, r));
            }
            if let Some(cost) = median(r) {
                return Ok(cost);
            }
            match (runs.number(r, "wall_seconds"), runs.number(r, "final_time")) {
                (Some(w), Some(t)) if t > 0.0 => Ok(w / t),
                _ => Err("no time measured".into()),
            }
        },
        &|r| {
            let k = per_second(r)?;
            Some((
                runs.number(r, "step_seconds_q1")? * k,
                runs.number(r, "step_seconds_q3")? * k,
            ))
        },
    )
}

/// Cost per simulated second where the table has the wall and simulated times, then energy
/// drift where it has it: what trajectory and work-precision studies rank first.
pub(in crate::study) fn cost_and_drift(s: &SceneRows, damped: Option<&str>) -> Vec<Ranking> {
    let has = |c: &str| s.runs.column(c).is_some();
    let mut out = Vec::new();
    if has("wall_seconds") && has("final_time") {
        out.extend(cost_per_simulated_second(s));
    }
    if has("energy_drift_max") {
        out.extend(energy_drift(s, damped));
    }
    out
}

/// The largest energy drift of the completed runs: the energy gained or lost beyond the work
/// done on the body and the energy damping removed, over the energy it holds or exchanges
/// (`damped`, how the scene is damped, is named so a reader knows the damping's loss is
/// accounted, not counted as drift).
pub(in crate::study) fn energy_drift(s: &SceneRows, damped: Option<&str>) -> Option<Ranking> {
    energy_drift_of(s, damped, "", &|_| Ok(()))
}

/// [`energy_drift`] among the completed runs that `admit` lets in (else why not), with
/// `among` appended to the metric to say which.
pub(in crate::study) fn energy_drift_of(
    s: &SceneRows,
    damped: Option<&str>,
    among: &str,
    admit: &dyn Fn(&[String]) -> Result<(), String>,
) -> Option<Ranking> {
    let runs = s.runs;
    let accounted = if damped.is_some() {
        "work done and the damping's loss"
    } else {
        "work done"
    };
    let note = format!(
        "energy drift, max abs(E(t) - E(0) - {accounted}) / energy held or exchanged{among}"
    );
    ranking(s, note, Better::Smaller, &|r| {
        if !completed(runs, r) {
            return Err(outcome(runs, r));
        }
        admit(r)?;
        runs.number(r, "energy_drift_max")
            .ok_or_else(|| "not measured".into())
    })
}

/// Writes the findings as the report's opening section.
pub fn write(out: &mut String, f: &Findings) {
    let _ = writeln!(out, "## Findings\n");
    if f.rankings.is_empty() && f.warnings.is_empty() {
        let _ = writeln!(out, "No metric could be ranked.\n");
        return;
    }
    if !f.rankings.is_empty() {
        let _ = writeln!(
            out,
            "| scene | metric | best | ranking (best first) |\n|---|---|---|---|"
        );
        for r in &f.rankings {
            let mut best = r
                .ranked
                .first()
                .map_or("-".to_owned(), |(l, v)| format!("{l} ({})", short(*v)));
            // Runs tied with the first share the place.
            let tied: Vec<&str> = (1..r.ranked.len())
                .take_while(|&i| r.tied_with_previous(i))
                .map(|i| r.ranked[i].0.as_str())
                .collect();
            if !tied.is_empty() {
                best = format!("{best}, tied with {} (spreads overlap)", tied.join(", "));
            }
            let mut list: Vec<String> = r
                .ranked
                .iter()
                .enumerate()
                .map(|(i, (l, v))| {
                    let spread = r
                        .spreads
                        .get(i)
                        .copied()
                        .flatten()
                        .map_or(String::new(), |(a, b)| {
                            format!(" [{}, {}]", short(a), short(b))
                        });
                    let tie = if r.tied_with_previous(i) { "≈ " } else { "" };
                    format!("{tie}{l} {}{spread}", short(*v))
                })
                .collect();
            for (l, why) in &r.left_out {
                list.push(format!("*{l}: not ranked, {why}*"));
            }
            let _ = writeln!(
                out,
                "| {} | {} ({} is better) | {} | {} |",
                r.scene,
                r.metric.replace('|', "\\|"),
                match r.better {
                    Better::Larger => "larger",
                    Better::Smaller => "smaller",
                },
                best.replace('|', "\\|"),
                list.join("; ").replace('|', "\\|")
            );
        }
        let _ = writeln!(out);
    }
    if !f.warnings.is_empty() {
        let _ = writeln!(out, "Warnings:\n");
        for w in &f.warnings {
            let _ = writeln!(out, "- {w}");
        }
        let _ = writeln!(out);
    }
}
