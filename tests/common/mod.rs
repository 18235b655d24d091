//! Helpers shared by the integration tests: finding reference meshes and writing small files
//! into a private temporary folder.
#![allow(dead_code)] // each test binary uses a different subset

pub mod hostile;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The reference mesh `name` in the folder named by `SOFTBENCH_DATA`.
///
/// Returns `None`, after saying so on stderr, when `SOFTBENCH_DATA` is not set, so the suite
/// passes on a machine without the data. Panics when it is set but the file is missing, since
/// that is a broken setup rather than an absent one.
pub fn reference_mesh(name: &str) -> Option<PathBuf> {
    let Some(dir) = std::env::var_os("SOFTBENCH_DATA").filter(|v| !v.is_empty()) else {
        let test = std::thread::current()
            .name()
            .unwrap_or("<unnamed test>")
            .to_string();
        // Writing to the stderr handle bypasses libtest's output capture, so the skip shows.
        // One write call, so lines of tests running in parallel do not interleave.
        let line = format!(
            "skipped: {test}: SOFTBENCH_DATA is not set (set it to the reference mesh folder, \
             e.g. shared/meshes, to run this test)\n"
        );
        let _ = std::io::stderr().write_all(line.as_bytes());
        return None;
    };
    let path = Path::new(&dir).join(name);
    assert!(
        path.is_file(),
        "reference mesh {} is missing: SOFTBENCH_DATA={} does not hold `{name}`",
        path.display(),
        Path::new(&dir).display()
    );
    Some(path)
}

/// A fresh, empty folder under the system temp folder, removed when dropped.
pub struct TempDir(PathBuf);

impl TempDir {
    /// A new folder whose name contains `label`, the process id and a counter (unique across
    /// the tests of one run and across concurrent runs).
    pub fn new(label: &str) -> Self {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let dir =
            std::env::temp_dir().join(format!("softbench-test-{label}-{}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("cannot create a temporary folder");
        TempDir(dir)
    }

    /// Writes `content` to `name` in this folder and returns its path.
    pub fn write(&self, name: &str, content: &str) -> PathBuf {
        let path = self.0.join(name);
        std::fs::write(&path, content).expect("cannot write a temporary file");
        path
    }

    /// The folder.
    pub fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Asserts that `a` is within `rel` relative error of `b`.
#[track_caller]
pub fn assert_close(a: f64, b: f64, rel: f64) {
    assert!(
        (a - b).abs() <= rel * b.abs(),
        "{a} is not within {rel} (relative) of {b}"
    );
}
pub mod bodies;
pub mod results;
pub mod stability_study;

/// Run the `softbench` binary with `args` (environment inherited) and collect its output.
pub fn softbench(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_softbench"))
        .args(args)
        .output()
        .expect("cannot run softbench")
}

/// `softbench simulate <scene> --out <out> [extra...]`.
pub fn simulate(scene: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "simulate",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    softbench(&args)
}

/// `softbench run <study> --out <out> [extra...]`.
pub fn run_study(study: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "run",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    softbench(&args)
}

/// [`run_study`], asserting that it succeeded.
pub fn run_study_ok(study: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    let o = run_study(study, out, extra);
    assert!(
        o.status.success(),
        "softbench run {} failed: {}",
        study.display(),
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

/// A shipped scene file, `experiments/scenes/<name>`.
pub fn scene(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("experiments/scenes")
        .join(name)
}

/// Wall times differ between two runs of the same scene; everything else must not.
pub fn is_timing(key: &str) -> bool {
    key.contains("seconds") || key == "times"
}

/// A CSV file without its timing columns.
pub fn csv_without_timings(path: &Path) -> Vec<Vec<String>> {
    let mut reader = csv::Reader::from_path(path).unwrap();
    let header: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
    let keep: Vec<usize> = (0..header.len())
        .filter(|&i| !is_timing(&header[i]))
        .collect();
    let mut rows = vec![keep.iter().map(|&i| header[i].clone()).collect()];
    for record in reader.records() {
        let record = record.unwrap();
        rows.push(keep.iter().map(|&i| record[i].to_owned()).collect());
    }
    rows
}
