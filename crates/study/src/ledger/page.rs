//! The ledger as one Markdown page: a summary of the verdicts, the graph of "A beats B"
//! claims coloured by verdict (Mermaid), and one section per claim with the paper, its words,
//! the rule in words, the evidence and the verdict — for a claim about one method, a verdict
//! per implementation (softbench's own and the field's), each saying which one it judges and,
//! when it rests on a time, on which device. The page holds nothing but what the claim files
//! and the results give, so rendering it again from the same files gives the same bytes.

use super::Judged;
use super::cases::Outcome;
use super::verdict::{Class, count};
use std::fmt::Write;

/// The page for `judged` (claims in file order); `results` is how the page names the results
/// folder the verdicts were computed from.
pub fn render(judged: &[Judged], results: &str) -> String {
    let mut out = String::from("# Claims ledger\n\n");
    let count = |c: Class| judged.iter().filter(|j| j.verdict.class == c).count();
    let _ = writeln!(
        out,
        "{} claims from the literature on the methods softbench has, each tested by a committed \
         study under `{results}/`; a claim about one method is judged on softbench's own \
         implementation and on the field's own (the peer methods of docs/peers.md), so the \
         {} claims give {} verdicts. Every verdict below is computed by `softbench ledger` from \
         the claim's rule (written next to it in `claims/<id>.toml`) and those results: \
         **{} validated, {} qualified, {} refuted, {} unmeasured**. A verdict is only as wide \
         as the study behind it: the caveats say what the test does not cover, and a verdict \
         that rests on a time names the device it was measured on. A verdict counts independent \
         problems (a scene with its material and setting), not the rungs of one ladder \
         (accuracy targets, steps, tolerances, cut-off levels), and one that rests on a time \
         compares spreads: times whose spreads overlap tie, and a time without a spread decides \
         nothing. *Decided by* says how many problems decided each verdict.\n",
        claims(judged).len(),
        claims(judged).len(),
        judged.len(),
        count(Class::Validated),
        count(Class::Qualified),
        count(Class::Refuted),
        count(Class::Unmeasured)
    );
    let _ = writeln!(
        out,
        "| claim | judged on | dimension | tested by | verdict | decided by |\n\
         |---|---|---|---|---|---|"
    );
    for j in judged {
        let _ = writeln!(
            out,
            "| [{}](#{}) | {} | {} | `{}` | **{}**{} | {} |",
            j.claim.claim.replace('|', "\\|"),
            j.claim.id,
            judged_on(j),
            j.claim.dimension,
            j.table,
            j.verdict.class.name(),
            if j.verdict.condition.is_empty() || j.verdict.class != Class::Qualified {
                String::new()
            } else {
                format!(": {}", j.verdict.condition.replace('|', "\\|"))
            },
            if j.verdict.cases.total() == 0 {
                "-".to_owned()
            } else {
                j.verdict.tally()
            }
        );
    }
    graph(&mut out, judged);
    for group in claims(judged) {
        section(&mut out, group);
    }
    out
}

/// The verdicts grouped by claim, in file order.
fn claims(judged: &[Judged]) -> Vec<&[Judged]> {
    judged.chunk_by(|a, b| a.claim.id == b.claim.id).collect()
}

/// Which implementation a verdict judges ("softbench's `vbd`, CPU"), or `-`.
fn judged_on(j: &Judged) -> String {
    j.implementation
        .as_ref()
        .map_or_else(|| "-".to_owned(), |i| i.label(j.timed()))
}

/// The "A beats B" claims as a graph: an arrow from the method claimed better, labelled with
/// the dimension and the verdict.
fn graph(out: &mut String, judged: &[Judged]) {
    let edges: Vec<&Judged> = judged.iter().filter(|j| j.claim.beats.is_some()).collect();
    if edges.is_empty() {
        return;
    }
    let _ = writeln!(
        out,
        "\n## The claims graph\n\nAn arrow from the method a paper claims better to the one it \
         claims to beat, labelled with the dimension and the verdict.\n\n```mermaid\ngraph LR"
    );
    let node = |m: &str| m.replace(|c: char| !c.is_ascii_alphanumeric(), "_");
    for j in &edges {
        let [a, b] = j.claim.beats.as_ref().expect("filtered");
        // A verdict on an original starts at the original's node.
        let (a, device) = match &j.implementation {
            Some(i) if j.timed() => (i.method.as_str(), format!(", {}", i.device.name())),
            Some(i) => (i.method.as_str(), String::new()),
            None => (a.as_str(), String::new()),
        };
        let _ = writeln!(
            out,
            "  {}[\"{a}\"] -->|\"{}{device}: {}\"| {}[\"{b}\"]",
            node(a),
            j.claim.dimension,
            j.verdict.class.name(),
            node(b)
        );
    }
    let _ = writeln!(out, "```");
}

