//! Claims about the subtree-parallel supernodal LLᵀ (`solve::supernodal_tree`): it computes
//! faer's factor (to round-off) in faer's layout, bit-identically for any thread count, and
//! fails where faer's does.

#[path = "support/fem_system.rs"]
mod fem_system;

use std::sync::Arc;

use faer::Side;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{LltError, LltRegularization};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use fem_system::{fem_ball, fem_box};
use softbench::parallel::Parallelism;
use softbench::solve::ordering::nested_dissection;
use softbench::solve::supernodal_tree::{
    DIAGONAL_BLOCK, SOLVE_SPLIT_ENTRIES, ScratchPool, TreeSchedule, factorize, is_postordered,
    postorder_permutation, solve_in_place,
};
use softbench::solve::{
    CholeskySolver, DirectSettings, LinearSolver, Ordering, Scheduler, SolveError,
};
use softbench::sparse::{SparsityPattern, SymmetricMatrix};

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

/// The parallelism of a pool of `threads`, called inside it: `Par::rayon(0)` takes the current
/// pool's size where it is made (outside, the global pool's, so 3 and 4 threads would run as 2).
fn current_par(threads: usize) -> faer::Par {
    let par = if threads > 1 {
        faer::Par::rayon(0)
    } else {
        faer::Par::Seq
    };
    assert_eq!(par.degree(), threads, "made outside the pool of {threads}");
    par
}

/// faer's supernodal symbolic analysis of `a` in `ordering` (METIS composed with a postorder,
/// as the solver does; AMD as faer returns it).
fn symbolic(a: &SymmetricMatrix, ordering: Ordering) -> SymbolicCholesky<usize> {
    let p = a.pattern();
    let params = CholeskySymbolicParams {
        supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
        ..Default::default()
    };
    let (fwd, inv): (Vec<usize>, Vec<usize>) = match ordering {
        Ordering::Metis => {
            let fwd = postorder_permutation(p, &nested_dissection(p).unwrap());
            let mut inv = vec![0; fwd.len()];
            for (i, &o) in fwd.iter().enumerate() {
                inv[o] = i;
            }
            (fwd, inv)
        }
        _ => (Vec::new(), Vec::new()),
    };
    let ord = match ordering {
        Ordering::Metis => {
            SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(&fwd, &inv, p.dim()))
        }
        _ => SymmetricOrdering::Amd,
    };
    factorize_symbolic_cholesky(p.as_faer(), Side::Lower, ord, params).unwrap()
}

/// faer's own numeric LLᵀ (its sequential loop), or the first failing pivot (permuted).
fn faer_factor(a: &SymmetricMatrix, sym: &SymbolicCholesky<usize>) -> Result<Vec<f64>, usize> {
    let mut values = vec![0.0; sym.len_val()];
    let req = sym.factorize_numeric_llt_scratch::<f64>(faer::Par::Seq, Default::default());
    let mut mem = MemBuffer::new(req);
    let result = sym.factorize_numeric_llt(
        &mut values,
        a.as_faer(),
        Side::Lower,
        LltRegularization::default(),
        faer::Par::Seq,
        MemStack::new(&mut mem),
        Default::default(),
    );
    if let Err(LltError::NonPositivePivot { index }) = result {
        return Err(index);
    }
    Ok(values)
}

/// The subtree-parallel LLᵀ on a pool of `threads`, or the first failing pivot (permuted).
fn tree_factor(
    a: &SymmetricMatrix,
    sym: &SymbolicCholesky<usize>,
    threads: usize,
) -> Result<Vec<f64>, usize> {
    let SymbolicCholeskyRaw::Supernodal(sn) = sym.raw() else {
        panic!("forced supernodal");
    };
    assert!(is_postordered(sn));
    let schedule = TreeSchedule::new(sn, a.pattern(), sym.perm().map(|p| p.arrays())).unwrap();
    let scratch = ScratchPool::new(&schedule, threads);
    let mut values = vec![f64::NAN; sym.len_val()];
    pool(threads).install(|| {
        let par = current_par(threads);
        factorize(&mut values, a.values(), sn, &schedule, &scratch, par)
            .map(|()| values)
            .map_err(|e| e.index)
    })
}

