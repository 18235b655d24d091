//! `report.md`: what was run, on what, a summary table, the plots, and one line per run that
//! did not end well.

use crate::study::kind::Present;
use crate::study::present::charts::{Plot, SceneRows, distinguishing, scenes, slug};
use crate::study::present::findings::Findings;
use crate::study::vocabulary::config::SWEEP;
use crate::study::vocabulary::format::short;
use crate::study::vocabulary::meta::Meta;
use crate::study::vocabulary::reference::Reference;
use crate::study::vocabulary::spec::Study;
use crate::study::vocabulary::table::Table;
use softbench_run::io::write_atomic;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// The study's reference solutions by physics (scene name first), and those that failed
/// (with why).
#[derive(Clone, Copy)]
pub struct References<'a> {
    pub solved: &'a BTreeMap<u64, (String, Reference)>,
    pub failed: &'a BTreeMap<u64, (String, String)>,
}

/// Write `report.md` into `dir`.
pub fn write(
    dir: &Path,
    study: &Study,
    meta: &Meta,
    runs: &Table,
    plots: &[Plot],
    reused: usize,
    references: References,
) -> std::io::Result<()> {
    let text = render(study, meta, runs, plots, reused, references);
    write_atomic(&dir.join("report.md"), |w| w.write_all(text.as_bytes()))
}

fn render(
    study: &Study,
    meta: &Meta,
    runs: &Table,
    plots: &[Plot],
    reused: usize,
    references: References,
) -> String {
    let References {
        solved: references,
        failed: failed_references,
    } = references;
    let s = &meta.study;
    let mut out = String::new();
    let kind = if s.study == SWEEP {
        format!(
            "sweep of {} over `{}`",
            s.kind,
            s.sweep_parameter.as_deref().unwrap_or("?")
        )
    } else {
        s.kind.clone()
    };
    let _ = writeln!(out, "# {}: {kind} study\n", s.name);
    if let Some(d) = &s.description {
        let _ = writeln!(out, "{}\n", d.trim());
    }
    if s.quick {
        let _ = writeln!(
            out,
            "**Quick mode** (`--quick`): {}; these numbers are a smoke test, not results.\n",
            crate::study::kinds::present(&s.kind).quick_notice()
        );
    }
    let damped = damped_scenes(study);
    crate::study::present::findings::write(
        &mut out,
        &with_load_warnings(
            compute_findings(&s.kind, runs, &s.parameters, &damped).unwrap_or_default(),
            s,
        ),
    );
    let m = &meta.machine;
    let _ = writeln!(
        out,
        "Study file `{}`; {} runs in `runs.csv` ({reused} reused from an earlier invocation). \
         softbench {} (commit `{}`), {}; {} ({} cores{}), {}. Started {}, finished {}, {} s.\n",
        s.file.display(),
        runs.rows.len(),
        m.softbench_version,
        m.git_commit,
        m.rustc,
        m.cpu,
        m.cores,
        m.load_average.map_or(String::new(), |l| format!(
            ", load average {:.2} / {:.2} / {:.2} over 1 / 5 / 15 min at the start",
            l[0], l[1], l[2]
        )),
        m.os,
        meta.started,
        meta.finished.as_deref().unwrap_or("-"),
        meta.wall_seconds.map_or("-".into(), |w| format!("{w:.1}")),
    );
    shards_paragraph(&mut out, meta, study.runs.len());
    omissions_paragraph(&mut out, s);
    crate::study::kinds::present(&s.kind).report_settings(&mut out, &study.file);
    if !references.is_empty() || !failed_references.is_empty() {
        let _ = writeln!(out, "References:\n");
        for (scene, message) in failed_references.values() {
            let _ = writeln!(
                out,
                "- {scene}: **the reference failed**, so its errors are left empty: {message}"
            );
        }
        for (scene, r) in references.values() {
            if r.same_dt {
                let _ = writeln!(
                    out,
                    "- {scene}: {} converged at the runs' own dt; it differs from a second \
                     solve at a 100× tighter Newton tolerance by {:.3e} (position) and {:.3e} \
                     (energy); errors below {} x that are not scored.",
                    r.method.name(),
                    r.difference,
                    r.energy_difference,
                    r.floor_factor()
                );
                continue;
            }
            let _ = writeln!(
                out,
                "- {scene}: {} at dt = {} s; it differs from {} by {:.3e} (position) and \
                 {:.3e} (energy); errors below {} x that are not scored.",
                r.method.name(),
                short(r.dt),
                r.checked_against(),
                r.difference,
                r.energy_difference,
                r.floor_factor()
            );
        }
        let _ = writeln!(out);
    }
    crate::study::kinds::present(&s.kind).report_findings(&mut out, runs, s);

    if crate::study::kinds::present(&s.kind).report_runs_table() {
        let _ = writeln!(out, "## Runs\n");
        let mut columns: Vec<&str> = vec!["scene", "method", "linear_solver"];
        columns.extend(s.parameters.iter().map(String::as_str));
        columns.extend(
            crate::study::kinds::present(&s.kind)
                .summary_columns()
                .iter()
                .copied()
                .filter(|c| runs.column(c).is_some()),
        );
        let _ = writeln!(out, "| {} |", columns.join(" | "));
        let _ = writeln!(out, "|{}", "---|".repeat(columns.len()));
        for row in &runs.rows {
            let cells: Vec<String> = columns
                .iter()
                .map(|c| {
                    let v = runs.get(row, c).unwrap_or_default();
                    match v.parse::<f64>() {
                        Ok(x) if v.contains('e') || v.contains('.') => short(x),
                        _ => v.replace('|', "\\|"),
                    }
                })
                .collect();
            let _ = writeln!(out, "| {} |", cells.join(" | "));
        }
        let _ = writeln!(
            out,
            "\n{}\n",
            units_note(crate::study::kinds::present(&s.kind), runs, &columns)
        );
    } else {
        let _ = writeln!(
            out,
            "## Runs\n\nThe {} runs are in `runs.csv`, one row each.\n",
            runs.rows.len()
        );
    }

    closing_sections(&mut out, meta, runs, plots);
    provenance(&mut out, meta);
    out
}