fn section(out: &mut String, group: &[Judged]) {
    let j = &group[0];
    let c = &j.claim;
    let _ = writeln!(out, "\n<a id=\"{}\"></a>\n## {}\n", c.id, c.claim);
    if j.implementation.is_none() {
        let _ = writeln!(out, "{}\n", verdict_line(j));
    } else {
        for j in group {
            let _ = writeln!(out, "- Judged on {}: {}", judged_on(j), verdict_line(j));
        }
        let _ = writeln!(out);
    }
    let _ = writeln!(
        out,
        "- Paper: {}{}",
        c.paper,
        c.link.as_ref().map_or(String::new(), |l| format!(" ({l})"))
    );
    if let Some(q) = &c.quote {
        let _ = writeln!(
            out,
            "- In its words{}: “{}”",
            c.quote_where
                .as_ref()
                .map_or(String::new(), |w| format!(" ({w})")),
            q.trim()
        );
    }
    let _ = writeln!(
        out,
        "- Dimension: {}. Tested by `{}` (claim file `claims/{}.toml`).",
        c.dimension, j.table, c.id
    );
    if let (Some("gpu"), true) = (c.claimed_on.as_deref(), j.timed()) {
        let _ = writeln!(
            out,
            "- Device: the paper claims its speed on a GPU; a CPU verdict here is a verdict on \
             the CPU only, and a GPU verdict stays open until a machine with a GPU runs the \
             study."
        );
    }
    for j in group {
        if j.implementation.is_some() {
            let _ = writeln!(out, "- Judged on {}:", judged_on(j));
            evidence(out, j, "  ");
        } else {
            evidence(out, j, "");
        }
    }
    if let Some(caveats) = &c.caveats {
        let _ = writeln!(out, "- Caveats: {}", caveats.trim());
    }
}

/// The verdict in bold, with its condition.
fn verdict_line(j: &Judged) -> String {
    let v = &j.verdict;
    format!(
        "**{}**{}",
        v.class.name(),
        if v.condition.is_empty() {
            String::new()
        } else {
            format!(": {}", v.condition)
        }
    )
}

/// The rule in words and what it found, indented by `at`.
fn evidence(out: &mut String, j: &Judged, at: &str) {
    let v = &j.verdict;
    let rule = j.implementation.as_ref().map_or(&j.claim.rule, |i| &i.rule);
    let _ = writeln!(out, "{at}- Rule: {}", rule.describe());
    let (p, c) = (&v.problems, &v.cases);
    let mut undecided = Vec::new();
    if p.tied > 0 {
        undecided.push(format!("{} more tied", p.tied));
    }
    if p.unspread > 0 {
        undecided.push(format!("{} more had timings without a spread", p.unspread));
    }
    let _ = writeln!(
        out,
        "{at}- Evidence: decided by {}: it held on {}, failed on {}, was split on {}{}. Behind \
         them, {}: {} held, {} did not, {} tied{}.",
        count(p.decided(), "problem"),
        p.held,
        p.failed,
        p.split,
        if undecided.is_empty() {
            String::new()
        } else {
            format!("; {}, and decide nothing", undecided.join(" and "))
        },
        count(c.total(), "case"),
        c.held,
        c.failed,
        c.tied,
        if c.unspread > 0 {
            format!(", {} timed without a spread", c.unspread)
        } else {
            String::new()
        }
    );
    let mut by_column: Vec<(&str, Vec<String>)> = Vec::new();
    for s in v.strata.iter().filter(|s| s.problems.decided() > 0) {
        let text = format!(
            "{} {}/{}{}",
            if s.value.is_empty() { "-" } else { &s.value },
            s.problems.held,
            s.problems.decided(),
            if s.problems.split > 0 {
                format!(" ({} split)", s.problems.split)
            } else {
                String::new()
            }
        );
        match by_column.iter_mut().find(|(c, _)| *c == s.column) {
            Some((_, list)) => list.push(text),
            None => by_column.push((&s.column, vec![text])),
        }
    }
    for (column, list) in by_column {
        let _ = writeln!(out, "{at}  - by {column}: {}", list.join(", "));
    }
    for e in &v.examples {
        let cases: Vec<String> = e
            .cases
            .iter()
            .map(|(label, o)| {
                if e.outcome == Outcome::Split {
                    format!("{}: {label}", o.name())
                } else {
                    label.clone()
                }
            })
            .collect();
        let _ = writeln!(
            out,
            "{at}  - {} on {} ({}): {}{}",
            e.outcome.name(),
            e.problem,
            count(e.decided, "decided case"),
            cases.join("; "),
            if e.decided > e.cases.len() {
                "; …"
            } else {
                ""
            }
        );
    }
}
