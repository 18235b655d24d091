//! The V-cycle's smoother: a Gauss–Seidel sweep before the coarse correction and the reverse
//! sweep after it, so the cycle stays symmetric positive definite as CG requires.
//!
//! Two orders, a setting each ([`AmgSmoother`]):
//! - `gauss-seidel`: DOF order, one thread;
//! - `multicolour-gauss-seidel` (default): the nodes of each level (its DOF blocks: 3 on the
//!   finest, one per near-null-space vector on a coarse one) coloured greedily by the level's
//!   matrix pattern and swept colour by colour, each node's DOFs in order. Nodes of one colour
//!   share no matrix entry, so a colour's nodes are updated at once on every thread
//!   ([`OrderedChunks`], in place through [`DisjointSlice`]) and the result is that of the
//!   sequential sweep in colour order whatever the thread count. The backward sweep visits the
//!   colours in reverse and each node's DOFs in reverse: the exact reverse order. Each level is
//!   renumbered colour by colour when the hierarchy is built, so a colour's rows are read in
//!   memory order (visiting them scattered over the original numbering cost twice the time of
//!   a DOF-order sweep).
//!
//! The order changes the iteration (not only its speed); `tests/preconditioners.rs` and
//! `cargo bench --bench thread_crossover -- amg` compare the CG iterations of the two.

use serde::{Deserialize, Serialize};

use super::csr::Csr;
use crate::colouring::Colouring;
use crate::parallel::{DisjointSlice, OrderedChunks, Parallelism};

/// The order of the V-cycle's Gauss–Seidel sweeps (`solver.cg.amg.smoother`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AmgSmoother {
    /// DOF order, on one thread.
    GaussSeidel,
    /// Colour by colour over a greedy colouring of each level's nodes, parallel within a
    /// colour; the same result on any thread count.
    #[default]
    MulticolourGaussSeidel,
}

impl AmgSmoother {
    /// Every smoother, in the order the docs list them.
    pub const ALL: [AmgSmoother; 2] = [Self::GaussSeidel, Self::MulticolourGaussSeidel];

    /// The name in a scene file.
    pub fn name(self) -> &'static str {
        match self {
            Self::GaussSeidel => "gauss-seidel",
            Self::MulticolourGaussSeidel => "multicolour-gauss-seidel",
        }
    }
}

/// Nodes per chunk of a parallel colour (chunks are claimed by threads as a unit).
const NODES_PER_CHUNK: usize = 64;

/// One level's sweep order: DOF order, or colour by colour over a level renumbered so that
/// each colour's nodes are contiguous ([`colour_order`]).
pub(super) enum Sweep {
    Lexicographic,
    Coloured(Box<ColouredSweep>),
}

pub(super) struct ColouredSweep {
    /// DOF offsets of the nodes in the renumbered level (`nodes[k]..nodes[k + 1]`).
    nodes: Vec<usize>,
    /// Where each colour's nodes start (one more entry than colours).
    start: Vec<usize>,
    forward: OrderedChunks,
    backward: OrderedChunks,
}

/// A greedy colouring of the nodes of `a` (nodes at DOF offsets `nodes`; two nodes adjacent
/// when `a` couples a DOF of one to a DOF of the other), as a renumbering that makes each
/// colour's nodes contiguous: the DOF permutation (new → old), the node offsets and the colour
/// starts (in nodes) of the renumbered level. Within a colour, nodes keep their order.
pub(super) fn colour_order(a: &Csr, nodes: &[usize]) -> (Vec<usize>, Vec<usize>, Vec<usize>) {
    let n_nodes = nodes.len() - 1;
    let mut node_of = vec![0usize; a.nrows];
    for k in 0..n_nodes {
        node_of[nodes[k]..nodes[k + 1]].fill(k);
    }
    let colouring = Colouring::greedy(n_nodes, |k, visit| {
        for i in nodes[k]..nodes[k + 1] {
            for &j in a.row(i).0 {
                visit(node_of[j]);
            }
        }
    });
    let colours = colouring.num_colours();
    let mut perm = Vec::with_capacity(a.nrows);
    let mut new_nodes = vec![0];
    for c in 0..colours {
        for &k in colouring.group(c) {
            perm.extend(nodes[k]..nodes[k + 1]);
            new_nodes.push(perm.len());
        }
    }
    let start = (0..colours)
        .map(|c| colouring.group_start(c))
        .chain([n_nodes])
        .collect();
    (perm, new_nodes, start)
}

impl Sweep {
    /// The coloured sweep of a level renumbered by [`colour_order`] (its `nodes` and `start`).
    pub fn coloured(nodes: Vec<usize>, start: Vec<usize>) -> Self {
        let lens: Vec<usize> = start.windows(2).map(|w| w[1] - w[0]).collect();
        Self::Coloured(Box::new(ColouredSweep {
            forward: OrderedChunks::new(lens.iter().copied(), NODES_PER_CHUNK),
            backward: OrderedChunks::new(lens.iter().rev().copied(), NODES_PER_CHUNK),
            nodes,
            start,
        }))
    }

    /// Colours (1 for DOF order).
    pub fn colours(&self) -> usize {
        match self {
            Self::Lexicographic => 1,
            Self::Coloured(c) => c.start.len() - 1,
        }
    }

