//! The claims ledger: claims from the literature about the methods softbench has, each with
//! the study that tests it and a rule that computes its verdict — validated, qualified (with
//! the condition), refuted or unmeasured — from committed results, never typed by hand.
//!
//! A claim is one TOML file in a folder (`claims/`): the paper, the claim in one sentence,
//! its dimension (speed, robustness, accuracy, convergence), the study whose results test it
//! (`results/<study>/`), optionally the two methods it ranks (`beats = ["a", "b"]`, an edge of
//! the claims graph), and a `[rule]` (see [`rule`]; [`cases`] reads its cases from the table,
//! [`verdict`] counts them by problem: a claim's evidence is its independent problems, not
//! the rungs of one ladder). A claim about one method names it (`subject = "vbd"`) and the
//! field's own implementations of it (`[[originals]]`, peer methods): it is then judged on
//! each, and every verdict says which implementation, and for a time on which device, it is
//! about ([`implementation`]).
//! `softbench ledger` evaluates every claim and renders the ledger as one page ([`page`]).

pub mod cases;
pub mod filter;
pub mod implementation;
pub mod page;
pub mod rule;
pub mod verdict;

use crate::study::table::Table;
use implementation::{DEVICE_COLUMN, Device, Implementation, Original};
use rule::RuleSpec;
use std::path::{Path, PathBuf};
use verdict::Verdict;

/// The dimensions a claim can be about.
pub const DIMENSIONS: [&str; 4] = ["speed", "robustness", "accuracy", "convergence"];

/// Why the ledger cannot be built.
#[derive(Debug, thiserror::Error)]
pub enum LedgerError {
    #[error("{path}: cannot read: {error}")]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    #[error("{path}: no claim files (*.toml) in it")]
    Empty { path: PathBuf },
}

impl softbench_core::error_class::Classify for LedgerError {
    /// A claim file that cannot be read or judged.
    fn class(&self) -> softbench_core::error_class::ErrorClass {
        softbench_core::error_class::ErrorClass::BadInput
    }
}