/// max |x − y| / max |y| over the lower triangles (faer's storage leaves the strict upper
/// part of each diagonal block unspecified, so compare through a solve-free entry view).
fn relative_difference(x: &[f64], y: &[f64]) -> f64 {
    let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let diff = x
        .iter()
        .zip(y)
        .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
    diff / scale
}

fn cholesky(ordering: Ordering, scheduler: Scheduler) -> CholeskySolver {
    CholeskySolver::new(DirectSettings {
        ordering,
        parallelism: Parallelism::Rayon,
        parallel_min_flops: 0.0,
        scheduler,
        ..Default::default()
    })
}

fn bodies() -> Vec<(&'static str, SymmetricMatrix)> {
    vec![
        ("box 12x6x6", fem_box([12, 6, 6]).matrix),
        ("ball 5", fem_ball(5).matrix),
    ]
}

#[test]
fn subtree_factor_agrees_with_faers_to_round_off() {
    for (name, a) in bodies() {
        for ordering in [Ordering::Amd, Ordering::Metis] {
            let sym = symbolic(&a, ordering);
            let reference = faer_factor(&a, &sym).unwrap();
            for threads in [1, 2, 4] {
                let values = tree_factor(&a, &sym, threads).unwrap();
                let diff = relative_difference(&values, &reference);
                assert!(
                    diff < 1e-12,
                    "{name}, {ordering:?}, {threads} threads: factor differs by {diff:e}"
                );
            }
        }
    }
}

#[test]
fn subtree_factor_is_bit_identical_across_runs_and_thread_counts() {
    let a = fem_box([16, 8, 8]).matrix;
    for ordering in [Ordering::Amd, Ordering::Metis] {
        let sym = symbolic(&a, ordering);
        let one = tree_factor(&a, &sym, 1).unwrap();
        for threads in [1, 2, 3, 4] {
            for _ in 0..2 {
                let values = tree_factor(&a, &sym, threads).unwrap();
                assert!(
                    values
                        .iter()
                        .zip(&one)
                        .all(|(x, y)| x.to_bits() == y.to_bits()),
                    "{ordering:?}: {threads} threads changed the factor's bits"
                );
            }
        }
    }
}

#[test]
fn the_solver_uses_the_subtree_schedule_and_solves_to_1e_10() {
    for (name, a) in bodies() {
        for ordering in [Ordering::Amd, Ordering::Metis] {
            for threads in [2, 4] {
                let (scheduler, residual, x) = pool(threads).install(|| {
                    let mut s = cholesky(ordering, Scheduler::Subtrees);
                    s.analyze(a.pattern()).unwrap();
                    s.factor(&a).unwrap();
                    let mut x: Vec<f64> = (0..a.dim()).map(|i| (i % 17) as f64 - 8.0).collect();
                    let b = x.clone();
                    s.solve(&mut x).unwrap();
                    // The residual recomputed here, not only the solver's own report.
                    let mut ax = vec![0.0; a.dim()];
                    a.mul_vec(&x, &mut ax);
                    let r = ax.iter().zip(&b).map(|(p, q)| (p - q).powi(2)).sum::<f64>();
                    let nb = b.iter().map(|q| q * q).sum::<f64>();
                    (s.stats().factor_scheduler, (r / nb).sqrt(), x)
                });
                assert_eq!(scheduler, "subtrees", "{name}, {ordering:?}");
                assert!(
                    residual < 1e-10,
                    "{name}, {ordering:?}: residual {residual:e}"
                );
                assert!(x.iter().all(|v| v.is_finite()));
            }
        }
    }
}

