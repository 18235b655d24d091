//! Linear solver phases on the synthetic elasticity-like grid system (tests/support) at about
//! 30k DOFs: numeric factorization and solve for sparse Cholesky and LDLᵀ, and CG solves.
//! Symbolic analysis is done once, outside the timed loops, as in a simulation.

#[path = "../tests/support/grid_spd.rs"]
mod grid_spd;

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use grid_spd::{Grid, Spec, rhs};
use softbench::solve::{
    CgSettings, CgSolver, CholeskySolver, DirectSettings, LdltSolver, LinearSolver, Preconditioner,
};
use softbench::sparse::SymmetricMatrix;

/// 22 × 22 × 21 vertices = 30 492 DOFs.
fn system() -> (SymmetricMatrix, Vec<f64>) {
    let grid = Grid::new(22, 22, 21);
    let p = grid.pattern();
    let a = grid.matrix(&p, 1, &Spec::default());
    (a, rhs(grid.dofs(), 2))
}

fn bench_direct(
    c: &mut Criterion,
    name: &str,
    mut s: Box<dyn LinearSolver>,
    a: &SymmetricMatrix,
    b: &[f64],
) {
    s.analyze(a.pattern()).unwrap();
    s.factor(a).unwrap();
    eprintln!(
        "{name}: n = {}, nnz(A) = {}, nnz(L) = {}, stored L values = {}",
        a.dim(),
        a.pattern().nnz(),
        s.stats().factor_nnz,
        s.stats().factor_storage
    );
    c.bench_function(&format!("{name}/factor"), |bench| {
        bench.iter(|| s.factor(black_box(a)).unwrap())
    });
    let mut x = b.to_vec();
    c.bench_function(&format!("{name}/solve"), |bench| {
        bench.iter(|| {
            x.copy_from_slice(b);
            s.solve(black_box(&mut x)).unwrap()
        })
    });
}

fn bench_cg(
    c: &mut Criterion,
    name: &str,
    preconditioner: Preconditioner,
    a: &SymmetricMatrix,
    b: &[f64],
) {
    let mut s = CgSolver::new(CgSettings {
        preconditioner,
        ..CgSettings::default()
    });
    s.analyze(a.pattern()).unwrap();
    s.factor(a).unwrap();
    let mut x = b.to_vec();
    let report = s.solve(&mut x).unwrap();
    eprintln!(
        "{name}: {} iterations to relative residual {:.1e}",
        report.iterations, report.relative_residual
    );
    c.bench_function(&format!("{name}/factor"), |bench| {
        bench.iter(|| s.factor(black_box(a)).unwrap())
    });
    c.bench_function(&format!("{name}/solve"), |bench| {
        bench.iter(|| {
            x.copy_from_slice(b);
            s.solve(black_box(&mut x)).unwrap()
        })
    });
}

fn solvers(c: &mut Criterion) {
    let (a, b) = system();
    bench_direct(
        c,
        "cholesky",
        Box::new(CholeskySolver::new(DirectSettings::default())),
        &a,
        &b,
    );
    bench_direct(
        c,
        "ldlt",
        Box::new(LdltSolver::new(DirectSettings::default())),
        &a,
        &b,
    );
    bench_cg(c, "cg_block_jacobi", Preconditioner::BlockJacobi3, &a, &b);
    bench_cg(c, "cg_ic0", Preconditioner::IncompleteCholesky, &a, &b);
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_millis(500))
        .without_plots();
    targets = solvers
}
criterion_main!(benches);
