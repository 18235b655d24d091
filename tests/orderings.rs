//! Claims about the fill-reducing orderings and the threads of the direct solvers, checked on
//! real backward-Euler systems of generated FEM bodies.

#[path = "support/fem_system.rs"]
mod fem_system;

use fem_system::{fem_ball, fem_box};
use softbench::parallel::Parallelism;
use softbench::solve::{
    CholeskySolver, DirectSettings, LinearSolver, Ordering, SolverStats, Supernodal,
};
use softbench::sparse::SymmetricMatrix;

fn analyzed(a: &SymmetricMatrix, ordering: Ordering, parallelism: Parallelism) -> CholeskySolver {
    analyzed_with(
        a,
        ordering,
        parallelism,
        softbench::solve::PARALLEL_MIN_FLOPS,
    )
}

fn analyzed_with(
    a: &SymmetricMatrix,
    ordering: Ordering,
    parallelism: Parallelism,
    parallel_min_flops: f64,
) -> CholeskySolver {
    let mut s = CholeskySolver::new(DirectSettings {
        ordering,
        supernodal: Supernodal::Auto,
        parallelism,
        parallel_min_flops,
        ..Default::default()
    });
    s.analyze(a.pattern()).unwrap();
    s
}

fn stats(a: &SymmetricMatrix, ordering: Ordering) -> SolverStats {
    analyzed(a, ordering, Parallelism::Sequential)
        .stats()
        .clone()
}

fn solve(s: &mut CholeskySolver, a: &SymmetricMatrix) -> (Vec<f64>, f64) {
    s.factor(a).unwrap();
    let mut x: Vec<f64> = (0..a.dim())
        .map(|i| ((i * 7919) % 101) as f64 - 50.0)
        .collect();
    let report = s.solve(&mut x).unwrap();
    (x, report.relative_residual)
}

#[test]
fn nested_dissection_leaves_less_fill_and_fewer_flops_than_amd_on_a_3d_box() {
    // 24×12×12 cells, 20,736 tets.
    let a = fem_box([24, 12, 12]).matrix;
    let (amd, nd) = (stats(&a, Ordering::Amd), stats(&a, Ordering::Metis));
    assert_eq!((amd.ordering, nd.ordering), ("amd", "metis"));
    assert!(
        (nd.factor_nnz as f64) < 0.9 * amd.factor_nnz as f64,
        "nnz(L): metis {} vs amd {}",
        nd.factor_nnz,
        amd.factor_nnz
    );
    assert!(
        nd.factor_flops < 0.8 * amd.factor_flops,
        "flops: metis {:e} vs amd {:e}",
        nd.factor_flops,
        amd.factor_flops
    );
}

#[test]
fn metis_ordered_cholesky_solves_to_rounding_error() {
    for a in [fem_box([8, 4, 4]).matrix, fem_ball(3).matrix] {
        let mut s = analyzed(&a, Ordering::Metis, Parallelism::Sequential);
        let (_, residual) = solve(&mut s, &a);
        assert!(residual < 1e-12, "relative residual {residual:e}");
    }
}

#[test]
fn auto_keeps_the_ordering_with_fewer_predicted_flops() {
    for a in [
        fem_box([12, 6, 6]).matrix,
        fem_box([20, 1, 1]).matrix,
        fem_ball(4).matrix,
    ] {
        let (amd, nd, auto) = (
            stats(&a, Ordering::Amd),
            stats(&a, Ordering::Metis),
            stats(&a, Ordering::Auto),
        );
        let best = if nd.factor_flops < amd.factor_flops {
            &nd
        } else {
            &amd
        };
        assert_eq!(auto.ordering, best.ordering);
        assert_eq!(auto.factor_flops, best.factor_flops);
        assert_eq!(auto.factor_nnz, best.factor_nnz);
    }
}

/// On a run with threads `auto` computes AMD and METIS side by side; it keeps the same
/// ordering, with the same cost, as one thread does.
#[test]
fn auto_orders_on_two_threads_as_on_one() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    for a in [fem_box([12, 6, 6]).matrix, fem_ball(4).matrix] {
        let one = analyzed(&a, Ordering::Auto, Parallelism::Sequential);
        let two = pool.install(|| analyzed(&a, Ordering::Auto, Parallelism::Rayon));
        let (one, two) = (one.stats(), two.stats());
        assert_eq!(one.ordering, two.ordering);
        assert_eq!(
            (one.factor_flops, one.factor_nnz),
            (two.factor_flops, two.factor_nnz)
        );
    }
}

/// Column counts of L (diagonal included) in the identity ordering, by the elimination game
/// on a dense boolean pattern.
fn column_counts(a: &SymmetricMatrix) -> Vec<usize> {
    let n = a.dim();
    let mut l = vec![vec![false; n]; n];
    for (i, row) in l.iter_mut().enumerate() {
        for (j, e) in row.iter_mut().enumerate() {
            *e = a.pattern().find(i, j).is_some();
        }
    }
    for k in 0..n {
        let below: Vec<usize> = (k + 1..n).filter(|&i| l[i][k]).collect();
        for &i in &below {
            for &j in &below {
                l[i][j] = true;
            }
        }
    }
    (0..n)
        .map(|j| (j..n).filter(|&i| l[i][j]).count())
        .collect()
}

