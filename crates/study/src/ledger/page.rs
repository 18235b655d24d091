//! The ledger as one Markdown page: a summary of the verdicts, the graph of "A beats B"
//! claims coloured by verdict (Mermaid), and one section per claim with the paper, its words,
//! the rule in words, the evidence and the verdict. The page holds nothing but what the claim
//! files and the results give, so rendering it again from the same files gives the same bytes.

use super::Judged;
use super::verdict::Class;
use std::fmt::Write;

/// The page for `judged` (claims in file order); `results` is how the page names the results
/// folder the verdicts were computed from.
pub fn render(judged: &[Judged], results: &str) -> String {
    let mut out = String::from("# Claims ledger\n\n");
    let count = |c: Class| judged.iter().filter(|j| j.verdict.class == c).count();
    let _ = writeln!(
        out,
        "{} claims from the literature on the methods softbench has, each tested by a committed \
         study under `{results}/`. Every verdict below is computed by `softbench ledger` from the \
         claim's rule (written next to it in `claims/<id>.toml`) and those results: \
         **{} validated, {} qualified, {} refuted, {} unmeasured**. A verdict is only as wide \
         as the study behind it: the caveats say what the test does not cover.\n",
        judged.len(),
        count(Class::Validated),
        count(Class::Qualified),
        count(Class::Refuted),
        count(Class::Unmeasured)
    );
    let _ = writeln!(
        out,
        "| claim | dimension | tested by | verdict |\n|---|---|---|---|"
    );
    for j in judged {
        let _ = writeln!(
            out,
            "| [{}](#{}) | {} | `{}` | **{}**{} |",
            j.claim.claim.replace('|', "\\|"),
            j.claim.id,
            j.claim.dimension,
            j.table,
            j.verdict.class.name(),
            if j.verdict.condition.is_empty() || j.verdict.class != Class::Qualified {
                String::new()
            } else {
                format!(": {}", j.verdict.condition.replace('|', "\\|"))
            }
        );
    }
    graph(&mut out, judged);
    for j in judged {
        section(&mut out, j);
    }
    out
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
        let _ = writeln!(
            out,
            "  {}[\"{a}\"] -->|\"{}: {}\"| {}[\"{b}\"]",
            node(a),
            j.claim.dimension,
            j.verdict.class.name(),
            node(b)
        );
    }
    let _ = writeln!(out, "```");
}

fn section(out: &mut String, j: &Judged) {
    let c = &j.claim;
    let v = &j.verdict;
    let _ = writeln!(out, "\n<a id=\"{}\"></a>\n## {}\n", c.id, c.claim);
    let _ = writeln!(
        out,
        "**{}**{}\n",
        v.class.name(),
        if v.condition.is_empty() {
            String::new()
        } else {
            format!(": {}", v.condition)
        }
    );
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
    let _ = writeln!(out, "- Rule: {}", c.rule.describe());
    let _ = writeln!(
        out,
        "- Evidence: it held in {} of {} decided cases{}.",
        v.held,
        v.decided,
        if v.ties > 0 {
            format!(" ({} more were ties and decide nothing)", v.ties)
        } else {
            String::new()
        }
    );
    if !v.strata.is_empty() {
        let mut by_column: Vec<(&str, Vec<String>)> = Vec::new();
        for (column, value, held, n) in &v.strata {
            let text = format!("{} {held}/{n}", if value.is_empty() { "-" } else { value });
            match by_column.iter_mut().find(|(c, _)| c == column) {
                Some((_, list)) => list.push(text),
                None => by_column.push((column, vec![text])),
            }
        }
        for (column, list) in by_column {
            let _ = writeln!(out, "  - by {column}: {}", list.join(", "));
        }
    }
    for (label, held) in &v.examples {
        let _ = writeln!(
            out,
            "  - {}: {}",
            if *held { "holds" } else { "does not hold" },
            label
        );
    }
    if let Some(caveats) = &c.caveats {
        let _ = writeln!(out, "- Caveats: {}", caveats.trim());
    }
}
