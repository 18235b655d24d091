//! Exports backward-Euler system matrices in Matrix Market format and times softbench's own
//! factorization of them (supernodal LLᵀ, METIS nested dissection, one and two threads, with
//! faer's loop and with the subtree-parallel schedule, interleaved), for
//! `tools/cholmod_compare.py` to factor the very same matrices with CHOLMOD.
//!
//! The systems are those of the solver tests and benches (`tests/support/fem_system.rs`):
//! `M + dt² K`, dt = 0.01, Stable Neo-Hookean (E = 1e6 Pa, ν = 0.45, 1000 kg/m³), lumped
//! mass, clamped at x = 0, at a sagged state. For each mesh it writes `<name>.mtx` and
//! `<name>.softbench.json` (n, nnz(A), nnz(L) and flops per ordering, the numeric
//! factorization's wall times and median per thread count: `factor_metis_threads` for
//! softbench's default scheduler (subtrees) and
//! `factor_metis_schedulers` for both schedulers at both thread counts, plus the load average
//! after timing).
//!
//! `cargo run --release --example cholmod_export -- <out_dir> [repeats] [mesh ...]`
//! (meshes: box_12k, box_49k, ball_83k, or the path of a tet mesh file, such as the ~57k-tet
//! TetGen armadillo that `tools/armadillo_tetgen.py` writes; default the three generated ones).

#[path = "../tests/support/fem_system.rs"]
mod fem_system;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use fem_system::{fem_ball, fem_box, fem_system};
use softbench::parallel::Parallelism;
use softbench::solve::{CholeskySolver, DirectSettings, LinearSolver, Ordering, Scheduler};
use softbench::sparse::SymmetricMatrix;

const MESHES: [&str; 3] = ["box_12k", "box_49k", "ball_83k"];

/// A generated mesh's name, or a mesh file (named by its file stem).
enum Source {
    Generated(&'static str),
    File(PathBuf),
}

impl Source {
    fn parse(arg: &str) -> anyhow::Result<Self> {
        if let Some(name) = MESHES.iter().find(|m| **m == arg) {
            return Ok(Self::Generated(name));
        }
        let path = PathBuf::from(arg);
        if path.is_file() {
            return Ok(Self::File(path));
        }
        bail!("{arg:?} is neither a generated mesh ({MESHES:?}) nor a mesh file")
    }

    fn name(&self) -> String {
        match self {
            Self::Generated(name) => name.to_string(),
            Self::File(path) => path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "mesh".to_string()),
        }
    }

    fn system(&self) -> anyhow::Result<SymmetricMatrix> {
        Ok(match self {
            Self::Generated("box_12k") => fem_box([20, 10, 10]).matrix,
            Self::Generated("box_49k") => fem_box([32, 16, 16]).matrix,
            // 48 n³ tets: n = 12.
            Self::Generated(_) => fem_ball(12).matrix,
            Self::File(path) => {
                let mesh = softbench::mesh::read_tet_mesh(path)
                    .with_context(|| format!("reading {}", path.display()))?;
                fem_system(mesh).matrix
            }
        })
    }
}

fn settings(ordering: Ordering, threads: usize) -> DirectSettings {
    settings_with(ordering, threads, Scheduler::default())
}

fn settings_with(ordering: Ordering, threads: usize, scheduler: Scheduler) -> DirectSettings {
    DirectSettings {
        ordering,
        scheduler,
        parallelism: if threads > 1 {
            Parallelism::Rayon
        } else {
            Parallelism::Sequential
        },
        // Measure the threads themselves, whatever the flops rule would pick.
        parallel_min_flops: 0.0,
        ..DirectSettings::default()
    }
}

/// One timed configuration: a scheduler on a pool of `threads`, with METIS and threads
/// forced, or `defaults`: the settings a scene gets when it sets nothing (ordering `auto`,
/// the flops rule for threads), as `softbench simulate` runs it.
struct Timed {
    scheduler: Scheduler,
    defaults: bool,
    threads: usize,
    pool: rayon::ThreadPool,
    solver: CholeskySolver,
    analysis_seconds: f64,
    seconds: Vec<f64>,
}