#[test]
fn the_sequential_and_threaded_solvers_give_the_same_bits() {
    let a = fem_box([16, 8, 8]).matrix;
    let solve = |parallelism, threads| {
        pool(threads).install(|| {
            let mut s = CholeskySolver::new(DirectSettings {
                ordering: Ordering::Metis,
                parallelism,
                parallel_min_flops: 0.0,
                ..Default::default()
            });
            s.analyze(a.pattern()).unwrap();
            assert_eq!(s.stats().factor_scheduler, "subtrees");
            s.factor(&a).unwrap();
            let mut x = vec![1.0; a.dim()];
            s.solve(&mut x).unwrap();
            x
        })
    };
    let sequential = solve(Parallelism::Sequential, 1);
    for threads in [2, 3] {
        let x = solve(Parallelism::Rayon, threads);
        assert!(
            x.iter()
                .zip(&sequential)
                .all(|(p, q)| p.to_bits() == q.to_bits()),
            "{threads} threads"
        );
    }
}

#[test]
fn the_faer_scheduler_setting_keeps_faers_loop() {
    let a = fem_box([6, 3, 3]).matrix;
    let scheduler = pool(2).install(|| {
        let mut s = cholesky(Ordering::Metis, Scheduler::Faer);
        s.analyze(a.pattern()).unwrap();
        s.factor(&a).unwrap();
        s.stats().factor_scheduler
    });
    assert_eq!(scheduler, "faer");
    let mut s = CholeskySolver::new(DirectSettings {
        scheduler: Scheduler::Faer,
        ..Default::default()
    });
    s.analyze(a.pattern()).unwrap();
    assert_eq!(s.stats().factor_scheduler, "faer");
    assert!(!s.stats().parallel_factor);
}

/// `a` with the diagonal entries of `columns` replaced by `-1`.
fn with_negative_diagonal(a: &SymmetricMatrix, columns: &[usize]) -> SymmetricMatrix {
    let mut b = a.clone();
    for &c in columns {
        let slot = b.pattern().find(c, c).unwrap();
        b.values_mut()[slot] = -1.0;
    }
    b
}

#[test]
fn an_indefinite_matrix_fails_at_faers_column() {
    let a = fem_box([12, 6, 6]).matrix;
    let n = a.dim();
    // One bad column; then two far apart, in different subtrees of the nested dissection.
    for bad in [vec![n / 3], vec![5, n - 7], vec![n / 2, n / 5, 11]] {
        let b = with_negative_diagonal(&a, &bad);
        for ordering in [Ordering::Amd, Ordering::Metis] {
            let sym = symbolic(&b, ordering);
            let faers = faer_factor(&b, &sym).unwrap_err();
            for threads in [1, 2, 4] {
                assert_eq!(tree_factor(&b, &sym, threads).unwrap_err(), faers);
            }
            let errors: Vec<SolveError> = [Scheduler::Faer, Scheduler::Subtrees]
                .into_iter()
                .map(|scheduler| {
                    pool(2).install(|| {
                        let mut s = cholesky(ordering, scheduler);
                        s.analyze(b.pattern()).unwrap();
                        s.factor(&b).unwrap_err()
                    })
                })
                .collect();
            assert!(
                matches!(errors[0], SolveError::NotPositiveDefinite { .. }),
                "{:?}",
                errors[0]
            );
            assert_eq!(errors[0], errors[1], "{bad:?}, {ordering:?}");
        }
    }
}

#[test]
fn a_dense_matrix_in_one_supernode_factors() {
    // 6×6 SPD, every entry stored: one supernode, no tree.
    let a = dense(6);
    let sym = symbolic(&a, Ordering::Amd);
    let SymbolicCholeskyRaw::Supernodal(sn) = sym.raw() else {
        unreachable!()
    };
    assert_eq!(sn.n_supernodes(), 1);
    let reference = faer_factor(&a, &sym).unwrap();
    for threads in [1, 2] {
        let values = tree_factor(&a, &sym, threads).unwrap();
        assert!(relative_difference(&values, &reference) < 1e-14);
    }
}

