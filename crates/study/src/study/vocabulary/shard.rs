//! Deterministic shards of a study's grid: `softbench run --shard K/N` runs the K-th of N
//! disjoint parts. The parts are balanced by an estimate of each run's cost, and the
//! assignment depends only on the study and N — never on which shard asks, on timings or on
//! what is already done — so N processes on N machines split the grid without talking to
//! each other.

use crate::study::vocabulary::spec::{RunSpec, Study};

/// One of N parts of a study's grid (`index` counts from 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

/// A `--shard` value that is not `K/N` with `0 <= K < N`.
#[derive(Debug, thiserror::Error)]
#[error(
    "--shard {text}: {why}; expected K/N with 0 <= K < N (e.g. 0/3, or \
     $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT)"
)]
pub struct ShardParseError {
    text: String,
    why: String,
}

impl std::str::FromStr for Shard {
    type Err = ShardParseError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let bad = |why: &str| ShardParseError {
            text: softbench_core::quote::clip_message(text),
            why: why.to_owned(),
        };
        let (k, n) = text.split_once('/').ok_or_else(|| bad("no `/`"))?;
        let number = |s: &str, what: &str| {
            s.trim()
                .parse::<usize>()
                .map_err(|_| bad(&format!("{what} `{}` is not a whole number", s.trim())))
        };
        let (index, count) = (number(k, "K")?, number(n, "N")?);
        if count == 0 {
            return Err(bad("N must be at least 1"));
        }
        if index >= count {
            return Err(bad(&format!("K = {index} is not below N = {count}")));
        }
        Ok(Shard { index, count })
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl Shard {
    /// The shard's folder under `<study>/shards/`: `K-of-N`.
    pub fn folder_name(&self) -> String {
        format!("{}-of-{}", self.index, self.count)
    }

    /// Parses a folder name written by [`Shard::folder_name`].
    pub fn from_folder_name(name: &str) -> Option<Self> {
        let (k, n) = name.split_once("-of-")?;
        let shard = Shard {
            index: k.parse().ok()?,
            count: n.parse().ok()?,
        };
        (shard.index < shard.count).then_some(shard)
    }
}

/// The estimated cost of one run, in arbitrary units (only ratios between runs matter):
/// steps × free DOFs × a per-step weight — the method's order for an explicit method (a
/// proxy for its force evaluations per step), 10 for an implicit one (a few Newton
/// iterations, each a Hessian assembly and a factorization).
pub fn estimated_cost(study: &Study, spec: &RunSpec) -> f64 {
    let _ = study;
    spec.estimated_steps.max(1.0) * step_weight(spec)
}

/// The estimated cost of one step of a run: free DOFs × the method's weight (see
/// [`estimated_cost`]).
pub fn step_weight(spec: &RunSpec) -> f64 {
    let weight = if spec.method.is_explicit() {
        f64::from(spec.method.order().max(1))
    } else {
        10.0
    };
    spec.dofs.max(1) as f64 * weight
}

/// The shard of every run of `study` (in grid order) when split `count` ways: longest
/// processing time first — runs in decreasing estimated cost (ties in grid order) each go
/// to the shard with the least estimated cost so far (ties to the lowest index).
pub fn assign(study: &Study, count: usize) -> Vec<usize> {
    let costs: Vec<f64> = study
        .runs
        .iter()
        .map(|r| estimated_cost(study, r))
        .collect();
    let mut order: Vec<usize> = (0..costs.len()).collect();
    order.sort_by(|&a, &b| costs[b].total_cmp(&costs[a]).then(a.cmp(&b)));
    let mut load = vec![0.0f64; count.max(1)];
    let mut shard_of = vec![0; costs.len()];
    for i in order {
        let lightest = (0..load.len())
            .min_by(|&a, &b| load[a].total_cmp(&load[b]).then(a.cmp(&b)))
            .expect("at least one shard");
        shard_of[i] = lightest;
        load[lightest] += costs[i];
    }
    shard_of
}

/// The estimated cost of the whole study.
pub fn total_cost(study: &Study) -> f64 {
    study.runs.iter().map(|r| estimated_cost(study, r)).sum()
}

/// The runs of `shard`, in grid order, and their total estimated cost.
pub fn runs_of(study: &Study, shard: Shard) -> (Vec<&RunSpec>, f64) {
    let assignment = assign(study, shard.count);
    let runs: Vec<&RunSpec> = study
        .runs
        .iter()
        .zip(&assignment)
        .filter(|(_, s)| **s == shard.index)
        .map(|(r, _)| r)
        .collect();
    let cost = runs.iter().map(|r| estimated_cost(study, r)).sum();
    (runs, cost)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shard_values_parse_and_bad_ones_say_what_is_valid() {
        let s: Shard = "2/3".parse().unwrap();
        assert_eq!(s, Shard { index: 2, count: 3 });
        assert_eq!(s.to_string(), "2/3");
        assert_eq!(Shard::from_folder_name(&s.folder_name()), Some(s));
        for (bad, says) in [
            ("3/3", "not below"),
            ("1/0", "at least 1"),
            ("a/3", "`a` is not a whole number"),
            ("2", "no `/`"),
            ("-1/3", "not a whole number"),
        ] {
            let e = bad.parse::<Shard>().unwrap_err().to_string();
            assert!(e.contains(says) && e.contains("0 <= K < N"), "{bad}: {e}");
        }
        assert_eq!(Shard::from_folder_name("3-of-3"), None);
        assert_eq!(Shard::from_folder_name("x"), None);
    }
}
