//! Measures the rates behind `linear_solver = "auto"` (crates/core/src/solve/auto.rs) on
//! backward-Euler systems of generated boxes and balls (tests/support/fem_system.rs), and checks
//! the rule's choice against the measured faster solver.
//!
//! Per mesh, one thread, medians of `repeats`:
//! - Cholesky (the `direct.ordering` auto uses, METIS here): numeric factorization + one
//!   solve, against the predicted flops → the dense rate (flops/s);
//! - CG + AMG (defaults): one symmetric mat-vec (→ the sparse rate, 2 nnz(A) flops per
//!   mat-vec), a hierarchy build, a value-only refresh, and a solve to 1e-8 of a smooth load
//!   (iterations, seconds per iteration) → setup and iteration costs in mat-vecs;
//! - per Newton iteration: Cholesky's factor + solve, and CG's amortized setup (one build
//!   per `rebuild_every` setups) + solve; the measured winner next to `auto`'s prediction.
//!
//! Its CG solves go to 1e-8 (exact directions); the rule's iteration counts for inexact
//! Newton directions (`CG_ITERATIONS`, `INEXACT_NEWTON_ITERATIONS`) and CG + AMG's parallel
//! speed-up come from the solver-scaling study and step_49k instead (see
//! crates/core/src/solve/auto.rs), so the choices printed here lean towards Cholesky more than
//! the rule does.
//!
//! `cargo run --release --example auto_calibrate -- [repeats]`

#[path = "../tests/support/fem_system.rs"]
mod fem_system;

use std::time::Instant;

use fem_system::{FemSystem, fem_ball, fem_box};
use softbench::parallel::Parallelism;
use softbench::solve::{
    AmgSettings, AutoPrediction, CgSettings, CgSolver, CholeskySolver, DirectSettings,
    LinearSolver, Ordering, Preconditioner, symmetric_mul_vec,
};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

fn time(repeats: usize, mut f: impl FnMut()) -> f64 {
    f(); // warm-up
    median(
        (0..repeats)
            .map(|_| {
                let t = Instant::now();
                f();
                t.elapsed().as_secs_f64()
            })
            .collect(),
    )
}

fn load(s: &FemSystem) -> Vec<f64> {
    (0..s.matrix.dim())
        .map(|i| {
            let p = &s.positions[3 * (i / 3)..3 * (i / 3) + 3];
            match i % 3 {
                0 => -p[2],
                1 => -1.0 + 0.1 * p[0],
                _ => p[0],
            }
        })
        .collect()
}

fn measure(name: &str, s: &FemSystem, repeats: usize) {
    let a = &s.matrix;
    let rhs = load(s);
    let direct = DirectSettings {
        ordering: Ordering::Metis,
        ..DirectSettings::default()
    };
    let mut chol = CholeskySolver::new(direct);
    chol.analyze(a.pattern()).unwrap();
    let (nnz_l, flops) = (chol.stats().factor_nnz, chol.stats().factor_flops);
    let factor = time(repeats, || {
        chol.factor(a).unwrap();
    });
    let solve = time(repeats, || {
        let mut x = rhs.clone();
        chol.solve(&mut x).unwrap();
    });
    let mut y = vec![0.0; a.dim()];
    let matvec = time(repeats.max(20), || {
        symmetric_mul_vec(a, &rhs, &mut y, Parallelism::Sequential)
    });
    let cg_settings = |rebuild_every| CgSettings {
        preconditioner: Preconditioner::Amg,
        amg: AmgSettings {
            rebuild_every,
            ..AmgSettings::default()
        },
        ..CgSettings::default()
    };
    let mut cg = CgSolver::new(cg_settings(1));
    cg.analyze(a.pattern()).unwrap();
    cg.set_coordinates(&s.positions);
    let build = time(repeats, || {
        cg.factor(a).unwrap();
    });
    let mut iterations = 0;
    let cg_solve = time(repeats, || {
        let mut x = rhs.clone();
        iterations = cg.solve(&mut x).unwrap().iterations;
    });
    let amg = cg.stats().amg;
    let mut reuse = CgSolver::new(cg_settings(0));
    reuse.analyze(a.pattern()).unwrap();
    reuse.set_coordinates(&s.positions);
    reuse.factor(a).unwrap();
    let refresh = time(repeats, || {
        reuse.factor(a).unwrap();
    });
    let k = AmgSettings::DEFAULT_REBUILD_EVERY as f64;
    let setup = (build + (k - 1.0) * refresh) / k;
    let direct_total = factor + solve;
    let cg_total = setup + cg_solve;
    let per_iteration = cg_solve / iterations.max(1) as f64;
    let prediction = AutoPrediction::new(nnz_l, flops, a.pattern().nnz());
    println!(
        "{name}: n {}, nnz(A) {}, nnz(L) {nnz_l}, flops {flops:.3e} | factor {factor:.4} s \
         ({:.2e} flop/s), solve {solve:.4} s | mat-vec {matvec:.2e} s ({:.2e} flop/s) | AMG \
         levels {}, op. complexity {:.2}, build {build:.4} s = {:.0} mat-vecs, refresh \
         {refresh:.4} s = {:.0} mat-vecs, {iterations} it at {per_iteration:.2e} s = {:.1} \
         mat-vecs | per Newton iteration: Cholesky {direct_total:.4} s, CG+AMG {cg_total:.4} s \
         -> measured {}, predicted {} ({:.4} vs {:.4} s)",
        a.dim(),
        a.pattern().nnz(),
        flops / factor,
        2.0 * a.pattern().nnz() as f64 / matvec,
        amg.levels,
        amg.operator_complexity,
        build / matvec,
        refresh / matvec,
        per_iteration / matvec,
        if direct_total <= cg_total {
            "cholesky"
        } else {
            "cg"
        },
        if prediction.direct() {
            "cholesky"
        } else {
            "cg"
        },
        prediction.direct_seconds,
        prediction.iterative_seconds,
    );
}

fn main() {
    let repeats = std::env::args()
        .nth(1)
        .and_then(|r| r.parse().ok())
        .unwrap_or(5);
    measure("box_1.5k", &fem_box([10, 5, 5]), repeats);
    measure("box_12k", &fem_box([20, 10, 10]), repeats);
    measure("ball_10k", &fem_ball(6), repeats);
    measure("box_49k", &fem_box([32, 16, 16]), repeats);
    measure("ball_48k", &fem_ball(10), repeats);
    measure("box_96k", &fem_box([40, 20, 20]), repeats);
}