/// A dense SPD matrix of order `n` (diagonally dominant), every entry stored (one supernode).
fn dense(n: usize) -> SymmetricMatrix {
    let col_ptr: Vec<usize> = (0..=n).map(|j| j * n).collect();
    let row_idx: Vec<usize> = (0..n * n).map(|k| k % n).collect();
    let mut a = SymmetricMatrix::zeros(Arc::new(SparsityPattern::from_csc(n, col_ptr, row_idx)));
    for j in 0..n {
        for i in 0..n {
            let slot = a.pattern().find(i, j).unwrap();
            a.values_mut()[slot] = if i == j {
                n as f64
            } else {
                1.0 / (1 + i + j) as f64
            };
        }
    }
    a
}

/// The tree solve against faer's solve with the same factor values (round-off), and its bits
/// on pools of 1–4 threads against the sequential solve: on FEM bodies in both orderings, and
/// on a dense matrix wide enough that its diagonal block is solved in several column blocks
/// whose rectangles split over the pool.
#[test]
fn the_tree_solve_agrees_with_faers_and_gives_the_same_bits_on_any_pool() {
    let wide = 2 * DIAGONAL_BLOCK + SOLVE_SPLIT_ENTRIES / DIAGONAL_BLOCK + 7;
    let mut systems = bodies();
    systems.push(("box 16x8x8", fem_box([16, 8, 8]).matrix));
    systems.push(("dense", dense(wide)));
    for (name, a) in systems {
        for ordering in [Ordering::Amd, Ordering::Metis] {
            let sym = symbolic(&a, ordering);
            let SymbolicCholeskyRaw::Supernodal(sn) = sym.raw() else {
                unreachable!()
            };
            let schedule =
                TreeSchedule::new(sn, a.pattern(), sym.perm().map(|p| p.arrays())).unwrap();
            let values = tree_factor(&a, &sym, 1).unwrap();
            let b: Vec<f64> = (0..a.dim()).map(|i| ((i * 31) % 17) as f64 - 8.0).collect();
            // faer's solve in the permuted order: permute b in, solve, compare there.
            let fwd = sym.perm().map(|p| p.arrays().0.to_vec());
            let at = |i: usize| fwd.as_ref().map_or(i, |f| f[i]);
            let permuted: Vec<f64> = (0..a.dim()).map(|i| b[at(i)]).collect();
            let mut reference = permuted.clone();
            let mut mem = MemBuffer::new(sn.solve_in_place_scratch::<f64>(1, faer::Par::Seq));
            faer::sparse::linalg::cholesky::supernodal::SupernodalLltRef::new(sn, &values)
                .solve_in_place_with_conj(
                    faer::Conj::No,
                    faer::MatMut::from_column_major_slice_mut(&mut reference, a.dim(), 1),
                    faer::Par::Seq,
                    MemStack::new(&mut mem),
                );
            let solve_with = |par: faer::Par| {
                let scratch = ScratchPool::new(&schedule, par.degree());
                let mut x = permuted.clone();
                solve_in_place(&mut x, &values, sn, &schedule, &scratch, par);
                x
            };
            let solve = |threads: usize| pool(threads).install(|| solve_with(current_par(threads)));
            let sequential = solve(1);
            let diff = relative_difference(&sequential, &reference);
            assert!(diff < 1e-12, "{name}, {ordering:?}: {diff:e} from faer's");
            assert_ne!(sequential, permuted, "{name}: the solve changed nothing");
            for threads in 2..=4 {
                let x = solve(threads);
                assert!(
                    x.iter()
                        .zip(&sequential)
                        .all(|(p, q)| p.to_bits() == q.to_bits()),
                    "{name}, {ordering:?}, {threads} threads"
                );
            }
            // From outside any pool (the solve enters the global pool itself).
            let x = solve_with(faer::Par::rayon(2));
            assert_eq!(x, sequential, "{name}, {ordering:?}, from outside the pool");
        }
    }
}

