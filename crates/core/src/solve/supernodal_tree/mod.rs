//! Subtree-parallel supernodal numeric LLᵀ over faer's symbolic analysis.
//!
//! faer 0.24's supernodal numeric factorization walks the supernodes in one sequential
//! left-looking loop and parallelizes only inside each supernode's dense kernels, so the many
//! small supernodes of the elimination tree's lower levels get no parallelism. Here the
//! supernodal elimination tree is factored subtree by subtree: independent subtrees run
//! concurrently (`rayon::join` over disjoint, contiguous ranges of the value storage), each
//! one sequentially; a supernode whose subtree is split waits for its children and then runs
//! its own dense kernels, on the pool when its front is large (the separators near the root).
//!
//! The values are written in exactly faer's layout (each supernode a column-major block of
//! `ncols + pattern` rows), so faer's solve could read them unchanged. Every supernode applies its
//! descendants' updates in ascending order with the same kernels whatever the schedule, so
//! the factor is bit-identical for any thread count.
//!
//! [`TreeSchedule`] is built once per symbolic analysis (elimination tree, descendant lists,
//! flop estimates, where each entry of `A` lands in L); [`ScratchPool`] holds per-worker
//! buffers that persist across factorizations, so the numeric phase allocates nothing once
//! every worker has run.
//!
//! The module is in four parts: `etree` (the elimination tree, the postorder that makes every
//! subtree contiguous, and L's column counts), `schedule` (what the numeric phase needs per
//! symbolic analysis), `numeric` (the factorization itself) and `solve` (the triangular solves
//! with the factor, scheduled the same way).

mod etree;
mod numeric;
mod schedule;
mod solve;

pub use etree::{column_counts, elimination_tree, postorder, postorder_permutation};
pub use numeric::{
    KERNEL_PARALLEL_FLOPS, NonPositivePivot, PARALLEL_MEMORY_ENTRIES, ScratchPool, factorize,
};
pub use schedule::{MIN_TASK_FLOPS, ScheduleError, TASKS_PER_THREAD, TreeSchedule, is_postordered};
pub use solve::{DIAGONAL_BLOCK, SOLVE_SPLIT_ENTRIES, solve_in_place};

/// "No parent" in an elimination tree; "no failure yet" in a factorization.
const NONE: usize = usize::MAX;

/// `[0, c0, c0 + c1, …]`, one longer than `counts`.
fn exclusive_prefix_sum(counts: &[usize]) -> Vec<usize> {
    let mut ptr = Vec::with_capacity(counts.len() + 1);
    ptr.push(0);
    let mut sum = 0;
    for &c in counts {
        sum += c;
        ptr.push(sum);
    }
    ptr
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prefix_sum_is_one_longer() {
        assert_eq!(exclusive_prefix_sum(&[2, 0, 3]), vec![0, 2, 2, 5]);
    }
}