/// The report's last section: the versions, the machine, the exact command and the load, so a
/// reader can tell what made these numbers and how comparable its timings are.
fn provenance(out: &mut String, meta: &Meta) {
    let _ = writeln!(out, "\n{PROVENANCE_HEADING}\n");
    if meta.shards.is_empty() {
        let m = &meta.machine;
        let _ = writeln!(
            out,
            "- Command: `{}`\n\
             - {}\n\
             - Machine: {}\n\
             - Load average over 1 / 5 / 15 min: {} at the start, {} at the end\n\
             - Started {}, finished {}, {} s",
            shell_words(&meta.command),
            build(m),
            machine(m),
            load(m.load_average),
            load(meta.finished_load_average),
            meta.started,
            meta.finished.as_deref().unwrap_or("-"),
            meta.wall_seconds.map_or("-".into(), |w| format!("{w:.1}")),
        );
        return;
    }
    // Merged shards: each shard's own command, build, machine and load (the merge itself
    // measures nothing, and its time and load would make merging twice differ).
    let of = meta.shards.iter().map(|r| r.of).max().unwrap_or(0);
    let _ = writeln!(
        out,
        "Run as {of} shard{} ({} recorded) and merged with `softbench merge`:\n",
        if of == 1 { "" } else { "s" },
        meta.shards.len()
    );
    for r in &meta.shards {
        let m = &r.machine;
        let _ = writeln!(
            out,
            "- Shard {}/{} on {}: `{}`; {}; {}; load average over 1 / 5 / 15 min {} at its \
             start; started {}, {} s",
            r.shard,
            r.of,
            r.host,
            shell_words(&r.command),
            build(m),
            machine(m),
            load(m.load_average),
            r.started,
            r.wall_seconds.map_or("-".into(), |w| format!("{w:.1}")),
        );
    }
}

/// The build that ran: `softbench 0.1.0 (commit `…`), rustc …`.
fn build(m: &crate::study::vocabulary::machine::Machine) -> String {
    format!(
        "softbench {} (commit `{}`), {}",
        m.softbench_version, m.git_commit, m.rustc
    )
}

/// The machine that ran: `CPU (N cores), OS`.
fn machine(m: &crate::study::vocabulary::machine::Machine) -> String {
    format!("{} ({} cores), {}", m.cpu, m.cores, m.os)
}

/// A load average as `1 / 5 / 15` minutes, or `-` where the platform gives none.
fn load(l: Option<[f64; 3]>) -> String {
    l.map_or("-".to_owned(), |l| {
        format!("{:.2} / {:.2} / {:.2}", l[0], l[1], l[2])
    })
}

