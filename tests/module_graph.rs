//! Module dependencies point one way. Between the crates of the workspace Cargo holds it
//! (softbench-core <- softbench-run <- softbench-study <- softbench, each crate depending only on
//! those before it); inside each crate this test holds it: no file of a folder reaches, through
//! the modules it names, a file that names it back, and no top-level module of a crate does
//! that with another (`a/` -> `b/` -> `a/`). DESIGN.md promises both.
//!
//! The test reads each crate's source text, drops comments, string literals and
//! `#[cfg(test)]` items, and collects every path that starts with `super`, `self` or `crate`
//! (with `use` groups such as `use super::{a, b::{c, d}}` expanded), plus `child::...` paths
//! in a file that declares `mod child;`. Each path is resolved against the file's module (and
//! any inline `mod x { .. }` it sits in) to the longest module it names: that is an arrow from
//! the file's module to that module, except a module's re-exports of its own submodules
//! (`pub use child::X`: a table of contents, not a use). The top folder's `mod.rs` and
//! `lib.rs` are not nodes; `src/bin/` is not part of the library.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::path::{Path, PathBuf};

/// A module: its path in the crate (`["mesh", "read"]`).
type Module = Vec<String>;

/// One source file: its module, whether it is a folder's `mod.rs`, and its text.
struct Source {
    module: Module,
    is_mod_rs: bool,
    text: String,
    /// Where it is, for messages (`crates/core/src/mesh/read.rs`).
    shown: String,
}

/// An arrow between two modules, with where the first one names the second.
#[derive(Clone, Debug)]
struct Arrow {
    from: Module,
    to: Module,
    at: String,
}

/// The source folders of the workspace's crates, lowest floor first.
const CRATE_SOURCES: [&str; 4] = [
    "crates/core/src",
    "crates/run/src",
    "crates/study/src",
    "src",
];

#[test]
fn no_folder_of_a_crate_has_an_import_cycle_and_folders_point_one_way() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut failures = Vec::new();
    let mut files = 0;
    for crate_src in CRATE_SOURCES {
        let sources = read_tree(&root.join(crate_src), crate_src);
        files += sources.len();
        failures.extend(crate_failures(&sources, crate_src));
    }
    assert!(files > 200, "only {files} files under the crates' sources");
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn the_crates_depend_only_on_the_floors_below_them() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let floors = ["softbench-core", "softbench-run", "softbench-study"];
    for (i, dir) in ["crates/core", "crates/run", "crates/study"]
        .iter()
        .enumerate()
    {
        let manifest = std::fs::read_to_string(root.join(dir).join("Cargo.toml")).unwrap();
        let manifest: toml::Table = toml::from_str(&manifest).unwrap();
        let deps = manifest["dependencies"].as_table().unwrap();
        let named: Vec<&str> = floors
            .iter()
            .copied()
            .filter(|f| deps.contains_key(*f))
            .collect();
        assert_eq!(
            named,
            floors[..i],
            "{dir}/Cargo.toml names the floors {named:?}"
        );
    }
}

/// The cycles inside the folders of one crate and between its top-level modules.
fn crate_failures(sources: &[Source], crate_src: &str) -> Vec<String> {
    let arrows = arrows(sources);
    let mut failures = Vec::new();
    let folders: BTreeSet<String> = sources
        .iter()
        .filter(|s| s.is_mod_rs && s.module.len() == 1)
        .map(|s| s.module[0].clone())
        .collect();
    for folder in &folders {
        let inside: Vec<Arrow> = arrows
            .iter()
            .filter(|a| a.from.len() > 1 && a.to.len() > 1)
            .filter(|a| a.from[0] == *folder && a.to[0] == *folder)
            .cloned()
            .collect();
        for cycle in cycles(&inside) {
            failures.push(format!("{crate_src}/{folder}/: {cycle}"));
        }
    }
    let top: Vec<Arrow> = arrows
        .iter()
        .filter(|a| a.from[0] != a.to[0])
        .map(|a| Arrow {
            from: vec![a.from[0].clone()],
            to: vec![a.to[0].clone()],
            at: a.at.clone(),
        })
        .collect();
    for cycle in cycles(&top) {
        failures.push(format!("between the modules of {crate_src}/: {cycle}"));
    }
    failures
}

