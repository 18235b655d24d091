//! A seeded mutation fuzzer over every input softbench parses: every mesh reader (MEDIT
//! `.mesh`, TetGen `.node`/`.ele`, plain v/t `.mesh`, OBJ, Gmsh 2.2 and 4.1 ASCII and binary,
//! VTU ascii, inline base64 and zlib, appended raw (uncompressed, zlib, LZ4, LZMA) and base64,
//! legacy VTK 4.2 and 5.1 ASCII (with `METADATA` and `FIELD` data) and binary), scene files
//! (parsed, validated and built) and study files of every kind (loaded: grid expanded, every
//! scene checked and built).
//!
//! Each case takes a valid seed file, applies a few random mutations (tokens replaced by
//! hostile ones such as `18446744073709551615`, `nan`, `1e308` or `-1`, lines duplicated,
//! dropped or cut; for binary files, hostile 4- and 8-byte words written over the data and, in
//! a `.vtu`, the base64 payloads, inline or appended, decoded, mutated and encoded again) and asserts: no panic
//! (`catch_unwind`), an error that names the file, and bounded time and memory — by size
//! budgets lowered for the run (see `softbench::limits`), a watchdog that fails the test when a
//! case is still running after [`CASE_CAP`] (naming the target, seed, case and input, while the
//! case runs: it runs on a worker thread), and the process's peak memory at the end. Cases run
//! on one worker per core (`SOFTBENCH_FUZZ_WORKERS` overrides); they are drawn in order from
//! one seeded stream, so a case's input does not depend on the number of workers.
//!
//! The default (`cargo test`) is the CI slice: [`DEFAULT_CASES`] cases per target, seed 13.
//! The long mode is the same test with more cases; targets can be picked (comma-separated) to
//! run them apart:
//!
//! ```text
//! SOFTBENCH_FUZZ_CASES=1000000 SOFTBENCH_FUZZ_SEED=7 SOFTBENCH_FUZZ_TARGETS=gmsh22,vtu-zlib \
//!     cargo test --release --test fuzz_inputs -- --nocapture
//! ```
//!
//! A failure's message names `SOFTBENCH_FUZZ_SEED`, the target and the case, which replay it;
//! `SOFTBENCH_FUZZ_REPLAY=target:file` runs one file (of a one-file target) as its only case.

#[path = "support/fuzz_seeds.rs"]
mod fuzz_seeds;

use fuzz_seeds::below;
use softbench::data::DataPaths;
use softbench::mesh::{MeshReport, gmsh, medit, obj, plain, tetgen, vtk};
use softbench::parallel::Parallelism;
use softbench::rng::Rng;
use softbench::scene;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::{self, RecvTimeoutError};
use std::time::Duration;

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
    "BINARY",
    "POINTS",
    "CELLS",
    "CELL_TYPES",
    "OFFSETS",
    "$Nodes",
    "$EndNodes",
    "$Elements",
    "<Points>",
    "</Cells>",
    "<DataArray format=\"binary\">",
    "METADATA",
    "FIELD",
    "NULL_ARRAY",
    "</DataArray>",
    "<InformationKey>",
    "format=\"appended\" offset=\"0\"",
    "_",
];

