//! The documentation against the code: every TOML example in README.md and docs/ parses (and,
//! where it needs no data, builds) as the scene or study its marker says it is; the tables of
//! methods, linear solvers, materials, contact responses and obstacle kinds list exactly the
//! registered names; every relative link and its `#anchor` resolve.
//!
//! Markers are HTML comments on the line before what they mark, invisible in a rendered page:
//! `<!-- toml: KIND -->` before a ```` ```toml ```` fence, where KIND is `scene`,
//! `scene-fragment` (merged into a minimal valid scene), `study` or `study-fragment` (merged
//! into a minimal valid study); `<!-- table: NAME -->` before a table whose first column names
//! the registered entries in backticks.

mod common;

use common::TempDir;
use softbench::contact::{ContactResponse, ObstacleKind};
use softbench::data::DataPaths;
use softbench::integrate::acceleration::Acceleration;
use softbench::integrate::vbd::VbdSweep;
use softbench::integrate::{HessianFilter, Method};
use softbench::material::MaterialKind;
use softbench::parallel::Parallelism;
use softbench::scene::{self, LoadedScene, SceneConfig};
use softbench::solve::LinearSolverKind;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The pages whose TOML examples and tables are checked: README.md and docs/*.md.
fn pages() -> Vec<PathBuf> {
    let mut pages = vec![root().join("README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root().join("docs"))
        .expect("docs/ exists")
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    assert!(docs.len() >= 10, "docs/ has too few chapters: {docs:?}");
    pages.extend(docs);
    pages
}

/// The pages whose links are checked: the pages above, DESIGN.md and the results' READMEs.
fn linked_pages() -> Vec<PathBuf> {
    let mut all = pages();
    for extra in [
        "DESIGN.md",
        "results/README.md",
        "results/cholmod/README.md",
    ] {
        all.push(root().join(extra));
    }
    all
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn relative(path: &Path) -> String {
    path.strip_prefix(root())
        .unwrap_or(path)
        .display()
        .to_string()
}

/// A fenced code block.
struct Fence {
    /// 1-based line of the opening fence.
    line: usize,
    /// The info string's first word (`toml`, `sh`, ...).
    lang: String,
    /// The contents, with the fence's indentation removed.
    text: String,
    /// The `KIND` of a `<!-- toml: KIND -->` marker on the line before, if any.
    marker: Option<String>,
}

/// The argument of `<!-- NAME: ARG -->` if `line` is such a marker.
fn marker<'a>(line: &'a str, name: &str) -> Option<&'a str> {
    let rest = line
        .trim()
        .strip_prefix("<!--")?
        .strip_suffix("-->")?
        .trim();
    let rest = rest.strip_prefix(name)?.strip_prefix(':')?;
    Some(rest.trim())
}

/// Every fenced code block of `text`, and the lines outside them (`None` inside a fence).
fn fences(text: &str) -> (Vec<Fence>, Vec<Option<&str>>) {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    let mut prose = Vec::with_capacity(lines.len());
    let mut i = 0;
    while i < lines.len() {
        let trimmed = lines[i].trim_start();
        if !trimmed.starts_with("```") {
            prose.push(Some(lines[i]));
            i += 1;
            continue;
        }
        let indent = lines[i].len() - trimmed.len();
        let lang = trimmed[3..]
            .split(|c: char| c == ',' || c.is_whitespace())
            .next()
            .unwrap_or("")
            .to_string();
        let marker = i
            .checked_sub(1)
            .and_then(|p| marker(lines[p], "toml"))
            .map(str::to_string);
        let start = i;
        prose.push(None);
        i += 1;
        let mut body = String::new();
        while i < lines.len() && !lines[i].trim_start().starts_with("```") {
            let l = lines[i];
            let cut = l.len() - l.trim_start().len();
            body.push_str(&l[cut.min(indent)..]);
            body.push('\n');
            prose.push(None);
            i += 1;
        }
        assert!(i < lines.len(), "line {}: unclosed code fence", start + 1);
        prose.push(None);
        i += 1;
        out.push(Fence {
            line: start + 1,
            lang,
            text: body,
            marker,
        });
    }
    (out, prose)
}

/// A scene that needs no data: the examples' fragments are merged into it.
const BASE_SCENE: &str = r#"
[mesh]
generate = { box = [2, 1, 1], size = [1.0, 0.5, 0.5] }
[material]
model = "stable-neo-hookean"
youngs_modulus = 1e5
poisson_ratio = 0.3
density = 1000.0
mass = "lumped"
[fixed]
rule = { axis = "x", side = "min", tolerance = 1e-6 }
[forces]
gravity = [0.0, -9.81, 0.0]
[integrator]
method = "backward-euler"
[run]
dt = 0.01
steps = 2
"#;

/// A study of the soft beam that the study fragments are merged into.
const BASE_STUDY: &str = r#"
name = "docs_fragment"
study = "trajectory"
scenes = ["scenes/soft_beam.toml"]
"#;

/// Merges `from` into `into`: tables key by key, arrays of tables appended, anything else
/// replaced.
fn merge(into: &mut toml::Table, from: toml::Table) {
    for (key, value) in from {
        match (into.get_mut(&key), value) {
            (Some(toml::Value::Table(a)), toml::Value::Table(b)) => merge(a, b),
            (Some(toml::Value::Array(a)), toml::Value::Array(b))
                if b.iter().all(toml::Value::is_table) =>
            {
                a.extend(b)
            }
            (_, value) => {
                into.insert(key, value);
            }
        }
    }
}

fn toml_table(text: &str, what: &str) -> toml::Table {
    toml::from_str(text).unwrap_or_else(|e| panic!("{what}: not TOML: {e}"))
}

/// Parses, validates and, when it needs no data file, builds a scene.
fn check_scene(config: Result<SceneConfig, scene::SceneError>, what: &str) {
    let config = config.unwrap_or_else(|e| panic!("{what}: not a valid scene: {e}"));
    let needs_files = config.mesh.as_ref().is_some_and(|m| m.file.is_some())
        || config.display.is_some()
        || config.initial.from.is_some()
        || config.obstacles.iter().any(|o| o.file.is_some());
    if needs_files {
        return;
    }
    let loaded = LoadedScene {
        path: root().join("docs/example.toml"),
        config,
    };
    if let Err(e) = scene::build(&loaded, &DataPaths::new(None), Parallelism::Sequential) {
        panic!("{what}: the scene does not build: {e}");
    }
}

/// A folder holding a copy of `experiments/scenes/` and `experiments/problems/`, where study
/// examples are loaded.
fn study_folder() -> TempDir {
    let tmp = TempDir::new("docs-study");
    for folder in ["scenes", "problems"] {
        copy_folder(
            &root().join("experiments").join(folder),
            &tmp.path().join(folder),
        );
    }
    tmp
}

/// Copy `from` into `to`, subfolders included.
fn copy_folder(from: &std::path::Path, to: &std::path::Path) {
    std::fs::create_dir(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let path = entry.unwrap().path();
        let target = to.join(path.file_name().unwrap());
        if path.is_dir() {
            copy_folder(&path, &target);
        } else {
            std::fs::copy(&path, target).unwrap();
        }
    }
}

fn check_study(text: &str, what: &str) {
    let tmp = study_folder();
    let path = tmp.write("study.toml", text);
    if let Err(e) = softbench::study::load(&path, false, &DataPaths::from_env()) {
        panic!("{what}: not a valid study: {e}");
    }
}

/// Checks one marked TOML example; returns its kind.
fn check_example(fence: &Fence, what: &str) -> String {
    let kind = fence.marker.clone().unwrap_or_else(|| {
        panic!("{what}: a ```toml example needs a `<!-- toml: KIND -->` line before it")
    });
    match kind.as_str() {
        "scene" => check_scene(
            scene::parse(&fence.text, Path::new(what), &[]),
            &format!("{what} (scene)"),
        ),
        "scene-fragment" => {
            let fragment = toml_table(&fence.text, what);
            let mut table = toml_table(BASE_SCENE, "the base scene");
            if fragment.contains_key("jello") {
                // A jello body replaces the mesh and has no elastic material.
                table.remove("mesh");
                table.remove("material");
            }
            merge(&mut table, fragment);
            check_scene(
                scene::from_table(table, None, Path::new(what)),
                &format!("{what} (scene fragment)"),
            );
        }
        "study" => check_study(&fence.text, &format!("{what} (study)")),
        "study-fragment" => {
            let fragment = toml_table(&fence.text, what);
            let mut table = toml_table(BASE_STUDY, "the base study");
            merge(&mut table, fragment);
            if !table.contains_key("grid") && !table.contains_key("methods") {
                let grid = toml_table(
                    "\"integrator.method\" = [\"backward-euler\"]",
                    "the base grid",
                );
                table.insert("grid".into(), toml::Value::Table(grid));
            }
            check_study(&table.to_string(), &format!("{what} (study fragment)"));
        }
        "claim" => {
            let tmp = TempDir::new("docs-claim");
            let path = tmp.write("claim.toml", &fence.text);
            if let Err(e) = softbench::ledger::Claim::read(&path) {
                panic!("{what}: not a valid claim: {e}");
            }
        }
        other => panic!(
            "{what}: unknown example kind `{other}` (scene, scene-fragment, study, \
             study-fragment, claim)"
        ),
    }
    kind
}

#[test]
fn every_toml_example_is_the_scene_or_study_its_marker_says() {
    let mut kinds: BTreeMap<String, usize> = BTreeMap::new();
    for page in pages() {
        let text = read(&page);
        let (fences, prose) = fences(&text);
        for fence in fences.iter().filter(|f| f.lang == "toml") {
            let what = format!("{}:{}", relative(&page), fence.line);
            *kinds.entry(check_example(fence, &what)).or_default() += 1;
        }
        // A marker must mark a TOML example: one before anything else is a typo.
        for (i, line) in prose.iter().enumerate() {
            if let Some(kind) = line.and_then(|l| marker(l, "toml")) {
                assert!(
                    fences.iter().any(|f| f.line == i + 2 && f.lang == "toml"),
                    "{}:{}: `toml: {kind}` marks no ```toml fence on the next line",
                    relative(&page),
                    i + 1
                );
            }
        }
    }
    for kind in ["scene", "scene-fragment", "study", "study-fragment"] {
        assert!(
            kinds.get(kind).is_some_and(|&n| n > 0),
            "no example of kind {kind} was checked: {kinds:?}"
        );
    }
}

#[test]
fn an_example_with_an_unknown_key_or_a_bad_value_fails_the_check() {
    let fence = |marker: &str, text: &str| Fence {
        line: 1,
        lang: "toml".into(),
        text: text.into(),
        marker: Some(marker.into()),
    };
    let bad = [
        fence(
            "scene-fragment",
            "[damping]\nrayleigh = { alpha = 0.1, betta = 1e-3 }\n",
        ),
        fence("scene-fragment", "[run]\ndt = -0.01\n"),
        fence("scene-fragment", "[integrator]\nmethod = \"rk5\"\n"),
        fence(
            "scene-fragment",
            "[material]\nmodel = \"xpbd-neo-hookean\"\n[integrator]\nmethod = \"projective-dynamics\"\n",
        ),
        fence(
            "study-fragment",
            "[[methods]]\nmethod = \"backward-euler\"\n\"integrator.linear_solvr\" = [\"cg\"]\n",
        ),
        fence(
            "study",
            "name = \"x\"\nstudy = \"trajectory\"\nscenes = [\"scenes/soft_beam.toml\"]\nbogus = 1\n",
        ),
    ];
    for (i, f) in bad.iter().enumerate() {
        let caught = std::panic::catch_unwind(|| check_example(f, &format!("bad example {i}")));
        assert!(caught.is_err(), "bad example {i} passed:\n{}", f.text);
    }
}

/// The backticked names in the first column of the table after `<!-- table: NAME -->`.
fn tables() -> BTreeMap<String, Vec<(String, Vec<String>)>> {
    let mut found: BTreeMap<String, Vec<(String, Vec<String>)>> = BTreeMap::new();
    for page in pages() {
        let text = read(&page);
        let (_, prose) = fences(&text);
        for (i, line) in prose.iter().enumerate() {
            let Some(name) = line.and_then(|l| marker(l, "table")) else {
                continue;
            };
            let rows: Vec<&str> = prose[i + 1..]
                .iter()
                .map_while(|l| l.filter(|l| l.trim_start().starts_with('|')))
                .collect();
            let where_ = format!("{}:{}", relative(&page), i + 1);
            assert!(
                rows.len() > 2 && rows[1].contains("---"),
                "{where_}: `table: {name}` is not followed by a table"
            );
            let names = rows[2..]
                .iter()
                .map(|row| {
                    let cell = row
                        .trim()
                        .trim_start_matches('|')
                        .split('|')
                        .next()
                        .unwrap();
                    let cell = cell.trim();
                    assert!(
                        cell.starts_with('`') && cell.ends_with('`') && cell.len() > 2,
                        "{where_}: first cell `{cell}` is not one name in backticks"
                    );
                    cell.trim_matches('`').to_string()
                })
                .collect();
            found
                .entry(name.to_string())
                .or_default()
                .push((where_, names));
        }
    }
    found
}

#[test]
fn the_registry_tables_list_exactly_the_registered_names() {
    let kinds: Vec<&str> = softbench::study::kinds().iter().map(|k| k.name).collect();
    use softbench::integrate::newton::{Criterion, Direction, Globalization, LbfgsInitial};
    let registered: [(&str, Vec<&str>); 14] = [
        ("study-kinds", kinds),
        ("methods", Method::names()),
        ("linear-solvers", LinearSolverKind::names()),
        ("materials", MaterialKind::names()),
        ("contact-responses", ContactResponse::names()),
        ("obstacle-kinds", ObstacleKind::names()),
        ("hessian-filters", HessianFilter::names()),
        ("newton-directions", Direction::names()),
        ("newton-globalizations", Globalization::names()),
        ("newton-criteria", Criterion::names()),
        ("lbfgs-initials", LbfgsInitial::names()),
        ("accelerations", Acceleration::names()),
        ("vbd-sweeps", VbdSweep::names()),
        ("controllers", softbench::integrate::Controller::names()),
    ];
    let found = tables();
    for (name, names) in &registered {
        let want: BTreeSet<&str> = names.iter().copied().collect();
        assert_eq!(
            want.len(),
            names.len(),
            "{name}: duplicate registered names"
        );
        let tables = found
            .get(*name)
            .unwrap_or_else(|| panic!("no `<!-- table: {name} -->` in docs/"));
        for (where_, listed) in tables {
            let got: BTreeSet<&str> = listed.iter().map(String::as_str).collect();
            assert_eq!(got.len(), listed.len(), "{where_}: a name is listed twice");
            let missing: Vec<_> = want.difference(&got).collect();
            let unknown: Vec<_> = got.difference(&want).collect();
            assert!(
                missing.is_empty() && unknown.is_empty(),
                "{where_}: the {name} table misses {missing:?} and lists unregistered {unknown:?}"
            );
        }
    }
    for name in found.keys() {
        assert!(
            registered.iter().any(|(r, _)| r == name),
            "`table: {name}` names no registry"
        );
    }
}

/// GitHub's (and mdBook's) anchor of a heading: lowercase; letters, digits, `-` and `_` kept;
/// spaces become `-`; everything else dropped.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .flat_map(char::to_lowercase)
        .collect()
}

/// The anchors of a Markdown file's headings.
fn anchors(text: &str) -> BTreeSet<String> {
    let (_, prose) = fences(text);
    prose
        .iter()
        .flatten()
        .filter_map(|l| {
            let hashes = l.len() - l.trim_start_matches('#').len();
            (1..=6)
                .contains(&hashes)
                .then(|| &l[hashes..])
                .filter(|rest| rest.starts_with(' '))
        })
        .map(slug)
        .collect()
}

/// The link targets of a line of prose (inline code removed): `[text](target)`.
fn link_targets(line: &str) -> Vec<String> {
    let mut prose = String::new();
    for (i, part) in line.split('`').enumerate() {
        if i % 2 == 0 {
            prose.push_str(part);
        }
    }
    let mut targets = Vec::new();
    let mut rest = prose.as_str();
    while let Some(at) = rest.find("](") {
        let after = &rest[at + 2..];
        let end = after.find(')').unwrap_or(after.len());
        let target = after[..end].split_whitespace().next().unwrap_or("");
        targets.push(target.to_string());
        rest = &after[end..];
    }
    targets
}

#[test]
fn every_relative_link_resolves() {
    let mut checked = 0;
    for page in linked_pages() {
        let text = read(&page);
        let (_, prose) = fences(&text);
        for (i, line) in prose.iter().enumerate() {
            let Some(line) = line else { continue };
            for target in link_targets(line) {
                let where_ = format!("{}:{}", relative(&page), i + 1);
                if target.contains("://") || target.starts_with("mailto:") {
                    continue;
                }
                let (file, anchor) = match target.split_once('#') {
                    Some((f, a)) => (f, Some(a)),
                    None => (target.as_str(), None),
                };
                let path = if file.is_empty() {
                    page.clone()
                } else {
                    page.parent().unwrap().join(file)
                };
                assert!(
                    path.exists(),
                    "{where_}: link `{target}`: {} does not exist",
                    path.display()
                );
                if let Some(anchor) = anchor.filter(|_| path.extension().is_some_and(|e| e == "md"))
                {
                    assert!(
                        anchors(&read(&path)).contains(anchor),
                        "{where_}: link `{target}`: no heading of {} has the anchor `{anchor}`",
                        relative(&path)
                    );
                }
                checked += 1;
            }
        }
    }
    assert!(
        checked > 50,
        "only {checked} links found: is the parser broken?"
    );
}

#[test]
fn the_link_checker_sees_links_and_anchors() {
    assert_eq!(
        link_targets("see [a](b.md#c) and `[not](x)` and ![img](d.png \"title\")"),
        ["b.md#c", "d.png"]
    );
    assert_eq!(
        slug("step_49k — the 49k-tet box's step, one and two threads"),
        "step_49k--the-49k-tet-boxs-step-one-and-two-threads"
    );
    assert_eq!(
        slug("Pictures (`--render`, `softbench render`)"),
        "pictures---render-softbench-render"
    );
    let page = "# Title\n\n```sh\n# not a heading\n```\n## Two words\n";
    let got = anchors(page);
    assert!(got.contains("title") && got.contains("two-words") && got.len() == 2);
}

/// DESIGN.md's "Where things are" section: the index of the modules.
fn design_layout() -> String {
    let text = read(&root().join("DESIGN.md"));
    let start = text
        .find("\n## Where things are")
        .expect("DESIGN.md has a \"Where things are\" section");
    let end = text[start + 1..]
        .find("\n## ")
        .map_or(text.len(), |e| start + 1 + e);
    text[start..end].to_string()
}

/// Whether `word` occurs in `text` with no identifier character on either side.
fn has_word(text: &str, word: &str) -> bool {
    let ident = |c: char| c.is_alphanumeric() || c == '_';
    text.match_indices(word).any(|(at, _)| {
        !text[..at].chars().next_back().is_some_and(ident)
            && !text[at + word.len()..].chars().next().is_some_and(ident)
    })
}

#[test]
fn design_md_names_every_module_of_the_crate() {
    let layout = design_layout();
    let mut missing = Vec::new();
    let mut stack: Vec<PathBuf> = [
        "crates/core/src",
        "crates/run/src",
        "crates/study/src",
        "src",
    ]
    .iter()
    .map(|src| root().join(src))
    .collect();
    let mut files = 0;
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().to_string();
            if path.is_dir() {
                if !layout.contains(&format!("{name}/")) {
                    missing.push(relative(&path) + "/");
                }
                stack.push(path);
            } else if let Some(stem) = name.strip_suffix(".rs") {
                files += 1;
                if stem != "mod" && !has_word(&layout, stem) {
                    missing.push(relative(&path));
                }
            }
        }
    }
    assert!(files > 100, "only {files} source files found");
    assert!(
        missing.is_empty(),
        "DESIGN.md's \"Where things are\" section does not name {missing:?}: add each to the index"
    );
}