#[test]
fn a_small_tree_with_a_cycle_fails_and_names_it() {
    let file = |path: &str, text: &str| (PathBuf::from(path), text.to_owned());
    let tree = [
        file("lib.rs", "pub mod shop;\npub mod util;\n"),
        file(
            "shop/mod.rs",
            "mod cart;\nmod ledger;\nmod price;\nmod tax;\nmod report;\npub use cart::Cart;\n",
        ),
        // A nested folder: its mod.rs re-exports a child (no arrow) and holds a helper the
        // child uses (an arrow up).
        file(
            "shop/ledger/mod.rs",
            "mod entry;\npub use entry::Entry;\npub(crate) fn helper() {}\n",
        ),
        file(
            "shop/ledger/entry.rs",
            "use super::helper;\npub struct Entry;\n",
        ),
        // cart -> price through a nested use group.
        file(
            "shop/cart.rs",
            "use super::{report::{self}, price::{Price, round}};\npub struct Cart;\n",
        ),
        // price -> tax through a path in an expression, and price -> util (another folder).
        file(
            "shop/price.rs",
            "pub fn round() -> f64 { crate::shop::tax::rate() * crate::util::half() }\n",
        ),
        // tax -> cart closes the cycle; what comments, strings and test code name does not
        // count.
        file(
            "shop/tax.rs",
            "// use super::report;\n/* super::report::x /* nested */ */\n\
             pub fn rate() -> f64 { let _ = \"super::report\"; let _ = r#\"crate::shop::report\"#;\n\
             let _c = 'x'; super::cart::Cart; 0.5 }\n\
             #[cfg(test)]\nmod tests { use super::super::report; }\n",
        ),
        // report is a leaf: `pub(super)` and an inline module's `super` name no sibling.
        file(
            "shop/report.rs",
            "pub(super) fn show() {}\nmod inner { fn f() { super::show(); } }\n",
        ),
        file("util/mod.rs", "mod half;\npub use half::half;\n"),
        // util -> shop (folder level): with shop -> util, a cycle between folders.
        file(
            "util/half.rs",
            "pub fn half() -> f64 { let _ = crate::shop::Cart; 0.5 }\n",
        ),
    ];
    let sources: Vec<Source> = tree
        .iter()
        .filter_map(|(path, text)| source(path, text.clone(), "src"))
        .collect();
    let arrows = arrows(&sources);
    let shop: Vec<Arrow> = arrows
        .iter()
        .filter(|a| a.from.len() > 1 && a.to.len() > 1)
        .filter(|a| a.from[0] == "shop" && a.to[0] == "shop")
        .cloned()
        .collect();
    let pairs: BTreeSet<(String, String)> = shop
        .iter()
        .map(|a| (a.from.join("::"), a.to.join("::")))
        .collect();
    let expected: BTreeSet<(String, String)> = [
        ("shop::cart", "shop::report"),
        ("shop::cart", "shop::price"),
        ("shop::price", "shop::tax"),
        ("shop::tax", "shop::cart"),
        ("shop::ledger::entry", "shop::ledger"),
    ]
    .iter()
    .map(|(a, b)| (a.to_string(), b.to_string()))
    .collect();
    assert_eq!(pairs, expected);
    let found = cycles(&shop);
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(
        found[0].contains("shop::cart -> shop::price -> shop::tax -> shop::cart"),
        "{}",
        found[0]
    );
    assert!(found[0].contains("shop/tax.rs:4"), "{}", found[0]);
    let top: Vec<Arrow> = arrows
        .iter()
        .filter(|a| a.from[0] != a.to[0])
        .map(|a| Arrow {
            from: vec![a.from[0].clone()],
            to: vec![a.to[0].clone()],
            at: a.at.clone(),
        })
        .collect();
    let found = cycles(&top);
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(found[0].contains("shop -> util -> shop"), "{}", found[0]);
    // Without the arrow back, no cycle.
    let acyclic: Vec<Arrow> = shop
        .into_iter()
        .filter(|a| a.from.join("::") != "shop::tax")
        .collect();
    assert!(cycles(&acyclic).is_empty());
}

