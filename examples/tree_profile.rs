//! Where the work of the subtree-parallel LLᵀ sits, for the meshes of `cholmod_export`
//! (METIS composed with its postorder, as the solver orders them): the estimated flops in
//! sequential subtree tasks and in the supernodes above them that wait for their children
//! ("split" supernodes, whose only parallelism when they have no concurrent sibling is their
//! dense kernels), per thread count; the share of L's values in split supernodes (what a
//! subtree-parallel triangular solve would still do on one thread); the updates the last
//! root receives, by size against the kernels' parallel threshold; and the heaviest
//! supernodes by left-looking work (the updates they receive plus their own dense LLᵀ and
//! triangular solve).
//!
//! `cargo run --release --example tree_profile -- [mesh ...]` (box_12k, box_49k, ball_83k;
//! default box_49k). Counts only, no timing.

#[path = "../tests/support/fem_system.rs"]
mod fem_system;

use anyhow::{Context, bail};
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::sparse::linalg::cholesky::{
    SymbolicCholeskyRaw, SymmetricOrdering, factorize_symbolic_cholesky,
};
use softbench::solve::ordering::nested_dissection;
use softbench::solve::supernodal_tree::{
    KERNEL_PARALLEL_FLOPS, TreeSchedule, postorder_permutation,
};
use softbench::sparse::SymmetricMatrix;

const MESHES: [&str; 3] = ["box_12k", "box_49k", "ball_83k"];

fn system(name: &str) -> SymmetricMatrix {
    match name {
        "box_12k" => fem_system::fem_box([20, 10, 10]).matrix,
        "box_49k" => fem_system::fem_box([32, 16, 16]).matrix,
        _ => fem_system::fem_ball(12).matrix,
    }
}

/// The rows of supernode `s` below its diagonal block.
fn pattern(sn: &SymbolicSupernodalCholesky<usize>, s: usize) -> &[usize] {
    let start = sn.col_ptr_for_row_idx()[s];
    &sn.row_idx()[start..start + sn.nnz_per_super()[s]]
}

/// Left-looking work of each supernode in flops: 2 m k n per update it receives, plus
/// c³/3 (dense LLᵀ) and c² r (triangular solve) of its own.
fn left_looking_work(sn: &SymbolicSupernodalCholesky<usize>) -> Vec<f64> {
    let ns = sn.n_supernodes();
    let (begin, end) = (sn.supernode_begin(), sn.supernode_end());
    let mut col_to_super = vec![0; sn.nrows()];
    for s in 0..ns {
        col_to_super[begin[s]..end[s]].fill(s);
    }
    let mut work = vec![0.0; ns];
    for d in 0..ns {
        let p = pattern(sn, d);
        let c = (end[d] - begin[d]) as f64;
        let mut i = 0;
        while i < p.len() {
            let s = col_to_super[p[i]];
            let k = p[i..].partition_point(|&r| r < end[s]);
            work[s] += 2.0 * ((p.len() - i) * k) as f64 * c;
            i += k;
        }
        work[d] += c * c * c / 3.0 + c * c * p.len() as f64;
    }
    work
}

/// The updates supernode `s` receives (2 m k n flops each), split at the flops from which a
/// kernel call runs on the pool: `(small flops, large flops, small count, large count)`.
fn root_updates(sn: &SymbolicSupernodalCholesky<usize>, s: usize) -> (f64, f64, usize, usize) {
    let (begin, end) = (sn.supernode_begin(), sn.supernode_end());
    let (mut small, mut large, mut ns, mut nl) = (0.0, 0.0, 0, 0);
    for d in 0..s {
        let p = pattern(sn, d);
        let first = p.partition_point(|&r| r < begin[s]);
        let k = p[first..].partition_point(|&r| r < end[s]);
        if k == 0 {
            continue;
        }
        let f = 2.0 * ((p.len() - first) * k * (end[d] - begin[d])) as f64;
        if f >= KERNEL_PARALLEL_FLOPS {
            large += f;
            nl += 1;
        } else {
            small += f;
            ns += 1;
        }
    }
    (small, large, ns, nl)
}

fn profile(name: &str) -> anyhow::Result<()> {
    let a = system(name);
    let p = a.pattern();
    let fwd = postorder_permutation(p, &nested_dissection(p)?);
    let mut inv = vec![0; fwd.len()];
    for (i, &o) in fwd.iter().enumerate() {
        inv[o] = i;
    }
    let symbolic = factorize_symbolic_cholesky(
        p.as_faer(),
        faer::Side::Lower,
        SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(&fwd, &inv, p.dim())),
        Default::default(),
    )
    .map_err(|e| anyhow::anyhow!("{e:?}"))
    .context("symbolic analysis")?;
    let SymbolicCholeskyRaw::Supernodal(sn) = symbolic.raw() else {
        bail!("{name}: faer chose a simplicial factorization");
    };
    let schedule = TreeSchedule::new(sn, p, symbolic.perm().map(|q| q.arrays()))?;
    let total = schedule.total_flops();
    println!(
        "{name}: n = {}, {} supernodes, {total:.3e} estimated flops",
        p.dim(),
        sn.n_supernodes()
    );
    for threads in [2, 4] {
        let (in_tasks, in_split, tasks, split) = schedule.split_profile(threads);
        println!(
            "  {threads} threads: {tasks} subtree tasks ({:.0} % of flops), {split} split \
             supernodes ({:.0} %)",
            100.0 * in_tasks / total,
            100.0 * in_split / total
        );
    }
    for threads in [2, 4] {
        let split = schedule.split_supernodes(threads);
        let vals = |s: usize| (sn.col_ptr_for_val()[s + 1] - sn.col_ptr_for_val()[s]) as f64;
        let in_split: f64 = split.iter().map(|&s| vals(s)).sum();
        println!(
            "  {threads} threads: {:.0} % of L's values in split supernodes (what a \
             subtree-parallel solve would leave on one thread)",
            100.0 * in_split / sn.len_val() as f64
        );
    }
    let root = sn.n_supernodes() - 1;
    let (small, large, count_small, count_large) = root_updates(sn, root);
    println!(
        "  updates into the last root: {count_large} of >= {KERNEL_PARALLEL_FLOPS:.0e} flops ({large:.3e}), \
         {count_small} smaller ({small:.3e})"
    );
    let work = left_looking_work(sn);
    let all: f64 = work.iter().sum();
    let mut order: Vec<usize> = (0..work.len()).collect();
    order.sort_by(|&x, &y| work[y].total_cmp(&work[x]));
    println!("  heaviest supernodes by left-looking work ({all:.3e} flops in all):");
    for &s in order.iter().take(6) {
        println!(
            "    supernode {s}: {} columns, {} rows below, {:.3e} flops ({:.1} %){}",
            sn.supernode_end()[s] - sn.supernode_begin()[s],
            sn.nnz_per_super()[s],
            work[s],
            100.0 * work[s] / all,
            if s + 1 == sn.n_supernodes() {
                ", the last root"
            } else {
                ""
            }
        );
    }
    Ok(())
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let meshes: Vec<&str> = if args.is_empty() {
        vec!["box_49k"]
    } else {
        args.iter().map(String::as_str).collect()
    };
    for m in meshes {
        if !MESHES.contains(&m) {
            bail!("unknown mesh {m:?}; valid: {MESHES:?}");
        }
        profile(m)?;
    }
    Ok(())
}