/// Two bodies' systems side by side: a block-diagonal matrix with two components.
fn block_diagonal(a: &SymmetricMatrix, b: &SymmetricMatrix) -> SymmetricMatrix {
    let (na, pa, pb) = (a.dim(), a.pattern(), b.pattern());
    let mut col_ptr = pa.col_ptr().to_vec();
    let offset = pa.nnz();
    col_ptr.extend(pb.col_ptr()[1..].iter().map(|&c| c + offset));
    let mut row_idx = pa.row_idx().to_vec();
    row_idx.extend(pb.row_idx().iter().map(|&r| r + na));
    let pattern = SparsityPattern::from_csc(na + b.dim(), col_ptr, row_idx);
    let mut m = SymmetricMatrix::zeros(Arc::new(pattern));
    m.values_mut()[..offset].copy_from_slice(a.values());
    m.values_mut()[offset..].copy_from_slice(b.values());
    m
}

#[test]
fn disconnected_components_factor_and_solve() {
    let a = block_diagonal(&fem_box([8, 4, 4]).matrix, &fem_ball(4).matrix);
    for ordering in [Ordering::Amd, Ordering::Metis] {
        let sym = symbolic(&a, ordering);
        let reference = faer_factor(&a, &sym).unwrap();
        for threads in [1, 2, 4] {
            let values = tree_factor(&a, &sym, threads).unwrap();
            let diff = relative_difference(&values, &reference);
            assert!(diff < 1e-12, "{ordering:?}, {threads} threads: {diff:e}");
        }
        let residual = pool(2).install(|| {
            let mut s = cholesky(ordering, Scheduler::Subtrees);
            s.analyze(a.pattern()).unwrap();
            s.factor(&a).unwrap();
            assert_eq!(s.stats().factor_scheduler, "subtrees");
            let mut x = vec![1.0; a.dim()];
            s.solve(&mut x).unwrap().relative_residual
        });
        assert!(residual < 1e-10, "{ordering:?}: residual {residual:e}");
    }
}

#[test]
fn postordering_keeps_the_fill_and_makes_subtrees_contiguous() {
    let a = fem_box([10, 5, 5]).matrix;
    let p = a.pattern();
    let nd = nested_dissection(p).unwrap();
    let post = postorder_permutation(p, &nd);
    let mut sorted = post.clone();
    sorted.sort_unstable();
    assert_eq!(
        sorted,
        (0..p.dim()).collect::<Vec<_>>(),
        "not a permutation"
    );
    let analyze = |perm: &[usize], threshold| {
        let mut inv = vec![0; perm.len()];
        for (i, &o) in perm.iter().enumerate() {
            inv[o] = i;
        }
        factorize_symbolic_cholesky(
            p.as_faer(),
            Side::Lower,
            SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(perm, &inv, perm.len())),
            CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: threshold,
                ..Default::default()
            },
        )
        .unwrap()
    };
    // Simplicial storage is exactly nnz(L).
    let exact_fill =
        |perm: &[usize]| analyze(perm, SupernodalThreshold::FORCE_SIMPLICIAL).len_val();
    assert_eq!(exact_fill(&post), exact_fill(&nd));
    let s = analyze(&post, SupernodalThreshold::FORCE_SUPERNODAL);
    let SymbolicCholeskyRaw::Supernodal(sn) = s.raw() else {
        unreachable!()
    };
    assert!(is_postordered(sn));
}

#[test]
fn the_scheduler_is_read_from_a_config_and_a_bad_name_lists_the_valid_ones() {
    let s: DirectSettings = toml::from_str("scheduler = \"faer\"").unwrap();
    assert_eq!(s.scheduler, Scheduler::Faer);
    assert_eq!(DirectSettings::default().scheduler, Scheduler::Subtrees);
    let e = toml::from_str::<DirectSettings>("scheduler = \"tree\"")
        .unwrap_err()
        .to_string();
    assert!(e.contains("subtrees") && e.contains("faer"), "{e}");
}