/// Every `.rs` file under `src` except `src/bin/`, as [`Source`]s (`shown` under `name`).
fn read_tree(src: &Path, name: &str) -> Vec<Source> {
    let mut files = Vec::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                if path != src.join("bin") {
                    stack.push(path);
                }
            } else if path.extension().is_some_and(|e| e == "rs") {
                let text = std::fs::read_to_string(&path).unwrap();
                files.push((path.strip_prefix(src).unwrap().to_path_buf(), text));
            }
        }
    }
    files.sort();
    let test_only = test_only_files(&files);
    files
        .into_iter()
        .filter(|(path, _)| !test_only.contains(path))
        .filter_map(|(path, text)| source(&path, text, name))
        .collect()
}

/// The files declared by `#[cfg(test)] mod x;` (tests kept in their own file).
fn test_only_files(files: &[(PathBuf, String)]) -> BTreeSet<PathBuf> {
    let mut out = BTreeSet::new();
    for (path, text) in files {
        let dir = match path.file_name().and_then(|n| n.to_str()) {
            Some("mod.rs" | "lib.rs") => path.parent().unwrap().to_path_buf(),
            _ => path.with_extension(""),
        };
        for name in Cleaned::new(text).test_modules {
            out.insert(dir.join(format!("{name}.rs")));
            out.insert(dir.join(&name).join("mod.rs"));
        }
    }
    out
}

/// The [`Source`] of a file at `path` (relative to its crate's `src`, shown under `name`);
/// `None` for `lib.rs`.
fn source(path: &Path, text: String, name: &str) -> Option<Source> {
    let mut module: Module = path
        .with_extension("")
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    let is_mod_rs = module.last().is_some_and(|m| m == "mod");
    if is_mod_rs {
        module.pop();
    }
    if module == ["lib"] {
        return None;
    }
    Some(Source {
        module,
        is_mod_rs,
        text,
        shown: format!("{name}/{}", path.display()),
    })
}

/// Every arrow between distinct modules that the sources name.
fn arrows(sources: &[Source]) -> Vec<Arrow> {
    let known: BTreeSet<&Module> = sources.iter().map(|s| &s.module).collect();
    let mut out = Vec::new();
    for s in sources {
        let cleaned = Cleaned::new(&s.text);
        let mut seen = BTreeSet::new();
        for Named {
            line,
            path,
            reexport,
        } in paths(&cleaned.tokens, &s.module)
        {
            // The longest prefix that is a module; the crate root names no module.
            let target = (1..=path.len())
                .rev()
                .map(|k| path[..k].to_vec())
                .find(|m| known.contains(m));
            let Some(to) = target else { continue };
            // A module's re-exports of its own submodules are its table of contents (what a
            // folder's `mod.rs` is for), not a use of them.
            if to == s.module || reexport && to.starts_with(&s.module) {
                continue;
            }
            if seen.insert(to.clone()) {
                out.push(Arrow {
                    from: s.module.clone(),
                    to,
                    at: format!("{}:{line}", s.shown),
                });
            }
        }
    }
    out
}

/// A token of cleaned source: an identifier (or keyword, or number), `::`, or one
/// punctuation character, with its 1-based line.
#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Word(String),
    PathSep,
    Punct(char),
}

/// A file's tokens without comments, literals and `#[cfg(test)]` items, and the names of its
/// `#[cfg(test)] mod x;` declarations.
struct Cleaned {
    tokens: Vec<(usize, Tok)>,
    test_modules: Vec<String>,
}

