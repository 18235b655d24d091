//! The elimination tree of a permuted sparse matrix; the postorder that makes every subtree a
//! contiguous range of columns (so of supernodes), which the subtree schedule needs; and the
//! column counts of L, which give nnz(L) and the flops without a symbolic factorization.

use super::{NONE, exclusive_prefix_sum};
use crate::sparse::SparsityPattern;

/// The elimination tree of `P A Pᵀ` (`fwd[new] = old`, `inv[old] = new`; `pattern` read as
/// its lower triangle): `parent[k]`, or `NONE` at a root. Liu's algorithm with path
/// compression, O(nnz(A) log n) time, O(n) memory.
pub fn elimination_tree(pattern: &SparsityPattern, fwd: &[usize], inv: &[usize]) -> Vec<usize> {
    let n = pattern.dim();
    let (cp, ri) = (pattern.col_ptr(), pattern.row_idx());
    let mut parent = vec![NONE; n];
    let mut ancestor = vec![NONE; n];
    for (k, &old) in fwd.iter().enumerate() {
        for &r in &ri[cp[old]..cp[old + 1]] {
            let mut i = inv[r];
            while i != NONE && i < k {
                let next = ancestor[i];
                ancestor[i] = k;
                if next == NONE {
                    parent[i] = k;
                }
                i = next;
            }
        }
    }
    parent
}

/// A postorder of the elimination tree of `P A Pᵀ` composed with `perm` (`perm[new] = old`):
/// the same fill and flops, with every subtree a contiguous range of columns (and so of
/// supernodes). `pattern` is read as its lower triangle.
pub fn postorder_permutation(pattern: &SparsityPattern, perm: &[usize]) -> Vec<usize> {
    let n = pattern.dim();
    let mut inv = vec![0usize; n];
    for (new, &old) in perm.iter().enumerate() {
        inv[old] = new;
    }
    let parent = elimination_tree(pattern, perm, &inv);
    postorder(&parent).iter().map(|&k| perm[k]).collect()
}

/// A postorder of the forest `parent` (`NONE` at a root): `post[k]` is the k-th node visited,
/// children in ascending order, every subtree a contiguous range ending at its root.
pub fn postorder(parent: &[usize]) -> Vec<usize> {
    let n = parent.len();
    let mut child_count = vec![0usize; n];
    for &p in parent {
        if p != NONE {
            child_count[p] += 1;
        }
    }
    let child_ptr = exclusive_prefix_sum(&child_count);
    let mut child_idx = vec![0usize; n];
    let mut fill = child_ptr[..n].to_vec();
    for (j, &p) in parent.iter().enumerate() {
        if p != NONE {
            child_idx[fill[p]] = j;
            fill[p] += 1;
        }
    }
    let mut post = Vec::with_capacity(n);
    let mut stack: Vec<(usize, usize)> = Vec::new();
    for root in (0..n).filter(|&j| parent[j] == NONE) {
        stack.push((root, child_ptr[root]));
        while let Some(top) = stack.last_mut() {
            let (node, next) = *top;
            if next < child_ptr[node + 1] {
                top.1 += 1;
                let c = child_idx[next];
                stack.push((c, child_ptr[c]));
            } else {
                post.push(node);
                stack.pop();
            }
        }
    }
    post
}