/// A command line as one would type it: the binary by its name, arguments quoted where a
/// shell would need it.
fn shell_words(command: &[String]) -> String {
    let words: Vec<String> = command
        .iter()
        .enumerate()
        .map(|(i, a)| {
            let a = if i == 0 {
                Path::new(a)
                    .file_name()
                    .map_or(a.clone(), |n| n.to_string_lossy().into_owned())
            } else {
                a.clone()
            };
            if a.is_empty() || a.contains(|c: char| c.is_whitespace() || "'\"$`\\*?".contains(c)) {
                format!("'{}'", a.replace('\'', "'\\''"))
            } else {
                a
            }
        })
        .collect();
    words.join(" ")
}

/// For a study run as shards and merged: which shard ran where and how long, and whether
/// runs are missing.
fn shards_paragraph(out: &mut String, meta: &Meta, total: usize) {
    if !meta.missing.is_empty() {
        let _ = writeln!(
            out,
            "**Incomplete: {} of the study's {total} runs are missing** (listed at the end); \
             run their shards again (a shard resumes where it stopped), then `softbench merge`.\n",
            meta.missing.len()
        );
    }
    if meta.shards.is_empty() {
        return;
    }
    let _ = writeln!(
        out,
        "Run as shards (`softbench run --shard K/N`) and merged (`softbench merge`); runs are \
         assigned by estimated cost (steps x DOFs x a per-step weight):\n"
    );
    let _ = writeln!(
        out,
        "| shard | host | status | runs | run now | estimated cost | started | s |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|");
    for r in &meta.shards {
        let _ = writeln!(
            out,
            "| {}/{} | {} | {} | {} | {} | {} | {} | {} |",
            r.shard,
            r.of,
            r.host,
            r.status,
            r.runs.len(),
            r.ran,
            short(r.estimated_cost),
            r.started,
            r.wall_seconds.map_or("-".into(), |w| format!("{w:.1}"))
        );
    }
    let _ = writeln!(out);
}

/// The scenes of the study with damping, and what damping.
fn damped_scenes(study: &Study) -> BTreeMap<String, String> {
    damped_scenes_of(
        study
            .runs
            .iter()
            .map(|r| (r.scene.as_str(), &r.loaded.config.damping)),
    )
}

/// The damped scenes among `(scene, damping)` pairs, with how each is damped.
pub(in crate::study) fn damped_scenes_of<'a>(
    runs: impl IntoIterator<Item = (&'a str, &'a softbench_run::scene::DampingConfig)>,
) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    for (scene, d) in runs {
        let mut how = Vec::new();
        if let Some(ray) = &d.rayleigh {
            how.push(format!(
                "Rayleigh alpha = {} 1/s, beta = {} s",
                ray.alpha, ray.beta
            ));
        }
        if let Some(sr) = &d.strain_rate {
            how.push(format!(
                "strain-rate phi = {} Pa s, psi = {} Pa s",
                sr.phi, sr.psi
            ));
        }
        if !how.is_empty() {
            out.entry(scene.to_owned())
                .or_insert_with(|| how.join(", "));
        }
    }
    out
}

/// The units line under the runs table: only for the columns it shows, and saying why a
/// momentum column is empty when it is.
fn units_note(kind: &dyn Present, runs: &Table, columns: &[&str]) -> String {
    let shown = |c: &str| columns.contains(&c);
    let mut parts = vec!["time steps and times in s".to_owned()];
    if shown("energy_drift_max") || shown("energy_drift_final") {
        parts.push(
            "energy drifts are the energy gained or lost beyond the work done on the body and \
             the energy damping removed, over the energy the body holds or exchanges"
                .into(),
        );
    }
    parts.extend(kind.unit_notes(runs, &shown));
    format!("Units: {}.", parts.join("; "))
}