impl Cleaned {
    fn new(text: &str) -> Cleaned {
        let all = tokenize(text);
        let mut tokens = Vec::with_capacity(all.len());
        let mut test_modules = Vec::new();
        let mut i = 0;
        if starts_with(&all, 0, &["#", "!", "[", "cfg", "(", "test", ")", "]"]) {
            return Cleaned {
                tokens,
                test_modules,
            };
        }
        while i < all.len() {
            if starts_with(&all, i, &["#", "[", "cfg", "(", "test", ")", "]"]) {
                i += 7;
                // Further attributes of the same item.
                while starts_with(&all, i, &["#", "["]) {
                    i = skip_group(&all, i + 1);
                }
                if starts_with(&all, i, &["mod"])
                    && matches!(all.get(i + 2), Some((_, Tok::Punct(';'))))
                    && let Some((_, Tok::Word(name))) = all.get(i + 1)
                {
                    test_modules.push(name.clone());
                }
                i = skip_item(&all, i);
                continue;
            }
            tokens.push(all[i].clone());
            i += 1;
        }
        Cleaned {
            tokens,
            test_modules,
        }
    }
}

/// Whether the tokens from `i` read `words` (`"::"` is one token).
fn starts_with(tokens: &[(usize, Tok)], i: usize, words: &[&str]) -> bool {
    words.iter().enumerate().all(|(k, w)| {
        tokens.get(i + k).is_some_and(|(_, t)| match t {
            Tok::Word(s) => s == w,
            Tok::PathSep => *w == "::",
            Tok::Punct(c) => w.len() == 1 && w.starts_with(*c),
        })
    })
}

/// The index after the bracket group opening at `i` (`(`, `[` or `{`).
fn skip_group(tokens: &[(usize, Tok)], i: usize) -> usize {
    let mut depth = 0usize;
    for (k, (_, t)) in tokens.iter().enumerate().skip(i) {
        match t {
            Tok::Punct('(' | '[' | '{') => depth += 1,
            Tok::Punct(')' | ']' | '}') => {
                depth = depth.saturating_sub(1);
                if depth == 0 {
                    return k + 1;
                }
            }
            _ => {}
        }
    }
    tokens.len()
}

/// The index after the item starting at `i`: its `;` at bracket depth 0, or its first
/// top-level `{ .. }` block.
fn skip_item(tokens: &[(usize, Tok)], mut i: usize) -> usize {
    while i < tokens.len() {
        match tokens[i].1 {
            Tok::Punct(';') => return i + 1,
            Tok::Punct('{') => return skip_group(tokens, i),
            Tok::Punct('(' | '[') => i = skip_group(tokens, i),
            _ => i += 1,
        }
    }
    i
}