/// The number of entries in each column of L (diagonal included) for `P A Pᵀ` (`fwd[new] =
/// old`, `inv[old] = new`), given its elimination tree `parent`. Gilbert, Ng and Peyton's
/// algorithm: a column's count is the number of row subtrees it lies in, found from the
/// leaves of those subtrees and their least common ancestors in a postorder, in O(nnz(A)
/// α(n)) time and O(n) memory — not O(nnz(L)), so predicting a factorization's cost stays
/// cheap beside the factorization however dense L gets.
pub fn column_counts(
    pattern: &SparsityPattern,
    fwd: &[usize],
    inv: &[usize],
    parent: &[usize],
) -> Vec<usize> {
    let n = pattern.dim();
    let (cp, ri) = (pattern.col_ptr(), pattern.row_idx());
    let post = postorder(parent);
    // first[j]: the postorder index of j's first descendant. delta[j] starts at 1 for a leaf
    // of the elimination tree, collects +1 per row subtree that has j as a leaf and -1 per
    // least common ancestor and per child; the counts are its sums over subtrees.
    let mut first = vec![NONE; n];
    let mut delta = vec![0isize; n];
    for (k, &node) in post.iter().enumerate() {
        delta[node] = isize::from(first[node] == NONE);
        let mut j = node;
        while j != NONE && first[j] == NONE {
            first[j] = k;
            j = parent[j];
        }
    }
    // For row i: the largest `first` of a leaf seen so far, and the previous leaf.
    let mut max_first = vec![NONE; n];
    let mut prev_leaf = vec![NONE; n];
    // Ancestors in a disjoint-set forest over the processed nodes, with path compression.
    let mut ancestor: Vec<usize> = (0..n).collect();
    for &j in &post {
        if parent[j] != NONE {
            delta[parent[j]] -= 1;
        }
        for &r in &ri[cp[fwd[j]]..cp[fwd[j] + 1]] {
            let i = inv[r];
            // j is a leaf of row i's subtree only if no earlier leaf's subtree holds it.
            if i <= j || (max_first[i] != NONE && first[j] <= max_first[i]) {
                continue;
            }
            max_first[i] = first[j];
            let previous = prev_leaf[i];
            prev_leaf[i] = j;
            delta[j] += 1;
            if previous != NONE {
                let mut q = previous;
                while q != ancestor[q] {
                    q = ancestor[q];
                }
                let mut s = previous;
                while s != q {
                    let next = ancestor[s];
                    ancestor[s] = q;
                    s = next;
                }
                // q: the least common ancestor of the previous leaf and j.
                delta[q] -= 1;
            }
        }
        if parent[j] != NONE {
            ancestor[j] = parent[j];
        }
    }
    // A parent's index exceeds its children's, so one ascending pass sums every subtree.
    for j in 0..n {
        if parent[j] != NONE {
            delta[parent[j]] += delta[j];
        }
    }
    delta.into_iter().map(|d| d as usize).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The counts by walking each row's subtree: O(nnz(L)), obviously right.
    fn counts_by_row_subtrees(
        pattern: &SparsityPattern,
        fwd: &[usize],
        inv: &[usize],
        parent: &[usize],
    ) -> Vec<usize> {
        let n = pattern.dim();
        let (cp, ri) = (pattern.col_ptr(), pattern.row_idx());
        let mut counts = vec![1usize; n];
        let mut mark = vec![NONE; n];
        for k in 0..n {
            mark[k] = k;
            for i in ri[cp[fwd[k]]..cp[fwd[k] + 1]].iter().map(|&r| inv[r]) {
                let mut j = i;
                while j < k && mark[j] != k {
                    counts[j] += 1;
                    mark[j] = k;
                    j = parent[j];
                }
            }
        }
        counts
    }

    /// A symmetric pattern (both triangles, diagonal included) of a 3D grid graph with some
    /// long-range edges, shuffled by a fixed pseudo-random permutation.
    fn grid_pattern(side: usize, seed: u64) -> (SparsityPattern, Vec<usize>) {
        let n = side * side * side;
        let id = |x: usize, y: usize, z: usize| (z * side + y) * side + x;
        let mut cols: Vec<Vec<usize>> = (0..n).map(|i| vec![i]).collect();
        let link = |a: usize, b: usize, cols: &mut Vec<Vec<usize>>| {
            cols[a].push(b);
            cols[b].push(a);
        };
        let mut state = seed;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 33) as usize
        };
        for z in 0..side {
            for y in 0..side {
                for x in 0..side {
                    if x + 1 < side {
                        link(id(x, y, z), id(x + 1, y, z), &mut cols);
                    }
                    if y + 1 < side {
                        link(id(x, y, z), id(x, y + 1, z), &mut cols);
                    }
                    if z + 1 < side {
                        link(id(x, y, z), id(x, y, z + 1), &mut cols);
                    }
                }
            }
        }
        for _ in 0..n / 10 {
            let (a, b) = (next() % n, next() % n);
            if a != b {
                link(a, b, &mut cols);
            }
        }
        let mut col_ptr = vec![0];
        let mut row_idx = Vec::new();
        for c in &mut cols {
            c.sort_unstable();
            c.dedup();
            row_idx.extend_from_slice(c);
            col_ptr.push(row_idx.len());
        }
        let mut perm: Vec<usize> = (0..n).collect();
        for i in (1..n).rev() {
            perm.swap(i, next() % (i + 1));
        }
        (SparsityPattern::from_csc(n, col_ptr, row_idx), perm)
    }

    #[test]
    fn column_counts_match_the_row_subtree_walk() {
        for (side, seed) in [(1, 1), (2, 2), (5, 3), (8, 4), (11, 5)] {
            let (pattern, shuffled) = grid_pattern(side, seed);
            let n = pattern.dim();
            for fwd in [(0..n).collect::<Vec<_>>(), shuffled] {
                let mut inv = vec![0; n];
                for (new, &old) in fwd.iter().enumerate() {
                    inv[old] = new;
                }
                let parent = elimination_tree(&pattern, &fwd, &inv);
                assert_eq!(
                    column_counts(&pattern, &fwd, &inv, &parent),
                    counts_by_row_subtrees(&pattern, &fwd, &inv, &parent),
                    "side {side}"
                );
            }
        }
    }

    #[test]
    fn a_postorder_keeps_every_subtree_contiguous() {
        let (pattern, fwd) = grid_pattern(6, 9);
        let n = pattern.dim();
        let mut inv = vec![0; n];
        for (new, &old) in fwd.iter().enumerate() {
            inv[old] = new;
        }
        let parent = elimination_tree(&pattern, &fwd, &inv);
        let post = postorder(&parent);
        let mut position = vec![0; n];
        for (k, &node) in post.iter().enumerate() {
            position[node] = k;
        }
        // Every child comes before its parent, and a subtree's size equals its span.
        let mut size = vec![1usize; n];
        for &node in &post {
            if parent[node] != NONE {
                assert!(position[node] < position[parent[node]]);
                size[parent[node]] += size[node];
            }
        }
        let mut lowest = position.clone();
        for &node in &post {
            if parent[node] != NONE {
                lowest[parent[node]] = lowest[parent[node]].min(lowest[node]);
            }
        }
        for j in 0..n {
            assert_eq!(position[j] + 1 - lowest[j], size[j]);
        }
    }
}
