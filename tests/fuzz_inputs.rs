//! A seeded mutation fuzzer over every input softbench parses: the four mesh readers (MEDIT
//! `.mesh`, TetGen `.node`/`.ele`, plain v/t `.mesh`, OBJ), scene files (parsed, validated and
//! built) and study files (loaded: grid expanded, every scene checked and built).
//!
//! Each case takes a valid seed file, applies a few random mutations (bytes flipped, tokens
//! replaced by hostile ones such as `18446744073709551615`, `nan`, `1e308` or `-1`, lines
//! duplicated, dropped or cut) and asserts: no panic (`catch_unwind`), an error that names the
//! file, and bounded time and memory — by size budgets lowered for the run (see
//! `softbench::limits`), a generous per-case sanity cap, and the process's peak memory at the
//! end.
//!
//! CI runs a few thousand cases in seconds. For a long run:
//!
//! ```text
//! SOFTBENCH_FUZZ_CASES=1000000 SOFTBENCH_FUZZ_SEED=7 cargo test --release --test fuzz_inputs -- --nocapture
//! ```

use softbench::data::DataPaths;
use softbench::mesh::{MeshReport, medit, obj, plain, tetgen};
use softbench::parallel::Parallelism;
use softbench::rng::Rng;
use softbench::scene;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Cases per target in CI (the study target runs a quarter of them: each builds scenes).
const DEFAULT_CASES: u64 = 1500;
/// A case that takes longer than this is a hang, whatever the machine.
const CASE_CAP: Duration = Duration::from_secs(20);

const MEDIT: &str = "MeshVersionFormatted 1\nDimension 3\nVertices\n5\n0 0 0 0\n1 0 0 0\n0 1 0 0\n\
0 0 1 0\n1 1 1 0\nTetrahedra\n2\n1 2 3 4 0\n2 3 4 5 0\nTriangles\n1\n1 2 3 0\nEnd\n";
const PLAIN: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 1 1 1\nt 0 1 2 3\nt 1 2 3 4\n";
const NODE: &str = "5 3 1 1\n0 0 0 0 0.5 1\n1 1 0 0 0.5 0\n2 0 1 0 0.5 0\n3 0 0 1 0.5 1\n\
4 1 1 1 0.5 0\n# comment\n";
const ELE: &str = "2 4 1\n0 0 1 2 3 7\n1 1 2 3 4 7\n";
const OBJ: &str = "# a tet's surface\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvn 0 0 1\nvt 0 0\n\
f 1 3 2\nf 1/1 2/1 4/1\nf 2//1 3//1 4//1\nf -4 -1 -2\n";

/// Tokens that have broken parsers before.
const HOSTILE: &[&str] = &[
    "0",
    "1",
    "-1",
    "4",
    "10",
    "18446744073709551615",
    "18446744073709551614",
    "9223372036854775807",
    "-9223372036854775808",
    "999999999999",
    "1e308",
    "-1e308",
    "1e-300",
    "nan",
    "inf",
    "-inf",
    "0.0",
    "1e160",
    "3000",
    "100000",
    "\"\"",
    "\"..\"",
    "\".\"",
    "\"/\"",
    "[]",
    "{}",
    "[1000, 1000, 1000]",
    "Vertices",
    "Tetrahedra",
    "Triangles",
    "End",
    "v",
    "t",
    "f",
    "#",
    "/",
    "//",
    "=",
    "[",
    "]",
    "\n",
    "\u{0}",
    "\u{feff}",
    "é",
];

