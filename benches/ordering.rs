//! Fill-reducing ordering and threads of the sparse Cholesky factorization, on backward-Euler
//! systems of generated FEM bodies (tests/support/fem_system.rs): symbolic analysis with AMD
//! and METIS, numeric factorization with each ordering on one and two threads. Prints nnz(L)
//! and the predicted flops of each ordering; the flops rule for threads
//! (`DirectSettings::parallel_min_flops`) is set from these medians.
//!
//! `cargo bench --bench ordering -- --quick` (single meshes: `-- --quick box_49k`).

#[path = "../tests/support/fem_system.rs"]
mod fem_system;

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use fem_system::{fem_ball, fem_box};
use softbench::parallel::Parallelism;
use softbench::solve::{CholeskySolver, DirectSettings, LinearSolver, Ordering};
use softbench::sparse::SymmetricMatrix;

fn settings(ordering: Ordering, threads: usize) -> DirectSettings {
    DirectSettings {
        ordering,
        parallelism: if threads > 1 {
            Parallelism::Rayon
        } else {
            Parallelism::Sequential
        },
        // Measure the threads themselves, whatever the rule would pick.
        parallel_min_flops: 0.0,
        ..DirectSettings::default()
    }
}

fn bench_mesh(c: &mut Criterion, name: &str, a: &SymmetricMatrix) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    for ordering in [Ordering::Amd, Ordering::Metis] {
        let mut s = CholeskySolver::new(settings(ordering, 1));
        s.analyze(a.pattern()).unwrap();
        eprintln!(
            "{name}/{}: n = {}, nnz(A lower) = {}, nnz(L) = {}, flops = {:.3e}",
            ordering.name(),
            a.dim(),
            a.pattern().nnz().div_ceil(2),
            s.stats().factor_nnz,
            s.stats().factor_flops
        );
        c.bench_function(&format!("{name}/{}/analyze", ordering.name()), |b| {
            b.iter(|| {
                let mut s = CholeskySolver::new(settings(ordering, 1));
                s.analyze(black_box(a.pattern())).unwrap();
            })
        });
        for threads in [1, 2] {
            // Analyze inside the pool: the thread count is read there.
            let mut s = pool.install(|| {
                let mut s = CholeskySolver::new(settings(ordering, threads));
                s.analyze(a.pattern()).unwrap();
                s.factor(a).unwrap();
                s
            });
            c.bench_function(
                &format!("{name}/{}/factor/{threads}t", ordering.name()),
                |b| b.iter(|| pool.install(|| s.factor(black_box(a)).unwrap())),
            );
        }
    }
}

fn orderings(c: &mut Criterion) {
    // 6 tets per cell.
    bench_mesh(c, "box_3k", &fem_box([12, 6, 6]).matrix);
    bench_mesh(c, "box_12k", &fem_box([20, 10, 10]).matrix);
    bench_mesh(c, "box_49k", &fem_box([32, 16, 16]).matrix);
    // 48 n³ tets.
    bench_mesh(c, "ball_16k", &fem_ball(7).matrix);
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_secs(2))
        .without_plots();
    targets = orderings
}
criterion_main!(benches);