/// One claim, as its file states it.
#[derive(Clone, Debug, PartialEq)]
pub struct Claim {
    /// The file stem: the claim's id.
    pub id: String,
    pub path: PathBuf,
    /// The claim in one sentence.
    pub claim: String,
    /// The citation.
    pub paper: String,
    /// Where to read it (a DOI or URL).
    pub link: Option<String>,
    /// The paper's own words, where they were checked, and where in the paper.
    pub quote: Option<String>,
    pub quote_where: Option<String>,
    pub dimension: String,
    /// The study whose committed results test it (`results/<study>/`).
    pub study: String,
    /// `[a, b]`: the claim says `a` beats `b` (an edge of the claims graph).
    pub beats: Option<[String; 2]>,
    /// What the test does not cover of the claim (hardware, features softbench lacks).
    pub caveats: Option<String>,
    /// Where the paper claims its results (`gpu`, `cpu`), when it says.
    pub claimed_on: Option<String>,
    pub rule: RuleSpec,
    /// The implementations it is judged on: softbench's own method (its `subject`) and the
    /// field's own (`[[originals]]`); empty for a claim about no one method.
    pub implementations: Vec<Implementation>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct ClaimFile {
    claim: String,
    paper: String,
    #[serde(default)]
    link: Option<String>,
    #[serde(default)]
    quote: Option<String>,
    #[serde(default)]
    quote_where: Option<String>,
    dimension: String,
    study: String,
    #[serde(default)]
    beats: Option<[String; 2]>,
    #[serde(default)]
    caveats: Option<String>,
    #[serde(default)]
    subject: Option<String>,
    #[serde(default)]
    claimed_on: Option<String>,
    #[serde(default)]
    originals: Vec<Original>,
    rule: toml::Table,
}

impl Claim {
    /// Read and check one claim file.
    pub fn read(path: &Path) -> Result<Self, LedgerError> {
        let text = std::fs::read_to_string(path).map_err(|error| LedgerError::Io {
            path: path.to_owned(),
            error,
        })?;
        let invalid = |message: String| LedgerError::Invalid {
            path: path.to_owned(),
            message,
        };
        let file: ClaimFile = toml::from_str(&text)
            .map_err(|e| invalid(softbench_core::quote::clip_source(e.to_string().trim_end())))?;
        if !DIMENSIONS.contains(&file.dimension.as_str()) {
            return Err(invalid(format!(
                "dimension: {}",
                softbench_core::names::unknown_name_message(
                    "dimension",
                    &file.dimension,
                    &DIMENSIONS
                )
            )));
        }
        for (key, value) in [
            ("claim", &file.claim),
            ("paper", &file.paper),
            ("study", &file.study),
        ] {
            if value.trim().is_empty() {
                return Err(invalid(format!("{key}: must not be empty")));
            }
        }
        crate::study::check_study_name(&file.study).map_err(|m| invalid(format!("study: {m}")))?;
        let rule = RuleSpec::parse(&file.rule).map_err(|m| invalid(format!("rule: {m}")))?;
        if let Some(c) = &file.claimed_on
            && !["cpu", "gpu"].contains(&c.as_str())
        {
            return Err(invalid(format!(
                "claimed_on: `{c}`: expected `cpu` or `gpu`"
            )));
        }
        let implementations = match &file.subject {
            Some(subject) => implementation::implementations(
                subject,
                &file.rule,
                &rule,
                &file.originals,
                file.claimed_on.as_deref() == Some("gpu"),
            )
            .map_err(invalid)?,
            None if !file.originals.is_empty() => {
                return Err(invalid(
                    "originals: name the method they implement with `subject = \"...\"`".into(),
                ));
            }
            None => Vec::new(),
        };
        Ok(Self {
            id: path
                .file_stem()
                .map_or_else(String::new, |s| s.to_string_lossy().into_owned()),
            path: path.to_owned(),
            claim: file.claim,
            paper: file.paper,
            link: file.link,
            quote: file.quote,
            quote_where: file.quote_where,
            dimension: file.dimension,
            study: file.study,
            beats: file.beats,
            caveats: file.caveats,
            claimed_on: file.claimed_on,
            rule,
            implementations,
        })
    }
}

/// Every claim file of a folder, by file name.
pub fn read_claims(dir: &Path) -> Result<Vec<Claim>, LedgerError> {
    let entries = std::fs::read_dir(dir).map_err(|error| LedgerError::Io {
        path: dir.to_owned(),
        error,
    })?;
    let mut paths: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    paths.sort();
    if paths.is_empty() {
        return Err(LedgerError::Empty {
            path: dir.to_owned(),
        });
    }
    paths.iter().map(|p| Claim::read(p)).collect()
}

/// A claim with its verdict, or why it could not be evaluated (its results are missing or lack
/// a column the rule reads: an unmeasured claim, with the reason).
#[derive(Clone, Debug, PartialEq)]
pub struct Judged {
    pub claim: Claim,
    /// The implementation judged, for a claim about one method (see [`Claim::implementations`]).
    pub implementation: Option<Implementation>,
    /// The table the rule read, relative to the results folder.
    pub table: String,
    pub verdict: Verdict,
}

impl Judged {
    /// Whether the verdict rests on a measured time, so the page names the device.
    pub fn timed(&self) -> bool {
        self.implementation
            .as_ref()
            .is_some_and(|i| i.rule.reads_time())
    }
}

/// Evaluate every claim against the committed results under `results` (`<results>/<study>/`):
/// one verdict per claim, or per implementation for a claim about one method.
pub fn judge(claims: &[Claim], results: &Path) -> Vec<Judged> {
    let mut out = Vec::new();
    for claim in claims {
        let table_path = results.join(&claim.study).join(&claim.rule.table);
        let shown = format!("{}/{}", claim.study, claim.rule.table);
        let table = Table::read(&table_path);
        let judged = |implementation: Option<&Implementation>| {
            let rule = implementation.map_or(&claim.rule, |i| &i.rule);
            let verdict = match &table {
                Ok(Some(table)) => judge_one(rule, table, implementation, &shown),
                Ok(None) => unmeasured(format!("no committed results: `{shown}` does not exist")),
                Err(e) => unmeasured(format!("`{shown}` cannot be read: {e}")),
            };
            Judged {
                claim: claim.clone(),
                implementation: implementation.cloned(),
                table: shown.clone(),
                verdict,
            }
        };
        if claim.implementations.is_empty() {
            out.push(judged(None));
        } else {
            out.extend(claim.implementations.iter().map(|i| judged(Some(i))));
        }
    }
    out
}

fn unmeasured(why: String) -> Verdict {
    Verdict::unmeasured(why)
}

/// `rule` on `table`, or why it cannot be: a column it reads is missing, or (a GPU verdict) no
/// row of the implementation ran on a GPU. A table without the device column ran every peer
/// on its default device, the CPU.
fn judge_one(
    rule: &RuleSpec,
    table: &Table,
    implementation: Option<&Implementation>,
    shown: &str,
) -> Verdict {
    let mut with_device;
    let mut table = table;
    if table.column(DEVICE_COLUMN).is_none() && rule.columns().iter().any(|c| c == DEVICE_COLUMN) {
        with_device = table.clone();
        with_device.header.push(DEVICE_COLUMN.to_owned());
        for row in &mut with_device.rows {
            row.push("cpu".to_owned());
        }
        table = &with_device;
    }
    if let Some(i) = implementation
        && i.package.is_some()
        && i.device == Device::Cpu
        && !table
            .rows
            .iter()
            .any(|row| table.get(row, "method") == Some(i.method.as_str()))
    {
        return unmeasured(format!(
            "no run of `{}` in `{shown}`: its committed results were made without the peer \
             methods (run the study with `python -m softbench`, docs/peers.md)",
            i.method
        ));
    }
    if let Some(i) = implementation
        && i.device == Device::Gpu
    {
        let on_gpu = table.rows.iter().any(|row| {
            table.get(row, "method") == Some(i.method.as_str())
                && table.get(row, DEVICE_COLUMN) == Some("cuda")
        });
        if !on_gpu {
            return unmeasured(format!(
                "open: no run of `{}` on a GPU in `{shown}` (the machine that ran it has none); \
                 it is judged when a machine with a GPU runs the study with \
                 `{DEVICE_COLUMN} = \"cuda\"`",
                i.method
            ));
        }
    }
    let missing: Vec<String> = rule
        .columns()
        .into_iter()
        .filter(|c| table.column(c).is_none())
        .collect();
    if missing.is_empty() {
        verdict::evaluate(rule, table)
    } else {
        unmeasured(format!(
            "`{shown}` has no column {}",
            missing
                .iter()
                .map(|c| format!("`{c}`"))
                .collect::<Vec<_>>()
                .join(", ")
        ))
    }
}