/// Splits source text into tokens, dropping comments (nested block comments too), string,
/// byte-string, raw-string and character literals, and lifetimes.
fn tokenize(text: &str) -> Vec<(usize, Tok)> {
    let c: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let (mut i, mut line) = (0usize, 1usize);
    let ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    // Moves past a quoted literal whose opening quote is at `i`; counts its lines.
    let skip_quoted = |i: &mut usize, line: &mut usize, quote: char| {
        *i += 1;
        while *i < c.len() && c[*i] != quote {
            if c[*i] == '\\' {
                *i += 1;
            }
            if c.get(*i) == Some(&'\n') {
                *line += 1;
            }
            *i += 1;
        }
        *i += 1;
    };
    while i < c.len() {
        let ch = c[i];
        let next = c.get(i + 1).copied();
        if ch == '\n' {
            line += 1;
            i += 1;
        } else if ch.is_whitespace() {
            i += 1;
        } else if ch == '/' && next == Some('/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if ch == '/' && next == Some('*') {
            let mut depth = 0usize;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    if c[i] == '\n' {
                        line += 1;
                    }
                    i += 1;
                }
            }
        } else if ch == '"' {
            skip_quoted(&mut i, &mut line, '"');
        } else if ch == '\'' {
            // A character literal ('x', '\n', '\u{..}') or a lifetime ('a).
            if next == Some('\\') || c.get(i + 2) == Some(&'\'') {
                skip_quoted(&mut i, &mut line, '\'');
            } else {
                i += 1;
                while i < c.len() && ident(c[i]) {
                    i += 1;
                }
            }
        } else if ident(ch) {
            let start = i;
            while i < c.len() && ident(c[i]) {
                i += 1;
            }
            let word: String = c[start..i].iter().collect();
            let raw_string = matches!(word.as_str(), "r" | "br" | "cr")
                && matches!(c.get(i), Some('"' | '#'))
                && c[i..].iter().find(|&&x| x != '#') == Some(&'"');
            if raw_string {
                let hashes = c[i..].iter().take_while(|&&x| x == '#').count();
                i += hashes + 1;
                let close: Vec<char> = std::iter::once('"')
                    .chain(std::iter::repeat_n('#', hashes))
                    .collect();
                while i < c.len() && !c[i..].starts_with(&close) {
                    if c[i] == '\n' {
                        line += 1;
                    }
                    i += 1;
                }
                i += close.len();
            } else if matches!(word.as_str(), "b" | "c") && matches!(c.get(i), Some('"' | '\'')) {
                let quote = c[i];
                skip_quoted(&mut i, &mut line, quote);
            } else if word == "r" && c.get(i) == Some(&'#') {
                // A raw identifier: r#name.
                let start = i + 1;
                i = start;
                while i < c.len() && ident(c[i]) {
                    i += 1;
                }
                out.push((line, Tok::Word(c[start..i].iter().collect())));
            } else {
                out.push((line, Tok::Word(word)));
            }
        } else if ch == ':' && next == Some(':') {
            out.push((line, Tok::PathSep));
            i += 2;
        } else {
            out.push((line, Tok::Punct(ch)));
            i += 1;
        }
    }
    out
}

/// A path a file names: where, the absolute path, and whether it is re-exported (`pub use`).
struct Named {
    line: usize,
    path: Vec<String>,
    reexport: bool,
}

/// Every path the tokens name that starts with `super`, `self` or `crate` (or, in a `mod.rs`
/// or a file with `mod child;`, with a child module), resolved to an absolute module path
/// from `module`, with its line. `use` groups are expanded; visibilities (`pub(super)`) and
/// `$crate` are not paths.
fn paths(tokens: &[(usize, Tok)], module: &Module) -> Vec<Named> {
    let children: BTreeSet<&str> = tokens
        .windows(3)
        .filter_map(|w| match (&w[0].1, &w[1].1, &w[2].1) {
            (Tok::Word(m), Tok::Word(name), Tok::Punct(';')) if m == "mod" => Some(name.as_str()),
            _ => None,
        })
        .collect();
    let mut out = Vec::new();
    // Inline modules: (name, brace depth at which it closes).
    let mut inline: Vec<(String, usize)> = Vec::new();
    let mut depth = 0usize;
    // Inside a `pub use`.
    let mut reexport = false;
    let mut i = 0;
    while i < tokens.len() {
        let (line, tok) = &tokens[i];
        let prev = i.checked_sub(1).map(|k| &tokens[k].1);
        match tok {
            Tok::Punct('{') => {
                depth += 1;
                i += 1;
                continue;
            }
            Tok::Punct('}') => {
                depth = depth.saturating_sub(1);
                if inline.last().is_some_and(|(_, d)| *d == depth) {
                    inline.pop();
                }
                i += 1;
                continue;
            }
            Tok::Word(w) if w == "mod" => {
                if let (Some((_, Tok::Word(name))), Some((_, Tok::Punct('{')))) =
                    (tokens.get(i + 1), tokens.get(i + 2))
                {
                    inline.push((name.clone(), depth));
                    depth += 1;
                    i += 3;
                    continue;
                }
            }
            Tok::Word(w) if w == "pub" => {
                // Skip a visibility's path (`pub(super)`); note a re-export.
                let mut j = i + 1;
                if matches!(tokens.get(j), Some((_, Tok::Punct('(')))) {
                    j = skip_group(tokens, j);
                }
                reexport = matches!(tokens.get(j), Some((_, Tok::Word(u))) if u == "use");
                i = j;
                continue;
            }
            Tok::Punct(';') => reexport = false,
            _ => {}
        }
        let starts_path = !matches!(prev, Some(Tok::PathSep) | Some(Tok::Punct('$')));
        let Tok::Word(word) = tok else {
            i += 1;
            continue;
        };
        // The module the path is written in (a `mod.rs` is its folder's module).
        let here: Module = module
            .iter()
            .cloned()
            .chain(inline.iter().map(|(n, _)| n.clone()))
            .collect();
        let is_root = matches!(word.as_str(), "super" | "self" | "crate");
        let is_child = children.contains(word.as_str())
            && matches!(tokens.get(i + 1), Some((_, Tok::PathSep)))
            && inline.is_empty();
        if !starts_path || !(is_root || is_child) {
            i += 1;
            continue;
        }
        let (next, trees) = use_tree(tokens, i);
        for segments in trees {
            if let Some(path) = resolve(&here, &segments) {
                out.push(Named {
                    line: *line,
                    path,
                    reexport,
                });
            }
        }
        i = next.max(i + 1);
    }
    out
}