    /// One sweep on `A x = b`, forward or backward; parallel within a colour with
    /// [`Parallelism::Rayon`].
    pub fn run(
        &self,
        a: &Csr,
        inv_diag: &[f64],
        b: &[f64],
        x: &mut [f64],
        backward: bool,
        par: Parallelism,
    ) {
        match self {
            Self::Lexicographic => {
                let mut update = |i: usize| x[i] = relaxed(a, inv_diag, b, i, |j| x[j]);
                if backward {
                    (0..a.nrows).rev().for_each(&mut update);
                } else {
                    (0..a.nrows).for_each(&mut update);
                }
            }
            Self::Coloured(c) => c.run(a, inv_diag, b, x, backward, par),
        }
    }
}

/// `(b_i − Σ_{j≠i} a_ij x_j) / a_ii`, reading `x` through `x_at`.
#[inline]
fn relaxed(a: &Csr, inv_diag: &[f64], b: &[f64], i: usize, x_at: impl Fn(usize) -> f64) -> f64 {
    let (idx, val) = a.row(i);
    let mut s = b[i];
    for (&j, &v) in idx.iter().zip(val) {
        if j != i {
            s -= v * x_at(j);
        }
    }
    s * inv_diag[i]
}

impl ColouredSweep {
    /// The DOFs of chunk `items` of colour `c` (contiguous: the level is renumbered).
    fn dofs(&self, c: usize, items: std::ops::Range<usize>) -> std::ops::Range<usize> {
        self.nodes[self.start[c] + items.start]..self.nodes[self.start[c] + items.end]
    }

    fn run(
        &self,
        a: &Csr,
        inv_diag: &[f64],
        b: &[f64],
        x: &mut [f64],
        backward: bool,
        par: Parallelism,
    ) {
        let colours = self.start.len() - 1;
        let x = DisjointSlice::new(x);
        // SAFETY (both closures): a node's DOFs are written only by the task holding the node;
        // the nodes of one colour share no matrix entry, so no task reads a DOF another task
        // of the same colour writes, and colours run one after another (OrderedChunks).
        let at = |j: usize| unsafe { x.read(j) };
        if backward {
            self.backward.run(par, &|g, items| {
                for i in self.dofs(colours - 1 - g, items).rev() {
                    unsafe { x.write(i, relaxed(a, inv_diag, b, i, at)) };
                }
            });
        } else {
            self.forward.run(par, &|c, items| {
                for i in self.dofs(c, items) {
                    unsafe { x.write(i, relaxed(a, inv_diag, b, i, at)) };
                }
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A chain of `n` nodes of 2 DOFs, coupled within a node and to the next node.
    fn chain(n: usize) -> (Csr, Vec<usize>) {
        let dofs = 2 * n;
        let mut a = Csr {
            nrows: dofs,
            ncols: dofs,
            ptr: vec![0],
            ..Csr::default()
        };
        for i in 0..dofs {
            for j in 0..dofs {
                let (ni, nj) = (i / 2, j / 2);
                if ni.abs_diff(nj) <= 1 {
                    a.idx.push(j);
                    a.val.push(if i == j {
                        4.0 + 0.01 * i as f64
                    } else {
                        -0.5 - 0.001 * (i + j) as f64
                    });
                }
            }
            a.ptr.push(a.idx.len());
        }
        (a, (0..=n).map(|k| 2 * k).collect())
    }

    /// The coloured sweep of the renumbered level is the sequential sweep in DOF order on 1 and
    /// 3 threads (forward and backward), and the renumbering makes each colour's nodes an
    /// independent set.
    #[test]
    fn coloured_sweeps_are_the_sequential_sweep_in_colour_order_on_any_thread_count() {
        let (natural, nodes) = chain(1000);
        let (perm, new_nodes, start) = colour_order(&natural, &nodes);
        assert_eq!(start.len() - 1, 2, "a chain needs two colours");
        let mut inverse = vec![0; perm.len()];
        for (new, &old) in perm.iter().enumerate() {
            inverse[old] = new;
        }
        let (a, _) = natural.permuted(&perm, &inverse, Parallelism::Sequential);
        let n = a.nrows;
        let node_of = |i: usize| new_nodes.partition_point(|&s| s <= i) - 1;
        let colour_of = |k: usize| start.partition_point(|&s| s <= k) - 1;
        for i in 0..n {
            for &j in a.row(i).0 {
                let (ki, kj) = (node_of(i), node_of(j));
                assert!(ki == kj || colour_of(ki) != colour_of(kj), "{i} {j}");
            }
        }
        let mut inv_diag = vec![0.0; n];
        a.diagonal_into(&mut inv_diag);
        inv_diag.iter_mut().for_each(|d| *d = 1.0 / *d);
        let b: Vec<f64> = (0..n).map(|i| (i % 5) as f64 - 2.0).collect();
        let sweep = Sweep::coloured(new_nodes.clone(), start.clone());
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for backward in [false, true] {
                let mut expected = vec![0.5; n];
                Sweep::Lexicographic.run(
                    &a,
                    &inv_diag,
                    &b,
                    &mut expected,
                    backward,
                    Parallelism::Sequential,
                );
                let mut x = vec![0.5; n];
                pool.install(|| sweep.run(&a, &inv_diag, &b, &mut x, backward, Parallelism::Rayon));
                assert_eq!(x, expected, "{threads} threads, backward {backward}");
            }
        }
    }

    #[test]
    fn every_smoother_has_its_name() {
        for s in AmgSmoother::ALL {
            let text = format!("s = \"{}\"", s.name());
            #[derive(serde::Deserialize)]
            struct T {
                s: AmgSmoother,
            }
            assert_eq!(toml::from_str::<T>(&text).unwrap().s, s);
        }
    }
}
