//! The spread of a run's measured time, as a results table records it: one number from one run
//! is not a measurement a speed comparison can rest on, so every table that reports a wall
//! time reports, where it can, the range it is known within. Two sources give it:
//!
//! - **repeats** (`repeats >= 2`, a study's `repeats` setting): the run was timed that many
//!   times; `wall_seconds` is the median and `[wall_seconds_min, wall_seconds_max]` the range.
//! - **the step times**: every step of a run is a repeated timing of the same operation. A run
//!   of `n` steps records its first step apart (`first_step_seconds`, with the one-time set-up)
//!   and, over the `n − 1` others, the median `m` and quartiles `q1`, `q3`
//!   (`step_seconds_median`, `step_seconds_q1`, `step_seconds_q3`). Its total `w`
//!   (`wall_seconds`, the sum of its step times) is then known to within
//!   `[w − (n − 1)(m − q1), w + (n − 1)(q3 − m)]`: the total had every step but the first been
//!   as fast as the lower quartile, or as slow as the upper one, instead of the median.
//!   It needs at least two steps besides the first (one step has no quartiles).
//!
//! The spread is the hull of the two where both exist. The step-time range is a single run's
//! own resolution, not a run-to-run variation: it is wide (every step shifted to a quartile at
//! once), so two totals whose ranges overlap are not told apart by the run; only repeats
//! measure what a second run on a loaded machine would give.

use crate::study::vocabulary::table::Table;

/// The spread `[low, high]` of `row`'s `wall_seconds` (see the module documentation), or
/// `None` when the row has no wall time or records neither repeats nor step-time quartiles.
pub fn wall_seconds(table: &Table, row: &[String]) -> Option<[f64; 2]> {
    let w = table.number(row, "wall_seconds")?;
    let mut out: Option<[f64; 2]> = None;
    let mut widen = |lo: f64, hi: f64| {
        out = Some(match out {
            None => [lo, hi],
            Some([a, b]) => [a.min(lo), b.max(hi)],
        });
    };
    if table.number(row, "repeats").is_some_and(|n| n >= 2.0)
        && let (Some(lo), Some(hi)) = (
            table.number(row, "wall_seconds_min"),
            table.number(row, "wall_seconds_max"),
        )
    {
        widen(lo.min(w), hi.max(w));
    }
    if let (Some(n), Some(m), Some(q1), Some(q3)) = (
        table.number(row, "steps"),
        table.number(row, "step_seconds_median"),
        table.number(row, "step_seconds_q1"),
        table.number(row, "step_seconds_q3"),
    ) && n >= 3.0
        && q1 <= m
        && m <= q3
    {
        let k = n - 1.0;
        widen((w - k * (m - q1)).max(0.0), w + k * (q3 - m));
    }
    out
}

/// A spread as two cells, `low` and `high` (both empty without one).
pub fn cells(spread: Option<[f64; 2]>) -> [String; 2] {
    spread.map_or([String::new(), String::new()], |[lo, hi]| {
        [format!("{lo}"), format!("{hi}")]
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(header: &[&str], row: &[&str]) -> Table {
        let mut t = Table::new(header.iter().map(|s| s.to_string()).collect());
        t.rows.push(row.iter().map(|s| s.to_string()).collect());
        t
    }

    #[test]
    fn the_step_quartiles_give_the_total_its_spread() {
        // 11 steps: the first 0.5 s, the other ten with median 1, quartiles 0.9 and 1.2;
        // total 10.5 s.
        let header = [
            "wall_seconds",
            "steps",
            "step_seconds_median",
            "step_seconds_q1",
            "step_seconds_q3",
        ];
        let t = table(&header, &["10.5", "11", "1", "0.9", "1.2"]);
        let [lo, hi] = wall_seconds(&t, &t.rows[0]).unwrap();
        assert!(
            (lo - 9.5).abs() < 1e-12 && (hi - 12.5).abs() < 1e-12,
            "{lo} {hi}"
        );
        // Two steps: one steady step has no quartiles; no spread.
        let t = table(&header, &["2", "2", "1", "1", "1"]);
        assert_eq!(wall_seconds(&t, &t.rows[0]), None);
    }

    #[test]
    fn repeats_give_a_range_and_a_single_timing_none() {
        let header = [
            "wall_seconds",
            "wall_seconds_min",
            "wall_seconds_max",
            "repeats",
        ];
        let t = table(&header, &["2", "1.5", "3", "5"]);
        assert_eq!(wall_seconds(&t, &t.rows[0]), Some([1.5, 3.0]));
        // One timing: its min and max are the value itself, which is no spread.
        let t = table(&header, &["2", "2", "2", "1"]);
        assert_eq!(wall_seconds(&t, &t.rows[0]), None);
        // Both: the hull.
        let header = [
            "wall_seconds",
            "wall_seconds_min",
            "wall_seconds_max",
            "repeats",
            "steps",
            "step_seconds_median",
            "step_seconds_q1",
            "step_seconds_q3",
        ];
        let t = table(
            &header,
            &["10", "9.9", "10.1", "3", "11", "1", "0.95", "1.1"],
        );
        let [lo, hi] = wall_seconds(&t, &t.rows[0]).unwrap();
        assert!(
            (lo - 9.5).abs() < 1e-12 && (hi - 11.0).abs() < 1e-12,
            "{lo} {hi}"
        );
    }
}