impl Timed {
    fn new(
        a: &SymmetricMatrix,
        scheduler: Scheduler,
        threads: usize,
        defaults: bool,
    ) -> anyhow::Result<Self> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()?;
        let mut solver = CholeskySolver::new(if defaults {
            DirectSettings {
                parallelism: Parallelism::Rayon,
                ..DirectSettings::default()
            }
        } else {
            settings_with(Ordering::Metis, threads, scheduler)
        });
        let start = Instant::now();
        pool.install(|| solver.analyze(a.pattern()))?;
        let analysis_seconds = start.elapsed().as_secs_f64();
        anyhow::ensure!(
            solver.stats().factor_scheduler == scheduler.name(),
            "expected scheduler {}, got {}",
            scheduler.name(),
            solver.stats().factor_scheduler
        );
        let mut timed = Self {
            scheduler,
            defaults,
            threads,
            pool,
            solver,
            analysis_seconds,
            seconds: Vec::new(),
        };
        timed.factor(a)?; // warm-up: first touch of the factor's pages
        Ok(timed)
    }

    fn factor(&mut self, a: &SymmetricMatrix) -> anyhow::Result<()> {
        let solver = &mut self.solver;
        self.pool.install(|| solver.factor(a))?;
        Ok(())
    }

    fn time_once(&mut self, a: &SymmetricMatrix) -> anyhow::Result<()> {
        let start = Instant::now();
        self.factor(a)?;
        self.seconds.push(start.elapsed().as_secs_f64());
        Ok(())
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

fn export(dir: &Path, source: &Source, repeats: usize) -> anyhow::Result<()> {
    let name = source.name();
    let a = source.system()?;
    let mtx = dir.join(format!("{name}.mtx"));
    softbench::io::write_atomic(&mtx, |w| a.write_matrix_market(w))
        .with_context(|| format!("writing {}", mtx.display()))?;
    let mut orderings = Vec::new();
    for ordering in [Ordering::Amd, Ordering::Metis] {
        let mut s = CholeskySolver::new(settings(ordering, 1));
        s.analyze(a.pattern())?;
        orderings.push(format!(
            "\"{}\": {{\"factor_nnz\": {}, \"factor_flops\": {:e}}}",
            ordering.name(),
            s.stats().factor_nnz,
            s.stats().factor_flops
        ));
    }
    // Interleaved: each repeat times every configuration once, so a change of machine load
    // hits them all alike.
    let mut configs = Vec::new();
    for (scheduler, threads) in [
        (Scheduler::Faer, 1),
        (Scheduler::Faer, 2),
        (Scheduler::Subtrees, 1),
        (Scheduler::Subtrees, 2),
    ] {
        configs.push(Timed::new(&a, scheduler, threads, false)?);
    }
    for threads in [1, 2] {
        configs.push(Timed::new(&a, Scheduler::default(), threads, true)?);
    }
    for _ in 0..repeats {
        for c in &mut configs {
            c.time_once(&a)?;
        }
    }
    let mut timings = Vec::new();
    let mut by_scheduler = Vec::new();
    let mut defaults = Vec::new();
    for c in &mut configs {
        let list = c
            .seconds
            .iter()
            .map(|t| format!("{t:.6}"))
            .collect::<Vec<_>>()
            .join(", ");
        let med = median(&mut c.seconds.clone());
        if c.defaults {
            let ordering = c.solver.stats().ordering;
            eprintln!(
                "{name}: default settings (ordering auto chose {ordering}), {} thread(s): \
                 analysis {:.4} s, factorization median {med:.4} s",
                c.threads, c.analysis_seconds
            );
            defaults.push(format!(
                "\"{}\": {{\"ordering\": \"{ordering}\", \"factor_nnz\": {}, \
                 \"analysis_seconds\": {:.6}, \"median_seconds\": {med:.6}, \"seconds\": [{list}]}}",
                c.threads,
                c.solver.stats().factor_nnz,
                c.analysis_seconds
            ));
            continue;
        }
        eprintln!(
            "{name}: METIS, scheduler {}, {} thread(s): median {med:.4} s",
            c.scheduler.name(),
            c.threads
        );
        let entry = format!(
            "\"{}\": {{\"median_seconds\": {med:.6}, \"seconds\": [{list}]}}",
            c.threads
        );
        // softbench's default scheduler.
        if c.scheduler == Scheduler::default() {
            timings.push(entry.clone());
        }
        by_scheduler.push((c.scheduler.name(), entry));
    }
    let schedulers = [Scheduler::Faer, Scheduler::Subtrees]
        .map(|sch| {
            let entries: Vec<&str> = by_scheduler
                .iter()
                .filter(|(n, _)| *n == sch.name())
                .map(|(_, e)| e.as_str())
                .collect();
            format!("\"{}\": {{{}}}", sch.name(), entries.join(", "))
        })
        .join(", ");
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    let load = load.split_whitespace().next().unwrap_or("null");
    let json = format!(
        "{{\n  \"mesh\": \"{name}\",\n  \"n\": {},\n  \"nnz_lower\": {},\n  \"orderings\": {{{}}},\n  \
         \"factor_metis_threads\": {{{}}},\n  \"factor_metis_schedulers\": {{{}}},\n  \
         \"factor_defaults\": {{{}}},\n  \
         \"repeats\": {repeats},\n  \"load_average_1min_after\": {load}\n}}\n",
        a.dim(),
        (a.pattern().nnz() + a.dim()) / 2,
        orderings.join(", "),
        timings.join(", "),
        schedulers,
        defaults.join(", ")
    );
    let path = dir.join(format!("{name}.softbench.json"));
    softbench::io::write_atomic(&path, |w| w.write_all(json.as_bytes()))
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(dir) = args.first().map(PathBuf::from) else {
        bail!(
            "usage: cholmod_export <out_dir> [repeats] [mesh ...] (meshes: {MESHES:?} or a tet mesh file)"
        );
    };
    let repeats = match args.get(1) {
        Some(r) => r
            .parse::<usize>()
            .ok()
            .filter(|&r| r >= 1)
            .with_context(|| format!("repeats must be a positive integer, got {r:?}"))?,
        None => 5,
    };
    let meshes: Vec<Source> = if args.len() > 2 {
        args[2..]
            .iter()
            .map(|a| Source::parse(a))
            .collect::<anyhow::Result<_>>()?
    } else {
        MESHES.iter().map(|m| Source::Generated(m)).collect()
    };
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    for m in &meshes {
        export(&dir, m, repeats)?;
    }
    Ok(())
}