fn cases() -> u64 {
    std::env::var("SOFTBENCH_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(DEFAULT_CASES)
}

fn seed() -> u64 {
    std::env::var("SOFTBENCH_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(13)
}

fn below(rng: &mut Rng, n: usize) -> usize {
    (rng.next_u64() % n.max(1) as u64) as usize
}

/// A char boundary at or before `i`.
fn boundary(s: &str, mut i: usize) -> usize {
    i = i.min(s.len());
    while !s.is_char_boundary(i) {
        i -= 1;
    }
    i
}

/// Byte ranges of the whitespace-separated tokens of `s`.
fn token_spans(s: &str) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut start = None;
    for (i, c) in s.char_indices() {
        match (c.is_whitespace(), start) {
            (false, None) => start = Some(i),
            (true, Some(b)) => {
                spans.push((b, i));
                start = None;
            }
            _ => {}
        }
    }
    if let Some(b) = start {
        spans.push((b, s.len()));
    }
    spans
}

/// One to four random mutations of `text`.
fn mutate(rng: &mut Rng, text: &str) -> String {
    let mut s = text.to_owned();
    for _ in 0..1 + below(rng, 4) {
        let len = s.len();
        match below(rng, 8) {
            // Replace a token by a hostile one.
            0..=2 => {
                let spans = token_spans(&s);
                if let Some(&(a, b)) = spans.get(below(rng, spans.len())) {
                    let t = HOSTILE[below(rng, HOSTILE.len())];
                    s.replace_range(a..b, t);
                }
            }
            // Insert a hostile token anywhere.
            3 => {
                let at = boundary(&s, below(rng, len + 1));
                let t = HOSTILE[below(rng, HOSTILE.len())];
                s.insert_str(at, &format!(" {t} "));
            }
            // Flip a byte to another ASCII character.
            4 => {
                if len > 0 {
                    let at = boundary(&s, below(rng, len));
                    let end = boundary(&s, at + 1).max(at);
                    let c = (32 + below(rng, 95)) as u8 as char;
                    if end > at {
                        s.replace_range(at..end, &c.to_string());
                    }
                }
            }
            // Delete a range.
            5 => {
                let a = boundary(&s, below(rng, len + 1));
                let b = boundary(&s, a + below(rng, 40));
                s.replace_range(a..b, "");
            }
            // Duplicate a line.
            6 => {
                let lines: Vec<&str> = s.split_inclusive('\n').collect();
                if !lines.is_empty() {
                    let i = below(rng, lines.len());
                    let mut out: Vec<&str> = lines.clone();
                    out.insert(i, lines[i]);
                    s = out.concat();
                }
            }
            // Cut the file short.
            _ => {
                let at = boundary(&s, below(rng, len + 1));
                s.truncate(at);
            }
        }
    }
    s
}

thread_local! {
    /// Whether a fuzz case is running (its panics are reported with the input instead).
    static IN_CASE: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `check` on `cases` mutations of `seeds`; panics (naming the seed and case) on a panic
/// inside softbench, an error that does not name `must_name`, or a case over the time cap.
fn fuzz<F>(target: &str, seeds: &[Vec<String>], cases: u64, mut check: F)
where
    F: FnMut(&[String]) -> Result<(), String>,
{
    let mut rng = Rng::new(seed() ^ softbench::study::fnv1a(target.as_bytes()));
    let (mut ok, mut err) = (0u64, 0u64);
    for case in 0..cases {
        let seed_files = &seeds[below(&mut rng, seeds.len())];
        // Mutate one of the seed's files (TetGen has two).
        let mut files = seed_files.clone();
        let which = below(&mut rng, files.len());
        files[which] = mutate(&mut rng, &files[which]);
        let start = Instant::now();
        IN_CASE.set(true);
        let outcome = catch_unwind(AssertUnwindSafe(|| check(&files)));
        IN_CASE.set(false);
        let elapsed = start.elapsed();
        match outcome {
            Ok(Ok(())) => ok += 1,
            Ok(Err(message)) if message.is_empty() => {
                panic!("{target} case {case}: an error without a message; input:\n{files:?}")
            }
            Ok(Err(_)) => err += 1,
            Err(_) => panic!("{target} case {case} panicked; input:\n{files:?}"),
        }
        assert!(
            elapsed < CASE_CAP,
            "{target} case {case} took {elapsed:?}; input:\n{files:?}"
        );
    }
    eprintln!("fuzz {target}: {cases} cases, {ok} accepted, {err} refused with an error");
}

/// `Err(message)` if `result` is an error, checking the message names `file`.
fn named<T, E: std::fmt::Display>(result: Result<T, E>, file: &str) -> Result<T, String> {
    result.map_err(|e| {
        let message = e.to_string();
        assert!(
            message.contains(file),
            "the error does not name {file}: {message}"
        );
        assert!(
            message.lines().all(|l| l.chars().count() <= 1100),
            "an error line over 1100 characters: {message}"
        );
        message
    })
}

fn mesh_targets(n: u64) {
    fuzz("medit", &[vec![MEDIT.into()]], n, |f| {
        let m = named(medit::parse(&f[0], Path::new("fuzz.mesh")), "fuzz.mesh")?;
        MeshReport::for_tet_mesh(&m);
        Ok(())
    });
    fuzz("plain", &[vec![PLAIN.into()]], n, |f| {
        let m = named(plain::parse(&f[0], Path::new("fuzz.mesh")), "fuzz.mesh")?;
        MeshReport::for_tet_mesh(&m);
        Ok(())
    });
    fuzz("tetgen", &[vec![NODE.into(), ELE.into()]], n, |f| {
        let (node, ele) = (Path::new("fuzz.node"), Path::new("fuzz.ele"));
        let m = tetgen::parse(&f[0], node, &f[1], ele).map_err(|e| {
            let message = e.to_string();
            assert!(
                message.contains("fuzz.node") || message.contains("fuzz.ele"),
                "{message}"
            );
            message
        })?;
        MeshReport::for_tet_mesh(&m);
        Ok(())
    });
    fuzz("obj", &[vec![OBJ.into()]], n, |f| {
        let m = named(obj::parse(&f[0], Path::new("fuzz.obj")), "fuzz.obj")?;
        MeshReport::for_surface(&m);
        Ok(())
    });
}

fn shipped(folder: &str) -> Vec<(PathBuf, String)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(folder);
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
        .into_iter()
        .map(|p| {
            let text = std::fs::read_to_string(&p).unwrap();
            (p, text)
        })
        .collect()
}

fn scene_target(n: u64) {
    let seeds: Vec<Vec<String>> = shipped("experiments/scenes")
        .into_iter()
        .map(|(_, t)| vec![t])
        .collect();
    // Relative mesh files resolve next to the (fake) scene path, in the shipped scenes
    // folder; meshes from SOFTBENCH_DATA are used if it is set.
    let fake = Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments/scenes/fuzz.toml");
    let data = DataPaths::from_env();
    fuzz("scene", &seeds, n, |f| {
        let config = named(scene::parse(&f[0], &fake, &[]), "fuzz.toml")?;
        let loaded = scene::LoadedScene {
            path: fake.clone(),
            config,
        };
        named(
            scene::build(&loaded, &data, Parallelism::Sequential),
            "fuzz.toml",
        )?;
        Ok(())
    });
}

fn study_target(n: u64) {
    let seeds: Vec<Vec<String>> = shipped("experiments")
        .into_iter()
        .map(|(_, t)| vec![t])
        .collect();
    // The study is written next to a copy of the shipped scenes, so its scene paths resolve.
    let dir = std::env::temp_dir().join(format!("softbench-fuzz-study-{}", std::process::id()));
    let scenes = dir.join("scenes");
    std::fs::create_dir_all(&scenes).unwrap();
    for (path, text) in shipped("experiments/scenes") {
        std::fs::write(scenes.join(path.file_name().unwrap()), text).unwrap();
    }
    let path = dir.join("fuzz.toml");
    fuzz("study", &seeds, n, |f| {
        std::fs::write(&path, &f[0]).unwrap();
        let quick = f[0].len() % 2 == 0;
        named(
            softbench::study::load(&path, quick, &softbench::data::DataPaths::from_env()),
            "fuzz.toml",
        )?;
        Ok(())
    });
    let _ = std::fs::remove_dir_all(&dir);
}

/// Peak resident memory of this process (kB), from /proc (Linux).
fn peak_memory_kb() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// One test, so the budgets are lowered (in the environment) before any thread reads them.
#[test]
fn fuzzed_meshes_scenes_and_studies_give_errors_that_name_the_file_never_a_panic() {
    // SAFETY: set before anything else in this test binary runs or reads the environment
    // (this is its only test).
    unsafe {
        std::env::set_var("SOFTBENCH_MAX_MESH", "200000");
        std::env::set_var("SOFTBENCH_MAX_RUNS", "200");
    }
    // A panic inside a case is reported with its input; the default message is shown too
    // only with SOFTBENCH_FUZZ_VERBOSE (it has the location).
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if !IN_CASE.get() || std::env::var_os("SOFTBENCH_FUZZ_VERBOSE").is_some() {
            hook(info);
        }
    }));
    let n = cases();
    mesh_targets(n);
    scene_target(n);
    study_target((n / 4).max(1));
    let _ = std::panic::take_hook();
    if let Some(kb) = peak_memory_kb() {
        assert!(
            kb < 3 << 20,
            "peak memory {kb} kB: a size budget is not holding"
        );
        eprintln!("fuzz: peak memory {} MB", kb >> 10);
    }
}