/// Rewrite the findings section of `dir/report.md` from `runs` (after `softbench plot`
/// redrew the plots): the section is replaced, or inserted before the study paragraph of a
/// report written before reports had findings. The damped scenes come from the scene
/// configurations `meta.json` records. Returns whether a report was there to update.
pub fn refresh_findings(dir: &Path, meta: &Meta, runs: &Table) -> std::io::Result<bool> {
    let path = dir.join("report.md");
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(false),
        Err(e) => return Err(e),
    };
    let damping: Vec<(String, softbench_run::scene::DampingConfig)> = runs
        .rows
        .iter()
        .filter_map(|r| {
            let id = runs.get(r, "run_id")?;
            let scene = runs.get(r, "scene")?;
            let d = meta.run_config(id)?.get("damping")?.clone();
            Some((scene.to_owned(), serde_json::from_value(d).ok()?))
        })
        .collect();
    let damped = damped_scenes_of(damping.iter().map(|(s, d)| (s.as_str(), d)));
    let mut findings = String::new();
    crate::study::present::findings::write(
        &mut findings,
        &with_load_warnings(
            compute_findings(&meta.study.kind, runs, &meta.study.parameters, &damped)
                .unwrap_or_default(),
            &meta.study,
        ),
    );
    let updated = replace_findings(&text, &findings);
    write_atomic(&path, |w| w.write_all(updated.as_bytes()))?;
    Ok(true)
}

/// The sections after the runs: `## Plots` (each plot's title, caption and image), the runs
/// that did not finish cleanly, and the missing runs of a merged study.
fn closing_sections(out: &mut String, meta: &Meta, runs: &Table, plots: &[Plot]) {
    let _ = writeln!(out, "{PLOTS_HEADING}\n");
    for p in plots {
        let _ = writeln!(
            out,
            "### {}\n\n{}\n\n![{}]({}.png)\n",
            p.title, p.caption, p.title, p.stem
        );
    }
    let _ = writeln!(out, "## Runs that did not finish cleanly\n");
    let kind = crate::study::kinds::present(&meta.study.kind);
    if let Some(note) = kind.failures_note(runs) {
        let _ = writeln!(out, "{note}");
    } else {
        let mut any = false;
        for row in &runs.rows {
            let verdict = kind.verdict(runs, row);
            let message = runs.get(row, "message").unwrap_or_default();
            let unconverged = runs
                .number(row, "newton_unconverged_steps")
                .is_some_and(|n| n > 0.0);
            if !verdict.clean || kind.flagged(runs, row) || unconverged {
                any = true;
                let what = verdict.word;
                let mut detail = message.to_owned();
                if unconverged {
                    let _ = write!(
                        detail,
                        "{}Newton stopped unconverged at its cap ({} iterations) in {} steps",
                        if detail.is_empty() { "" } else { "; " },
                        runs.get(row, "newton_max_iterations").unwrap_or("?"),
                        runs.get(row, "newton_unconverged_steps").unwrap_or("?")
                    );
                }
                let _ = writeln!(out, "- `{}`: {what}: {detail}", row[0]);
            }
        }
        if !any {
            let _ = writeln!(out, "None.");
        }
    }
    if !meta.missing.is_empty() {
        let _ = writeln!(out, "\n## Missing runs\n");
        for id in &meta.missing {
            let _ = writeln!(out, "- `{id}`");
        }
    }
}

const PLOTS_HEADING: &str = "## Plots";
const PROVENANCE_HEADING: &str = "## How these results were made";

/// Rewrite the sections of `dir/report.md` from its plots to its provenance for `plots` (after
/// `softbench plot` redrew them, their titles and captions may have changed) and `runs`.
/// Returns whether a report with a plots section was there to update.
pub fn refresh_closing_sections(
    dir: &Path,
    meta: &Meta,
    runs: &Table,
    plots: &[Plot],
) -> std::io::Result<bool> {
    let path = dir.join("report.md");
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(false),
        Err(e) => return Err(e),
    };
    let mut sections = String::new();
    closing_sections(&mut sections, meta, runs, plots);
    let Some(updated) = replace_closing_sections(&text, &sections) else {
        return Ok(false);
    };
    write_atomic(&path, |w| w.write_all(updated.as_bytes()))?;
    Ok(true)
}

/// `report` with everything from its plots section to its provenance (or its end) replaced
/// by `sections`; `None` without a plots section.
fn replace_closing_sections(report: &str, sections: &str) -> Option<String> {
    let start = report.find(&format!("\n{PLOTS_HEADING}\n"))? + 1;
    let end = report[start..]
        .find(&format!("\n\n{PROVENANCE_HEADING}\n"))
        .map_or(report.len(), |i| start + i + 1);
    Some(format!("{}{sections}{}", &report[..start], &report[end..]))
}