/// The paths of the use tree (or plain path) starting at `i`, as lists of segments, and the
/// index after it.
fn use_tree(tokens: &[(usize, Tok)], mut i: usize) -> (usize, Vec<Vec<String>>) {
    let mut prefix = Vec::new();
    loop {
        match tokens.get(i).map(|t| &t.1) {
            Some(Tok::Word(w)) => {
                prefix.push(w.clone());
                i += 1;
            }
            Some(Tok::Punct('*')) => return (i + 1, vec![prefix]),
            Some(Tok::Punct('{')) => {
                let mut out = Vec::new();
                i += 1;
                loop {
                    match tokens.get(i).map(|t| &t.1) {
                        None => return (i, out),
                        Some(Tok::Punct('}')) => return (i + 1, out),
                        Some(Tok::Punct(',')) => i += 1,
                        _ => {
                            let (next, trees) = use_tree(tokens, i);
                            for tail in trees {
                                let mut path = prefix.clone();
                                // `{self, ..}` names the prefix itself.
                                if tail != ["self"] {
                                    path.extend(tail);
                                }
                                out.push(path);
                            }
                            i = next.max(i + 1);
                        }
                    }
                }
            }
            _ => return (i, vec![prefix]),
        }
        if matches!(tokens.get(i).map(|t| &t.1), Some(Tok::PathSep)) {
            i += 1;
        } else {
            // `as name` or the end of the path.
            if matches!(tokens.get(i).map(|t| &t.1), Some(Tok::Word(w)) if w == "as") {
                i += 2;
            }
            return (i, vec![prefix]);
        }
    }
}

/// The absolute path that `segments` (starting with `super`, `self`, `crate` or a child
/// module) names from the module `here`; `None` when it climbs above the crate.
fn resolve(here: &Module, segments: &[String]) -> Option<Vec<String>> {
    let mut base: Vec<String>;
    let mut rest = segments;
    match segments.first().map(String::as_str) {
        Some("crate") => {
            base = Vec::new();
            rest = &segments[1..];
        }
        Some("self") => {
            base = here.clone();
            rest = &segments[1..];
        }
        Some("super") => {
            base = here.clone();
            while rest.first().is_some_and(|s| s == "super") {
                base.pop()?;
                rest = &rest[1..];
            }
        }
        _ => base = here.clone(),
    }
    base.extend(rest.iter().filter(|s| *s != "self").cloned());
    Some(base)
}