#[test]
fn predicted_flops_are_the_sum_of_squared_column_counts() {
    for cells in [[1, 1, 1], [3, 1, 1], [2, 2, 1]] {
        let a = fem_box(cells).matrix;
        let counts = column_counts(&a);
        for supernodal in [Supernodal::Simplicial, Supernodal::Supernodal] {
            let mut s = CholeskySolver::new(DirectSettings {
                ordering: Ordering::Identity,
                supernodal,
                parallelism: Parallelism::Sequential,
                ..Default::default()
            });
            s.analyze(a.pattern()).unwrap();
            assert_eq!(s.stats().factor_nnz, counts.iter().sum::<usize>());
            let flops: f64 = counts.iter().map(|&c| (c * c) as f64).sum();
            assert_eq!(s.stats().factor_flops, flops);
        }
    }
}

#[test]
fn threaded_factorization_is_reproducible_and_agrees_to_round_off() {
    // Threads from the first flop on, so the dense kernels of every supernode split.
    let a = fem_box([24, 12, 12]).matrix;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let on_two_threads = || {
        pool.install(|| {
            let mut s = analyzed_with(&a, Ordering::Metis, Parallelism::Rayon, 0.0);
            let x = solve(&mut s, &a).0;
            (s.stats().parallel_factor, x)
        })
    };
    let (parallel, x_par) = on_two_threads();
    assert!(
        parallel,
        "the flops rule kept a large factorization sequential"
    );
    assert!(
        on_two_threads().1 == x_par,
        "two runs on two threads differ"
    );
    let mut s = analyzed(&a, Ordering::Metis, Parallelism::Sequential);
    assert!(!s.stats().parallel_factor);
    let x_seq = solve(&mut s, &a).0;
    let scale = x_seq.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let diff = x_par
        .iter()
        .zip(&x_seq)
        .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
    assert!(
        diff <= 1e-10 * scale,
        "threads moved the solution by {diff:e} (scale {scale:e})"
    );
}

#[test]
fn the_flops_rule_keeps_small_factorizations_sequential() {
    let a = fem_box([8, 4, 4]).matrix;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let s = pool.install(|| analyzed(&a, Ordering::Metis, Parallelism::Rayon));
    assert!(s.stats().factor_flops < softbench::solve::PARALLEL_MIN_FLOPS);
    assert!(!s.stats().parallel_factor);
}

#[test]
fn metis_orderings_computed_at_once_on_several_threads_equal_the_ordering_alone() {
    // GKlib's random generator is process-wide; unserialized concurrent calls interleave it.
    let patterns: Vec<_> = [[6, 3, 3], [8, 4, 3], [5, 5, 4], [7, 3, 5]]
        .into_iter()
        .map(|cells| fem_box(cells).matrix.pattern().clone())
        .collect();
    let alone: Vec<Vec<usize>> = patterns
        .iter()
        .map(|p| softbench::solve::ordering::nested_dissection(p).unwrap())
        .collect();
    for _ in 0..20 {
        std::thread::scope(|scope| {
            let handles: Vec<_> = patterns
                .iter()
                .map(|p| scope.spawn(|| softbench::solve::ordering::nested_dissection(p).unwrap()))
                .collect();
            for (handle, expected) in handles.into_iter().zip(&alone) {
                assert_eq!(&handle.join().unwrap(), expected);
            }
        });
    }
}

/// The fast path is the default: a solver built from `DirectSettings::default()` (what a
/// scene gets when it sets nothing) asks for `auto` and ends with the ordering of fewer
/// predicted flops, never the other one — METIS on a 3D box, where AMD costs 1.5× the flops.
#[test]
fn the_default_ordering_is_auto_and_keeps_the_cheaper_one() {
    assert_eq!(DirectSettings::default().ordering, Ordering::Auto);
    let a = fem_box([20, 10, 10]).matrix;
    let mut s = CholeskySolver::new(DirectSettings::default());
    s.analyze(a.pattern()).unwrap();
    let chosen = s.stats().clone();
    let (amd, nd) = (stats(&a, Ordering::Amd), stats(&a, Ordering::Metis));
    assert!(
        nd.factor_flops < amd.factor_flops,
        "premise: METIS is cheaper here"
    );
    assert_eq!(chosen.ordering, "metis");
    assert_eq!(chosen.factor_flops, nd.factor_flops);
    assert_eq!(chosen.factor_nnz, nd.factor_nnz);
    // A scene file without solver settings resolves to the same default.
    let config: softbench::solve::SolverSettings = toml::from_str("").unwrap();
    assert_eq!(config.direct.ordering, Ordering::Auto);
}

/// Each scheduler has its own threshold, measured by `cargo bench --bench thread_crossover`:
/// the subtree scheduler pays on two threads from ~5e8 flops, faer's loop (parallel only
/// inside dense kernels) from billions, so a 6.9e8-flop factorization (the 12k box) takes two
/// threads with the first and one with the second.
#[test]
fn each_scheduler_has_its_own_flops_rule() {
    let a = fem_box([20, 10, 10]).matrix;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let parallel = |scheduler| {
        pool.install(|| {
            let mut s = CholeskySolver::new(DirectSettings {
                ordering: Ordering::Metis,
                parallelism: Parallelism::Rayon,
                scheduler,
                ..Default::default()
            });
            s.analyze(a.pattern()).unwrap();
            let flops = s.stats().factor_flops;
            assert!(
                (softbench::solve::PARALLEL_MIN_FLOPS
                    ..softbench::solve::FAER_LOOP_PARALLEL_MIN_FLOPS)
                    .contains(&flops),
                "{flops:e} flops"
            );
            s.stats().parallel_factor
        })
    };
    assert!(parallel(softbench::solve::Scheduler::Subtrees));
    assert!(!parallel(softbench::solve::Scheduler::Faer));
}