/// `report` with its findings section (from `## Findings` to the next paragraph that is not
/// part of it) replaced by `findings`, or `findings` inserted before the `Study file` paragraph.
fn replace_findings(report: &str, findings: &str) -> String {
    const STUDY_PARAGRAPH: &str = "Study file `";
    let end_of_section = |from: usize| {
        report[from..]
            .find(&format!("\n{STUDY_PARAGRAPH}"))
            .map(|i| from + i + 1)
            .or_else(|| report[from..].find("\n## ").map(|i| from + i + 1))
            .unwrap_or(report.len())
    };
    if let Some(start) = report.find("## Findings\n") {
        let end = end_of_section(start + 1);
        return format!("{}{findings}{}", &report[..start], &report[end..]);
    }
    match report.find(&format!("\n{STUDY_PARAGRAPH}")) {
        Some(i) => format!("{}{findings}{}", &report[..i + 1], &report[i + 1..]),
        None => format!("{report}\n{findings}"),
    }
}

/// The findings of `runs`, a table of a study whose runs a registered `kind` measured (a
/// sweep's inner kind): per scene, the kind's rankings; then the warnings. `damped` names the
/// scenes with damping (and how), named in the drift ranking, which accounts their loss.
/// `None` when no kind of that name is registered.
pub fn compute_findings(
    kind: &str,
    runs: &Table,
    params: &[String],
    damped: &BTreeMap<String, String>,
) -> Option<Findings> {
    let kind = crate::study::kinds::present_named(kind)?;
    let mut f = Findings::default();
    for scene in scenes(runs) {
        let rows: Vec<&Vec<String>> = runs
            .rows
            .iter()
            .filter(|r| runs.get(r, "scene") == Some(&scene))
            .collect();
        let slug = slug(&scene);
        // Labels name what tells this scene's runs apart (issue 24: dt included).
        let params = distinguishing(runs, params, &rows);
        let of_scene = SceneRows {
            scene: &scene,
            slug: &slug,
            runs,
            params: &params,
            rows: &rows,
        };
        let how = damped.get(&scene);
        f.rankings
            .extend(kind.rankings(&of_scene, how.map(String::as_str)));
    }
    f.warnings.extend(kind.table_warnings(runs));
    // Per-run warnings, one list per kind; a long list is summarized (a suite has thousands of
    // runs: the column in runs.csv holds every case).
    let mut unscored = Vec::new();
    let mut unconverged = Vec::new();
    let mut inverted = Vec::new();
    let mut stopped = Vec::new();
    for r in &runs.rows {
        let id = &r[0];
        if kind.unscored(runs, r) {
            unscored.push((
                id.clone(),
                format!(
                    "`{id}`: its error is at the reference's noise floor (not scored): the \
                     reference is not accurate enough to measure it."
                ),
            ));
        }
        if let Some(n) = runs
            .number(r, "newton_unconverged_steps")
            .filter(|n| *n > 0.0)
        {
            unconverged.push((
                id.clone(),
                format!(
                    "`{id}`: Newton stopped unconverged at its cap ({} iterations, required: \
                     {}) in {n} steps.",
                    runs.get(r, "newton_max_iterations").unwrap_or("?"),
                    runs.get(r, "newton_required").unwrap_or("?"),
                ),
            ));
        }
        if let Some(n) = runs.number(r, "inverted_elements_max").filter(|n| *n > 0.0)
            && !kind.stopped_early(runs, r)
        {
            inverted.push((
                id.clone(),
                format!(
                    "`{id}`: up to {n} tets inverted (det F <= 0) in one state of a run that was \
                     not stopped for it (inverted_elements_max): its result is not a valid \
                     deformation there."
                ),
            ));
        }
        if kind.stopped_early(runs, r) {
            let outcome = runs.get(r, "outcome").unwrap_or_default();
            let at = runs
                .number(r, "final_time")
                .map(|t| format!(" (stopped at t = {} s)", short(t)))
                .unwrap_or_default();
            stopped.push((
                id.clone(),
                format!("`{id}`: did not reach its horizon: {outcome}{at}."),
            ));
        }
    }
    let groups = [
        (
            unscored,
            "their errors are at the reference's noise floor (not scored): the reference is \
             not accurate enough to measure them (`error_unscored`)",
        ),
        (
            unconverged,
            "Newton stopped unconverged at its cap in some steps (`newton_unconverged_steps`, \
             `newton_max_iterations`, `newton_required`)",
        ),
        (
            inverted,
            "tets inverted (det F <= 0) in a state of a run that was not stopped for it: the \
             result is not a valid deformation there (`inverted_elements_max`)",
        ),
        (
            stopped,
            "did not reach their horizon (`outcome`, `final_time`)",
        ),
    ];
    for (items, what) in groups {
        f.warnings.extend(summarized(items, what));
    }
    Some(f)
}