/// The import cycles among the arrows: for each strongly connected set of two or more
/// modules, its members, one shortest cycle through its first member with where each arrow
/// is named, and how many arrows it has inside.
fn cycles(arrows: &[Arrow]) -> Vec<String> {
    let mut graph: BTreeMap<String, BTreeMap<String, String>> = BTreeMap::new();
    for a in arrows {
        let (from, to) = (a.from.join("::"), a.to.join("::"));
        graph.entry(to.clone()).or_default();
        graph
            .entry(from)
            .or_default()
            .entry(to)
            .or_insert_with(|| a.at.clone());
    }
    let mut out = Vec::new();
    for component in strongly_connected(&graph) {
        if component.len() < 2 {
            continue;
        }
        let inside: BTreeSet<&String> = component.iter().collect();
        let start = &component[0];
        let cycle = shortest_cycle(&graph, start, &inside);
        let mut steps = vec![start.clone()];
        let mut wheres = Vec::new();
        for pair in cycle.windows(2) {
            steps.push(pair[1].clone());
            wheres.push(format!(
                "{} -> {} at {}",
                pair[0], pair[1], graph[&pair[0]][&pair[1]]
            ));
        }
        let arrows_inside = component
            .iter()
            .map(|m| graph[m].keys().filter(|t| inside.contains(t)).count())
            .sum::<usize>();
        out.push(format!(
            "a cycle of {} modules ({arrows_inside} arrows among them): {}\n  e.g. {}\n    {}",
            component.len(),
            component.join(", "),
            steps.join(" -> "),
            wheres.join("\n    ")
        ));
    }
    out
}

/// Tarjan's strongly connected components, each sorted, in a deterministic order.
fn strongly_connected(graph: &BTreeMap<String, BTreeMap<String, String>>) -> Vec<Vec<String>> {
    struct State<'a> {
        graph: &'a BTreeMap<String, BTreeMap<String, String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on_stack: BTreeSet<&'a str>,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(s: &mut State<'a>, v: &'a str) {
        let n = s.index.len();
        s.index.insert(v, n);
        s.low.insert(v, n);
        s.stack.push(v);
        s.on_stack.insert(v);
        for w in s.graph[v].keys() {
            if !s.index.contains_key(w.as_str()) {
                visit(s, w);
                let low = s.low[v].min(s.low[w.as_str()]);
                s.low.insert(v, low);
            } else if s.on_stack.contains(w.as_str()) {
                let low = s.low[v].min(s.index[w.as_str()]);
                s.low.insert(v, low);
            }
        }
        if s.low[v] == s.index[v] {
            let mut component = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on_stack.remove(w);
                component.push(w.to_owned());
                if w == v {
                    break;
                }
            }
            component.sort();
            s.out.push(component);
        }
    }
    let mut s = State {
        graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in graph.keys() {
        if !s.index.contains_key(v.as_str()) {
            visit(&mut s, v);
        }
    }
    s.out.sort();
    s.out
}

/// A shortest path `start -> .. -> start` within `inside` (breadth first).
fn shortest_cycle(
    graph: &BTreeMap<String, BTreeMap<String, String>>,
    start: &String,
    inside: &BTreeSet<&String>,
) -> Vec<String> {
    let mut previous: BTreeMap<&String, &String> = BTreeMap::new();
    let mut queue = VecDeque::from([start]);
    while let Some(v) = queue.pop_front() {
        for w in graph[v].keys().filter(|w| inside.contains(w)) {
            if w == start {
                let mut path = vec![start.clone(), v.clone()];
                let mut at = v;
                while at != start {
                    at = previous[at];
                    path.push(at.clone());
                }
                path.reverse();
                return path;
            }
            if !previous.contains_key(w) {
                previous.insert(w, v);
                queue.push_back(w);
            }
        }
    }
    vec![start.clone()]
}
