//! CG preconditioners on backward-Euler systems of generated FEM boxes with 2 cm cells (stiff
//! next to the mass, like a finely meshed body): setup (`factor`) and one solve to 1e-8 for
//! AMG, IC(0) and 3×3 block-Jacobi, at 2.6k and 20.7k tets (the same body, cells halved).
//! Prints the iterations of each; AMG's should barely change between the sizes.
//!
//! `cargo bench --bench preconditioners -- --quick`

#[path = "../tests/support/fem_system.rs"]
mod fem_system;

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use fem_system::{FemSystem, fem_box_sized};
use softbench::solve::{CgSettings, CgSolver, LinearSolver, Preconditioner};

fn bench_system(c: &mut Criterion, name: &str, system: &FemSystem) {
    let a = &system.matrix;
    let b: Vec<f64> = (0..a.dim())
        .map(|i| if i % 3 == 1 { -1.0 } else { 0.0 })
        .collect();
    for p in [
        Preconditioner::Amg,
        Preconditioner::IncompleteCholesky,
        Preconditioner::BlockJacobi3,
    ] {
        let mut s = CgSolver::new(CgSettings {
            preconditioner: p,
            max_iterations: 5000,
            ..CgSettings::default()
        });
        s.analyze(a.pattern()).unwrap();
        s.set_coordinates(&system.positions);
        s.factor(a).unwrap();
        let mut x = b.clone();
        let report = s.solve(&mut x).unwrap();
        eprintln!(
            "{name}/{}: n = {}, {} iterations to {:.1e}",
            p.name(),
            a.dim(),
            report.iterations,
            report.relative_residual
        );
        c.bench_function(&format!("{name}/{}/setup", p.name()), |bench| {
            bench.iter(|| s.factor(black_box(a)).unwrap())
        });
        c.bench_function(&format!("{name}/{}/solve", p.name()), |bench| {
            bench.iter(|| {
                x.copy_from_slice(&b);
                s.solve(black_box(&mut x)).unwrap()
            })
        });
    }
}

fn preconditioners(c: &mut Criterion) {
    bench_system(c, "box_2.6k", &fem_box_sized([12, 6, 6], 0.04));
    bench_system(c, "box_20.7k", &fem_box_sized([24, 12, 12], 0.02));
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_secs(1))
        .without_plots();
    targets = preconditioners
}
criterion_main!(benches);