/// The findings with what loading the study warned about first (see `Study::warnings`):
/// they are about the set-up every number below comes from.
/// What the study left out, one line per method and reason with its scenes (a suite lists
/// them on its own page, `omissions.md`).
fn omissions_paragraph(out: &mut String, s: &crate::study::vocabulary::meta::StudyMeta) {
    if s.omitted.is_empty() || s.kind == "suite" {
        return;
    }
    let mut grouped: Vec<(String, &str, Vec<&str>)> = Vec::new();
    for o in &s.omitted {
        let method = o.method.clone().unwrap_or_else(|| "every method".into());
        match grouped
            .iter_mut()
            .find(|(m, r, _)| *m == method && *r == o.reason)
        {
            Some((_, _, scenes)) => scenes.push(&o.scene),
            None => grouped.push((method, &o.reason, vec![&o.scene])),
        }
    }
    let _ = writeln!(out, "Left out (not run, with why):\n");
    for (method, reason, scenes) in grouped {
        let on = scenes
            .iter()
            .filter(|s| !s.is_empty())
            .map(|s| format!("`{s}`"))
            .collect::<Vec<_>>();
        let _ = writeln!(
            out,
            "- `{method}`{}: {reason}",
            if on.is_empty() {
                String::new()
            } else {
                format!(" on {}", on.join(", "))
            }
        );
    }
    let _ = writeln!(out);
}

fn with_load_warnings(
    mut f: Findings,
    study: &crate::study::vocabulary::meta::StudyMeta,
) -> Findings {
    f.warnings.splice(0..0, study.warnings.iter().cloned());
    f
}

/// Runs listed one warning each, or, past [`WARNINGS_LISTED`] of one kind, one warning that
/// counts them, names the first few and says which column of `runs.csv` holds every case.
fn summarized(items: Vec<(String, String)>, what: &str) -> Vec<String> {
    if items.len() <= WARNINGS_LISTED {
        return items.into_iter().map(|(_, w)| w).collect();
    }
    let first: Vec<String> = items
        .iter()
        .take(5)
        .map(|(id, _)| format!("`{id}`"))
        .collect();
    vec![format!(
        "{} runs: {what}; for example {}, and {} more (every case is in `runs.csv`).",
        items.len(),
        first.join(", "),
        items.len() - first.len()
    )]
}

/// Past this many runs with the same warning, the report counts them instead of listing them.
const WARNINGS_LISTED: usize = 12;

#[cfg(test)]
mod tests {
    use super::{replace_closing_sections, replace_findings};

    #[test]
    fn the_closing_sections_are_replaced_up_to_the_provenance() {
        let before = "# s\n\nStudy file `a`.\n\n## Plots\n\n### Old\n\n## Runs that did not \
                      finish cleanly\n\nNone.\n\n## How these results were made\n\n- x\n";
        assert_eq!(
            replace_closing_sections(before, "## Plots\n\nnew\n").unwrap(),
            "# s\n\nStudy file `a`.\n\n## Plots\n\nnew\n\n## How these results were made\n\n- x\n"
        );
        assert_eq!(replace_closing_sections("# s\n\nno plots\n", "x"), None);
    }

    #[test]
    fn findings_replace_the_old_section_or_go_before_the_study_paragraph() {
        let new = "## Findings\n\nnew\n\n";
        let with = "# s\n\n## Findings\n\nold\n\nWarnings:\n\n- w\n\nStudy file `a`.\n";
        assert_eq!(
            replace_findings(with, new),
            "# s\n\n## Findings\n\nnew\n\nStudy file `a`.\n"
        );
        let without = "# s\n\nStudy file `a`.\n\n## Runs\n";
        assert_eq!(
            replace_findings(without, new),
            "# s\n\n## Findings\n\nnew\n\nStudy file `a`.\n\n## Runs\n"
        );
    }
}
