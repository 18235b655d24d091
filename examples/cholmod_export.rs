//! Exports backward-Euler system matrices in Matrix Market format and times softbench's own
//! factorization of them (faer supernodal LLᵀ, METIS nested dissection, one and two
//! threads), for `tools/cholmod_compare.py` to factor the very same matrices with CHOLMOD.
//!
//! The systems are those of the solver tests and benches (`tests/support/fem_system.rs`):
//! `M + dt² K`, dt = 0.01, Stable Neo-Hookean (E = 1e6 Pa, ν = 0.45, 1000 kg/m³), lumped
//! mass, clamped at x = 0, at a sagged state. For each mesh it writes `<name>.mtx` and
//! `<name>.softbench.json` (n, nnz(A), nnz(L) and flops per ordering, the numeric
//! factorization's wall times and median per thread count).
//!
//! `cargo run --release --example cholmod_export -- <out_dir> [repeats] [mesh ...]`
//! (meshes: box_12k, box_49k, ball_83k; default all).

#[path = "../tests/support/fem_system.rs"]
mod fem_system;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use fem_system::{fem_ball, fem_box};
use softbench::parallel::Parallelism;
use softbench::solve::{CholeskySolver, DirectSettings, LinearSolver, Ordering};
use softbench::sparse::SymmetricMatrix;

const MESHES: [&str; 3] = ["box_12k", "box_49k", "ball_83k"];

fn system(name: &str) -> SymmetricMatrix {
    match name {
        "box_12k" => fem_box([20, 10, 10]).matrix,
        "box_49k" => fem_box([32, 16, 16]).matrix,
        // 48 n³ tets: n = 12.
        _ => fem_ball(12).matrix,
    }
}

fn settings(ordering: Ordering, threads: usize) -> DirectSettings {
    DirectSettings {
        ordering,
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

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

fn export(dir: &Path, name: &str, repeats: usize) -> anyhow::Result<()> {
    let a = system(name);
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
    let mut timings = Vec::new();
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()?;
        let mut times: Vec<f64> = pool.install(|| -> anyhow::Result<Vec<f64>> {
            let mut s = CholeskySolver::new(settings(Ordering::Metis, threads));
            s.analyze(a.pattern())?;
            s.factor(&a)?; // warm-up: first touch of the factor's pages
            (0..repeats)
                .map(|_| {
                    let start = Instant::now();
                    s.factor(&a)?;
                    Ok(start.elapsed().as_secs_f64())
                })
                .collect()
        })?;
        let list = times
            .iter()
            .map(|t| format!("{t:.6}"))
            .collect::<Vec<_>>()
            .join(", ");
        let med = median(&mut times);
        eprintln!("{name}: faer + METIS, {threads} thread(s): median {med:.4} s");
        timings.push(format!(
            "\"{threads}\": {{\"median_seconds\": {med:.6}, \"seconds\": [{list}]}}"
        ));
    }
    let json = format!(
        "{{\n  \"mesh\": \"{name}\",\n  \"n\": {},\n  \"nnz_lower\": {},\n  \"orderings\": {{{}}},\n  \
         \"factor_metis_threads\": {{{}}},\n  \"repeats\": {repeats}\n}}\n",
        a.dim(),
        (a.pattern().nnz() + a.dim()) / 2,
        orderings.join(", "),
        timings.join(", ")
    );
    let path = dir.join(format!("{name}.softbench.json"));
    softbench::io::write_atomic(&path, |w| w.write_all(json.as_bytes()))
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(dir) = args.first().map(PathBuf::from) else {
        bail!("usage: cholmod_export <out_dir> [repeats] [mesh ...] (meshes: {MESHES:?})");
    };
    let repeats = match args.get(1) {
        Some(r) => r
            .parse::<usize>()
            .ok()
            .filter(|&r| r >= 1)
            .with_context(|| format!("repeats must be a positive integer, got {r:?}"))?,
        None => 5,
    };
    let meshes: Vec<&str> = if args.len() > 2 {
        args[2..].iter().map(String::as_str).collect()
    } else {
        MESHES.to_vec()
    };
    for m in &meshes {
        if !MESHES.contains(m) {
            bail!("unknown mesh {m:?}; valid: {MESHES:?}");
        }
    }
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    for m in meshes {
        export(&dir, m, repeats)?;
    }
    Ok(())
}