/// The cases per target asked for with `SOFTBENCH_FUZZ_CASES` (the long mode), if any.
fn cases() -> Option<u64> {
    std::env::var("SOFTBENCH_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
}

fn seed() -> u64 {
    std::env::var("SOFTBENCH_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(13)
}

/// The targets to run: `SOFTBENCH_FUZZ_TARGETS` (comma-separated names), or all.
fn selected(target: &str) -> bool {
    std::env::var("SOFTBENCH_FUZZ_TARGETS")
        .map(|v| v.split(',').any(|t| t.trim() == target))
        .unwrap_or(true)
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

/// [`mutate`] for a text seed given as bytes.
fn mutate_text(rng: &mut Rng, data: &[u8]) -> Vec<u8> {
    mutate(
        rng,
        std::str::from_utf8(data).expect("text seeds are UTF-8"),
    )
    .into_bytes()
}

/// A `.vtu` mutation: text, or a binary payload decoded, mutated and encoded again.
fn mutate_vtu(rng: &mut Rng, data: &[u8]) -> Vec<u8> {
    fuzz_seeds::mutate_vtu(rng, data, mutate_text)
}

/// How a seed file is mutated.
type Mutator = fn(&mut Rng, &[u8]) -> Vec<u8>;

/// A case's files (one, or TetGen's two).
type Files = Vec<Vec<u8>>;

/// How one case ended on the worker.
enum Outcome {
    Accepted,
    Refused(String),
    Panicked,
}

/// One fuzz target: its seeds, how a seed is mutated, and the check of a mutated case.
struct Target<F> {
    name: &'static str,
    seeds: Vec<Files>,
    mutate: Mutator,
    check: F,
}

thread_local! {
    /// Whether a fuzz case is running (its panics are reported with the input instead).
    static IN_CASE: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    /// This worker's index (0 on the main thread), so a check can keep its files apart.
    static WORKER: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// Worker threads per target: `SOFTBENCH_FUZZ_WORKERS`, or one per core. The cases and
/// their inputs do not depend on it (they are drawn in order on the main thread).
fn workers() -> usize {
    std::env::var("SOFTBENCH_FUZZ_WORKERS")
        .ok()
        .and_then(|v| v.parse().ok())
        .filter(|&w| w > 0)
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// Runs `target.check` on `cases` mutations of its seeds on [`workers`] worker threads,
/// under a watchdog; panics (naming the seed, target and case, with the input) on a panic
/// inside softbench, an error without a message, or a case still running after `cap` —
/// reported while it runs, so a hang is a failure, not a stuck test (the stuck worker is left
/// behind and ends with the process). The cases are drawn in order from one seeded stream on
/// this thread, so case k's input is the same whatever the number of workers.
fn fuzz<F>(target: Target<F>, seed: u64, cases: u64, cap: Duration) -> FuzzCount
where
    F: Fn(&[Vec<u8>]) -> Result<(), String> + Send + Sync + 'static,
{
    let Target {
        name,
        seeds,
        mutate,
        check,
    } = target;
    let check = Arc::new(check);
    let mut rng = Rng::new(seed ^ softbench::study::fnv1a(name.as_bytes()));
    let (to_workers, inbox) = mpsc::channel::<(u64, Arc<Files>)>();
    let inbox = Arc::new(std::sync::Mutex::new(inbox));
    let (outbox, from_workers) = mpsc::channel::<(u64, Outcome)>();
    let pool = workers();
    let handles: Vec<_> = (0..pool)
        .map(|w| {
            let (inbox, outbox, check) = (Arc::clone(&inbox), outbox.clone(), Arc::clone(&check));
            std::thread::Builder::new()
                .name(format!("fuzz-{name}-{w}"))
                .spawn(move || {
                    WORKER.set(w);
                    loop {
                        // The lock is held only while waiting for the next case.
                        let next = inbox.lock().map(|rx| rx.recv());
                        let Ok(Ok((case, files))) = next else { break };
                        IN_CASE.set(true);
                        let outcome = catch_unwind(AssertUnwindSafe(|| check(&files)));
                        IN_CASE.set(false);
                        let outcome = match outcome {
                            Ok(Ok(())) => Outcome::Accepted,
                            Ok(Err(message)) => Outcome::Refused(message),
                            Err(_) => Outcome::Panicked,
                        };
                        if outbox.send((case, outcome)).is_err() {
                            break;
                        }
                    }
                })
                .expect("cannot start a fuzz worker")
        })
        .collect();
    drop(outbox);
    let show = |files: &Files| -> Vec<String> {
        files
            .iter()
            .map(|f| String::from_utf8_lossy(f).escape_debug().to_string())
            .collect()
    };
    let replay = |case: u64| {
        format!(
            "{name} case {case} (replay: SOFTBENCH_FUZZ_SEED={seed} SOFTBENCH_FUZZ_TARGETS={name} \
             SOFTBENCH_FUZZ_CASES={})",
            case + 1
        )
    };
    let mut count = FuzzCount::default();
    let start = std::time::Instant::now();
    // The cases on a worker now: when each was handed over, and its input.
    let mut running: std::collections::BTreeMap<u64, (std::time::Instant, Arc<Files>)> =
        std::collections::BTreeMap::new();
    let mut next = 0;
    while next < cases || !running.is_empty() {
        // A case is handed over only when a worker is free, so its clock is its own.
        while next < cases && running.len() < pool {
            let seed_files = &seeds[below(&mut rng, seeds.len())];
            // Mutate one of the seed's files (TetGen has two).
            let mut files = seed_files.clone();
            let which = below(&mut rng, files.len());
            files[which] = mutate(&mut rng, &files[which]);
            let files = Arc::new(files);
            to_workers
                .send((next, Arc::clone(&files)))
                .expect("the fuzz workers are gone");
            running.insert(next, (std::time::Instant::now(), files));
            next += 1;
        }
        let oldest = running
            .values()
            .map(|(t, _)| *t)
            .min()
            .expect("a case is running");
        let wait = cap.saturating_sub(oldest.elapsed());
        match from_workers.recv_timeout(wait) {
            Ok((case, outcome)) => {
                let (_, files) = running.remove(&case).expect("an unknown case finished");
                match outcome {
                    Outcome::Accepted => count.accepted += 1,
                    Outcome::Refused(message) if message.is_empty() => panic!(
                        "{}: an error without a message; input:\n{:?}",
                        replay(case),
                        show(&files)
                    ),
                    Outcome::Refused(_) => count.refused += 1,
                    Outcome::Panicked => {
                        panic!("{} panicked; input:\n{:?}", replay(case), show(&files))
                    }
                }
            }
            Err(RecvTimeoutError::Timeout) => {
                if let Some((case, (_, files))) =
                    running.iter().find(|(_, (t, _))| t.elapsed() >= cap)
                {
                    panic!(
                        "{} is still running after {cap:?}: a hang; input:\n{:?}",
                        replay(*case),
                        show(files)
                    );
                }
            }
            Err(RecvTimeoutError::Disconnected) => {
                panic!("the fuzz workers of {name} died")
            }
        }
    }
    drop(to_workers);
    for handle in handles {
        handle.join().expect("a fuzz worker panicked");
    }
    let seconds = start.elapsed().as_secs_f64();
    eprintln!(
        "fuzz {name}: {cases} cases in {seconds:.1} s ({:.0} cases/s on {pool} workers), {} \
         accepted, {} refused with an error",
        cases as f64 / seconds.max(1e-9),
        count.accepted,
        count.refused
    );
    count
}

/// What a fuzz run saw.
#[derive(Default)]
struct FuzzCount {
    accepted: u64,
    refused: u64,
}

/// Runs `target` if it is [`selected`], with the seed and number of cases of this run.
fn run<F>(target: Target<F>, cases: u64)
where
    F: Fn(&[Vec<u8>]) -> Result<(), String> + Send + Sync + 'static,
{
    if !selected(target.name) {
        return;
    }
    // SOFTBENCH_FUZZ_REPLAY=target:file runs that one file, unmutated, under the watchdog.
    let replay = std::env::var("SOFTBENCH_FUZZ_REPLAY").ok();
    if let Some((_, file)) = replay
        .as_deref()
        .and_then(|r| r.split_once(':'))
        .filter(|(t, _)| *t == target.name)
    {
        let data = std::fs::read(file).expect("cannot read SOFTBENCH_FUZZ_REPLAY's file");
        let target = Target {
            seeds: vec![vec![data]],
            mutate: |_: &mut Rng, d: &[u8]| d.to_vec(),
            ..target
        };
        fuzz(target, seed(), 1, CASE_CAP);
        return;
    }
    fuzz(target, seed(), cases, CASE_CAP);
}

/// A file's bytes as text, or the error a text reader gives.
fn utf8<'a>(bytes: &'a [u8], file: &str) -> Result<&'a str, String> {
    std::str::from_utf8(bytes).map_err(|_| format!("{file}: not UTF-8 text"))
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

fn text_seed(s: &str) -> Vec<Files> {
    vec![vec![s.as_bytes().to_vec()]]
}

fn mesh_targets(n: u64) {
    run(
        Target {
            name: "medit",
            seeds: text_seed(MEDIT),
            mutate: mutate_text,
            check: |f: &[Vec<u8>]| {
                let m = named(
                    medit::parse(utf8(&f[0], "fuzz.mesh")?, Path::new("fuzz.mesh")),
                    "fuzz.mesh",
                )?;
                MeshReport::for_tet_mesh(&m);
                Ok(())
            },
        },
        n,
    );
    run(
        Target {
            name: "plain",
            seeds: text_seed(PLAIN),
            mutate: mutate_text,
            check: |f: &[Vec<u8>]| {
                let m = named(
                    plain::parse(utf8(&f[0], "fuzz.mesh")?, Path::new("fuzz.mesh")),
                    "fuzz.mesh",
                )?;
                MeshReport::for_tet_mesh(&m);
                Ok(())
            },
        },
        n,
    );
    run(
        Target {
            name: "tetgen",
            seeds: vec![vec![NODE.into(), ELE.into()]],
            mutate: mutate_text,
            check: |f: &[Vec<u8>]| {
                let (node, ele) = (Path::new("fuzz.node"), Path::new("fuzz.ele"));
                let m = tetgen::parse(
                    utf8(&f[0], "fuzz.node")?,
                    node,
                    utf8(&f[1], "fuzz.ele")?,
                    ele,
                )
                .map_err(|e| {
                    let message = e.to_string();
                    assert!(
                        message.contains("fuzz.node") || message.contains("fuzz.ele"),
                        "{message}"
                    );
                    message
                })?;
                MeshReport::for_tet_mesh(&m);
                Ok(())
            },
        },
        n,
    );
    run(
        Target {
            name: "obj",
            seeds: text_seed(OBJ),
            mutate: mutate_text,
            check: |f: &[Vec<u8>]| {
                let m = named(
                    obj::parse(utf8(&f[0], "fuzz.obj")?, Path::new("fuzz.obj")),
                    "fuzz.obj",
                )?;
                MeshReport::for_surface(&m);
                Ok(())
            },
        },
        n,
    );
    let gmsh_check = |f: &[Vec<u8>]| {
        let m = named(gmsh::parse(&f[0], Path::new("fuzz.msh")), "fuzz.msh")?;
        MeshReport::for_tet_mesh(&m);
        Ok(())
    };
    let gmsh_targets: [(&str, Vec<Files>, Mutator); 3] = [
        ("gmsh22", text_seed(fuzz_seeds::MSH22), mutate_text),
        ("gmsh41", text_seed(fuzz_seeds::MSH41), mutate_text),
        (
            "gmsh-binary",
            vec![
                vec![fuzz_seeds::msh22_binary()],
                vec![fuzz_seeds::msh41_binary()],
            ],
            fuzz_seeds::mutate_bytes,
        ),
    ];
    for (name, seeds, mutate) in gmsh_targets {
        run(
            Target {
                name,
                seeds,
                mutate,
                check: gmsh_check,
            },
            n,
        );
    }
    let legacy_check = |f: &[Vec<u8>]| {
        let m = named(vtk::parse_legacy(&f[0], Path::new("fuzz.vtk")), "fuzz.vtk")?;
        MeshReport::for_tet_mesh(&m);
        Ok(())
    };
    let vtu_check = |f: &[Vec<u8>]| {
        let frame = named(vtk::parse_vtu(&f[0], Path::new("fuzz.vtu")), "fuzz.vtu")?;
        MeshReport::for_tet_mesh(&frame.mesh);
        Ok(())
    };
    use fuzz_seeds::{pack_lz4, pack_lzma, pack_raw, pack_zlib, vtu_appended};
    const ZLIB: &str = " compressor=\"vtkZLibDataCompressor\"";
    const LZ4: &str = " compressor=\"vtkLZ4DataCompressor\"";
    const LZMA: &str = " compressor=\"vtkLZMADataCompressor\"";
    let vtu_targets: [(&str, Vec<Files>, Mutator); 5] = [
        ("vtu-ascii", text_seed(fuzz_seeds::VTU_ASCII), mutate_vtu),
        (
            "vtu-base64",
            vec![vec![fuzz_seeds::vtu_base64()]],
            mutate_vtu,
        ),
        ("vtu-zlib", vec![vec![fuzz_seeds::vtu_zlib()]], mutate_vtu),
        // Raw appended data: byte mutations reach the block tables and blocks directly.
        (
            "vtu-appended",
            vec![
                vec![vtu_appended("", (5, 2), false, &pack_raw)],
                vec![vtu_appended(ZLIB, (5, 2), false, &pack_zlib)],
                vec![vtu_appended(LZ4, (5, 2), false, &pack_lz4)],
                vec![vtu_appended(LZMA, (5, 2), false, &pack_lzma)],
            ],
            fuzz_seeds::mutate_bytes,
        ),
        // Appended base64: the text, or the decoded appended data, mutated.
        (
            "vtu-appended-base64",
            vec![
                vec![vtu_appended("", (5, 2), true, &pack_raw)],
                vec![vtu_appended(ZLIB, (5, 2), true, &pack_zlib)],
                vec![vtu_appended(LZMA, (5, 2), true, &pack_lzma)],
            ],
            mutate_vtu,
        ),
    ];
    for (name, seeds, mutate) in vtu_targets {
        run(
            Target {
                name,
                seeds,
                mutate,
                check: vtu_check,
            },
            n,
        );
    }
    run(
        Target {
            name: "legacy-vtk",
            seeds: vec![
                vec![fuzz_seeds::VTK42.into()],
                vec![fuzz_seeds::VTK51.into()],
                vec![fuzz_seeds::VTK51_METADATA.into()],
            ],
            mutate: mutate_text,
            check: legacy_check,
        },
        n,
    );
    run(
        Target {
            name: "legacy-vtk-binary",
            seeds: vec![
                vec![fuzz_seeds::legacy_binary("4.2")],
                vec![fuzz_seeds::legacy_binary("5.1")],
            ],
            mutate: fuzz_seeds::mutate_bytes,
            check: legacy_check,
        },
        n,
    );
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

/// The shipped files of `folder` as seeds.
fn shipped_seeds(folder: &str) -> Vec<Files> {
    shipped(folder)
        .into_iter()
        .map(|(_, t)| vec![t.into_bytes()])
        .collect()
}

fn scene_target(n: u64) {
    // Relative mesh files resolve next to the (fake) scene path, in the shipped scenes
    // folder; meshes from SOFTBENCH_DATA are used if it is set.
    let fake = Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments/scenes/fuzz.toml");
    let data = DataPaths::from_env();
    run(
        Target {
            name: "scene",
            seeds: shipped_seeds("experiments/scenes"),
            mutate: mutate_text,
            check: move |f: &[Vec<u8>]| {
                let text = utf8(&f[0], "fuzz.toml")?;
                let config = named(scene::parse(text, &fake, &[]), "fuzz.toml")?;
                let loaded = scene::LoadedScene {
                    path: fake.clone(),
                    config,
                };
                named(
                    scene::build(&loaded, &data, Parallelism::Sequential),
                    "fuzz.toml",
                )?;
                Ok(())
            },
        },
        n,
    );
}

fn study_target(n: u64) {
    let seeds = shipped_seeds("experiments");
    // Every study kind (and a sweep) is among the seeds.
    let kinds = softbench::study::kinds();
    let names = kinds.iter().map(|k| k.name).chain(["sweep"]);
    for kind in names {
        let line = format!("study = \"{kind}\"");
        assert!(
            seeds
                .iter()
                .any(|f| String::from_utf8_lossy(&f[0]).contains(&line)),
            "no shipped study of kind `{kind}` to fuzz from"
        );
    }
    // The study is written next to a copy of the shipped scenes, so its scene paths resolve:
    // one folder per worker.
    let dir = std::env::temp_dir().join(format!("softbench-fuzz-study-{}", std::process::id()));
    for w in 0..workers() {
        let scenes = dir.join(format!("w{w}")).join("scenes");
        std::fs::create_dir_all(&scenes).unwrap();
        for (path, text) in shipped("experiments/scenes") {
            std::fs::write(scenes.join(path.file_name().unwrap()), text).unwrap();
        }
    }
    let folder = dir.clone();
    run(
        Target {
            name: "study",
            seeds,
            mutate: mutate_text,
            check: move |f: &[Vec<u8>]| {
                let path = folder.join(format!("w{}", WORKER.get())).join("fuzz.toml");
                std::fs::write(&path, &f[0]).unwrap();
                let quick = f[0].len().is_multiple_of(2);
                named(
                    softbench::study::load(&path, quick, &DataPaths::from_env()),
                    "fuzz.toml",
                )?;
                Ok(())
            },
        },
        n,
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The watchdog's own check: a case that sleeps past the cap fails the run with its name,
/// seed and input while it is still running.
fn watchdog_reports_a_hang() {
    let target = Target {
        name: "watchdog",
        seeds: text_seed("sleep"),
        mutate: |_: &mut Rng, d: &[u8]| d.to_vec(),
        check: |_: &[Vec<u8>]| {
            std::thread::sleep(Duration::from_secs(2));
            Ok(())
        },
    };
    // The expected panic is not printed (the hook stays quiet inside a case).
    IN_CASE.set(true);
    let start = std::time::Instant::now();
    let caught = catch_unwind(AssertUnwindSafe(|| {
        fuzz(target, 99, 3, Duration::from_millis(100))
    }));
    IN_CASE.set(false);
    let message = match caught {
        Ok(_) => panic!("the watchdog let a 2 s case pass a 100 ms cap"),
        Err(e) => e.downcast_ref::<String>().cloned().unwrap_or_default(),
    };
    assert!(start.elapsed() < Duration::from_secs(2), "{message}");
    for needle in [
        "watchdog case 0",
        "SOFTBENCH_FUZZ_SEED=99",
        "still running after 100ms: a hang",
        "sleep",
    ] {
        assert!(message.contains(needle), "`{needle}` not in: {message}");
    }
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
    watchdog_reports_a_hang();
    // The CI slice gives the study target (a load builds every scene) a quarter of the cases;
    // the long mode gives every target the cases asked for.
    let (n, studies) = match cases() {
        Some(n) => (n, n),
        None => (DEFAULT_CASES, DEFAULT_CASES / 4),
    };
    mesh_targets(n);
    scene_target(n);
    study_target(studies);
    let _ = std::panic::take_hook();
    if let Some(kb) = peak_memory_kb() {
        assert!(
            kb < 3 << 20,
            "peak memory {kb} kB: a size budget is not holding"
        );
        eprintln!("fuzz: peak memory {} MB", kb >> 10);
    }
}