/// On the 49k-tet box the root's fronts are large enough for faer's parallel dense kernels and
/// solves: the factorization (its kernels split by output, each entry summed in one order) and
/// the solves (a fixed task count) still give the same bits on pools of one, two and three
/// threads. With the pool's thread count as faer's task count the solve changed 15,593 of the
/// 27,744 entries here.
#[test]
fn the_49k_box_solves_to_the_same_bits_on_one_thread_and_two() {
    let a = fem_box([32, 16, 16]).matrix;
    let run = |threads| {
        pool(threads).install(|| {
            let mut s = CholeskySolver::new(DirectSettings {
                parallelism: Parallelism::Rayon,
                ..Default::default()
            });
            s.analyze(a.pattern()).unwrap();
            s.factor(&a).unwrap();
            assert_eq!(s.stats().parallel_factor, threads > 1);
            let mut x: Vec<f64> = (0..a.dim()).map(|i| (i % 13) as f64 - 6.0).collect();
            s.solve(&mut x).unwrap();
            x
        })
    };
    let x1 = run(1);
    for threads in [2, 3] {
        let x = run(threads);
        let differing = x1
            .iter()
            .zip(&x)
            .filter(|(p, q)| p.to_bits() != q.to_bits())
            .count();
        assert_eq!(differing, 0, "{threads} threads: of {} entries", x.len());
    }
}

/// The split supernodes and the profile built on them describe one partition: every
/// supernode is split or in exactly one task subtree (headed by a root or a split node's
/// child), the flops add up, and a split node is never inside a task.
#[test]
fn the_split_profile_partitions_the_supernodes_into_tasks_and_split_nodes() {
    for (name, a) in bodies() {
        let sym = symbolic(&a, Ordering::Metis);
        let SymbolicCholeskyRaw::Supernodal(sn) = sym.raw() else {
            panic!("forced supernodal");
        };
        let schedule = TreeSchedule::new(sn, a.pattern(), sym.perm().map(|p| p.arrays())).unwrap();
        let ns = sn.n_supernodes();
        // Parent of each supernode: the one holding the first row below its diagonal block.
        let parent = |s: usize| -> Option<usize> {
            let start = sn.col_ptr_for_row_idx()[s];
            let first = *sn.row_idx()[start..start + sn.nnz_per_super()[s]].first()?;
            Some(sn.supernode_end().partition_point(|&e| e <= first))
        };
        for threads in [1, 2, 4] {
            let split = schedule.split_supernodes(threads);
            let (in_tasks, in_split, tasks, split_count) = schedule.split_profile(threads);
            assert_eq!(split_count, split.len(), "{name}, {threads} threads");
            let total = schedule.total_flops();
            assert!(
                (in_tasks + in_split - total).abs() <= 1e-9 * total,
                "{name}, {threads} threads"
            );
            let is_split = |s: usize| split.binary_search(&s).is_ok();
            // A task head is a non-split supernode whose parent is split or absent.
            let heads: Vec<usize> = (0..ns)
                .filter(|&s| !is_split(s) && parent(s).is_none_or(is_split))
                .collect();
            assert_eq!(tasks, heads.len(), "{name}, {threads} threads");
            // Above a split node only split nodes: its ancestors all wait for it.
            for &s in &split {
                let mut p = parent(s);
                while let Some(q) = p {
                    assert!(is_split(q), "{name}: split {s} under task node {q}");
                    p = parent(q);
                }
            }
        }
        // More threads, a finer grain: at least as many split nodes, and some on four.
        let (two, four) = (schedule.split_supernodes(2), schedule.split_supernodes(4));
        assert!(
            !four.is_empty() && four.len() >= two.len(),
            "{name}: {two:?} {four:?}"
        );
    }
}
