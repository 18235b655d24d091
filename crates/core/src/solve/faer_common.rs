//! What faer's Cholesky and LDLᵀ backends share: the symbolic analysis, the factor's value
//! storage and the scratch memory, all allocated once per pattern.

use faer::Par;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::amd;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};

use super::ordering::{FactorCost, Ordering, nested_dissection};
use super::supernodal_tree::{self, ScratchPool, TreeSchedule};
use super::{DirectSettings, Scheduler, SolveError, Supernodal};
use crate::parallel::Parallelism;
use crate::sparse::SparsityPattern;

/// Which numeric factorization the scratch memory must fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScratchKind {
    Llt,
    Ldlt,
}

/// The symbolic factorization of one pattern plus everything the numeric phase writes into:
/// the factor's values (`len_val` f64) and a scratch buffer big enough for both the numeric
/// factorization and a one-column solve.
pub struct FaerFactor {
    pub symbolic: SymbolicCholesky<usize>,
    pub values: Vec<f64>,
    pub mem: MemBuffer,
    pub par: Par,
    /// Entries of L (lower triangle with diagonal), counted exactly.
    pub nnz: usize,
    /// Predicted flops of one numeric factorization (Σ c_j² over L's column counts).
    pub flops: f64,
    /// The ordering used (`Amd`, `Metis` or `Identity`; never `Auto`).
    pub ordering: Ordering,
    /// The subtree-parallel schedule of a parallel supernodal LLᵀ (`None`: faer's own loop).
    pub tree: Option<SubtreeFactor>,
}

/// What the subtree-parallel numeric LLᵀ keeps per analysis: its schedule and the workers'
/// scratch.
pub struct SubtreeFactor {
    pub schedule: TreeSchedule,
    pub pool: ScratchPool,
    /// One right-hand side in the permuted order, for the solve.
    pub work: Vec<f64>,
}

/// A fill-reducing permutation of a pattern and the exact cost of factoring in it, found
/// before any symbolic factorization: what `Auto` compares orderings by, and what decides
/// between the direct and the iterative solver without paying for a symbolic analysis the
/// iterative one would throw away.
pub struct OrderingChoice {
    /// `Amd`, `Metis` or `Identity` (never `Auto`).
    pub ordering: Ordering,
    /// `perm[new] = old`, composed with a postorder of its elimination tree (except the
    /// identity), so every subtree is a contiguous range of supernodes.
    perm: Vec<usize>,
    pub cost: FactorCost,
}

impl OrderingChoice {
    /// Orders `pattern` as `settings` asks; `Auto` keeps the cheaper of AMD and METIS
    /// (computed on two threads when the run's parallelism has them).
    pub fn new(pattern: &SparsityPattern, settings: &DirectSettings) -> Result<Self, SolveError> {
        let single = |ordering| -> Result<Self, SolveError> {
            let perm = permutation(pattern, ordering)?;
            let cost = factor_cost(pattern, &perm);
            Ok(Self {
                ordering,
                perm,
                cost,
            })
        };
        match settings.ordering {
            Ordering::Auto => {
                // Both orderings side by side when the run has threads (each is sequential
                // and deterministic: the same choice on any thread count).
                let (amd, nd) = match settings.parallelism {
                    Parallelism::Rayon if rayon::current_num_threads() > 1 => {
                        rayon::join(|| single(Ordering::Amd), || single(Ordering::Metis))
                    }
                    _ => (single(Ordering::Amd), single(Ordering::Metis)),
                };
                let (amd, nd) = (amd?, nd?);
                Ok(if nd.cost.flops < amd.cost.flops {
                    nd
                } else {
                    amd
                })
            }
            o => single(o),
        }
    }
}

/// The symbolic factorization of a pattern in its chosen ordering, with its predicted cost.
pub struct SymbolicAnalysis {
    pub symbolic: SymbolicCholesky<usize>,
    /// `Amd`, `Metis` or `Identity` (never `Auto`).
    pub ordering: Ordering,
    pub cost: FactorCost,
}

impl SymbolicAnalysis {
    /// Orders and symbolically factors `pattern`; `Auto` keeps the cheaper of AMD and METIS.
    pub fn new(pattern: &SparsityPattern, settings: &DirectSettings) -> Result<Self, SolveError> {
        Self::from_choice(pattern, settings, OrderingChoice::new(pattern, settings)?)
    }

    /// Symbolically factors `pattern` in an ordering already chosen.
    pub fn from_choice(
        pattern: &SparsityPattern,
        settings: &DirectSettings,
        choice: OrderingChoice,
    ) -> Result<Self, SolveError> {
        Ok(Self {
            symbolic: symbolic_analysis(pattern, settings, &choice.perm)?,
            ordering: choice.ordering,
            cost: choice.cost,
        })
    }
}

/// Predicted factorization flops from which the subtree-scheduled numeric LLᵀ runs on rayon's
/// pool. `cargo bench --bench thread_crossover -- factor` on a quiet two-core machine, called
/// from outside the pool as a run calls it, in three runs: two threads were 0.89–0.98x at
/// 1.3e7–3.4e7 flops (the 1.5k- and 2.6k-tet boxes), 0.94–1.20x at 1.8e8, 1.18–1.20x at 6.9e8
/// (the 12k box) and 1.73x at 1.2e10 (the 49k box).
pub const PARALLEL_MIN_FLOPS: f64 = 5.0e8;

/// The same for faer's own supernodal loop (LDLᵀ, simplicial, `scheduler = "faer"`), which is
/// parallel only inside each supernode's dense kernels and pays only for large fronts: two
/// threads gave 1.2–1.5x on the 49k-tet box (1.2e10 flops) and were 1.3–1.5x slower on the
/// 12k-tet box (6.9e8) and the 56k-tet armadillo (`cargo bench --bench ordering`).
pub const FAER_LOOP_PARALLEL_MIN_FLOPS: f64 = 5.0e9;

/// The threads a numeric factorization of `flops` runs on: rayon's current pool when the
/// settings allow it and the flops reach the threshold of its scheduler (`faer_loop`: faer's
/// own loop), else one.
pub fn factor_threads(settings: &DirectSettings, flops: f64, faer_loop: bool) -> usize {
    let threads = rayon::current_num_threads();
    let min_flops = if faer_loop {
        settings.faer_parallel_min_flops
    } else {
        settings.parallel_min_flops
    };
    match settings.parallelism {
        Parallelism::Rayon if flops >= min_flops && threads > 1 => threads,
        _ => 1,
    }
}

impl FaerFactor {
    /// Orders and symbolically factors `pattern` (read as its lower triangle) and allocates
    /// the value and scratch storage. With `Ordering::Auto` both AMD and nested dissection
    /// are analyzed and the one with fewer predicted flops is kept.
    pub fn analyze(
        pattern: &SparsityPattern,
        settings: &DirectSettings,
        kind: ScratchKind,
    ) -> Result<Self, SolveError> {
        Self::allocate(
            pattern,
            SymbolicAnalysis::new(pattern, settings)?,
            settings,
            kind,
        )
    }

    /// Allocates the value and scratch storage for an analysis of `pattern`.
    pub fn allocate(
        pattern: &SparsityPattern,
        analysis: SymbolicAnalysis,
        settings: &DirectSettings,
        kind: ScratchKind,
    ) -> Result<Self, SolveError> {
        let SymbolicAnalysis {
            symbolic,
            ordering,
            cost,
        } = analysis;
        let tree = match (kind, settings.scheduler, symbolic.raw()) {
            (
                ScratchKind::Llt,
                Scheduler::Subtrees,
                SymbolicCholeskyRaw::Supernodal(supernodal),
            ) => {
                // Not postordered only with the caller's own (identity) ordering: faer's loop.
                TreeSchedule::new(supernodal, pattern, symbolic.perm().map(|p| p.arrays()))
                    .ok()
                    .map(|schedule| SubtreeFactor {
                        pool: ScratchPool::new(&schedule, rayon::current_num_threads()),
                        work: vec![0.0; schedule.dim()],
                        schedule,
                    })
            }
            _ => None,
        };
        let par = if factor_threads(settings, cost.flops, tree.is_none()) > 1 {
            Par::rayon(0)
        } else {
            Par::Seq
        };
        let factor_req = match kind {
            ScratchKind::Llt => {
                symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default())
            }
            ScratchKind::Ldlt => {
                symbolic.factorize_numeric_ldlt_scratch::<f64>(par, Default::default())
            }
        };
        let req = StackReq::or(factor_req, symbolic.solve_in_place_scratch::<f64>(1, par));
        let mem = MemBuffer::try_new(req)
            .map_err(|_| SolveError::Analysis("out of memory for scratch".into()))?;
        let mut values = Vec::new();
        values.try_reserve_exact(symbolic.len_val()).map_err(|_| {
            SolveError::Analysis(format!(
                "out of memory for {} factor values",
                symbolic.len_val()
            ))
        })?;
        values.resize(symbolic.len_val(), 0.0);
        Ok(Self {
            symbolic,
            values,
            mem,
            par,
            nnz: cost.nnz,
            flops: cost.flops,
            ordering,
            tree,
        })
    }

    /// Whether the numeric phase runs on several threads.
    pub fn is_parallel(&self) -> bool {
        !matches!(self.par, Par::Seq)
    }

    /// Who schedules the numeric phase: `subtrees` (the subtree-parallel LLᵀ) or `faer`
    /// (faer's loop over supernodes, parallel only inside each one's kernels).
    pub fn scheduler_name(&self) -> &'static str {
        match self.tree {
            Some(_) => Scheduler::Subtrees.name(),
            None => Scheduler::Faer.name(),
        }
    }

    /// Numeric LLᵀ of `a` into `values` with the subtree-parallel schedule; `None` when this
    /// factor has none (then faer's own loop applies). The error is faer's, permuted index.
    pub fn factor_subtrees(&mut self, a: &[f64]) -> Option<Result<(), usize>> {
        let tree = self.tree.as_ref()?;
        let SymbolicCholeskyRaw::Supernodal(supernodal) = self.symbolic.raw() else {
            return None;
        };
        Some(
            supernodal_tree::factorize(
                &mut self.values,
                a,
                supernodal,
                &tree.schedule,
                &tree.pool,
                self.par,
            )
            .map_err(|e| e.index),
        )
    }

    /// Solves `A x = b` in place (each column of `x`) with the subtree-scheduled factor;
    /// `false` when this factor has none (then faer's solve applies).
    pub fn solve_subtrees(&mut self, mut x: faer::MatMut<'_, f64>) -> bool {
        let (Some(tree), SymbolicCholeskyRaw::Supernodal(supernodal)) =
            (self.tree.as_mut(), self.symbolic.raw())
        else {
            return false;
        };
        let fwd = self.symbolic.perm().map(|p| p.arrays().0);
        let at = |i: usize| fwd.map_or(i, |f| f[i]);
        for j in 0..x.ncols() {
            for (i, w) in tree.work.iter_mut().enumerate() {
                *w = x[(at(i), j)];
            }
            supernodal_tree::solve_in_place(
                &mut tree.work,
                &self.values,
                supernodal,
                &tree.schedule,
                &tree.pool,
                self.par,
            );
            for (i, &w) in tree.work.iter().enumerate() {
                x[(at(i), j)] = w;
            }
        }
        true
    }

    /// The original column of the failed pivot reported as `index` by faer. faer 0.24.4
    /// reports it 0-based from the supernodal path but 1-based (`k + 1`) from the simplicial
    /// one; either way it is in the permuted order, where `P A Pᵀ` has `[i, j] = A[fwd[i], fwd[j]]`.
    pub fn original_column(&self, index: usize) -> usize {
        let permuted = match self.symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(_) => index.saturating_sub(1),
            SymbolicCholeskyRaw::Supernodal(_) => index,
        };
        self.symbolic
            .perm()
            .map_or(permuted, |p| p.arrays().0[permuted])
    }
}

/// The permutation `ordering` (not `Auto`) gives `pattern`, `perm[new] = old`. AMD is faer's
/// (the call faer's own symbolic analysis makes) and METIS is nested dissection on the vertex
/// graph; both are composed with a postorder of their elimination tree, so every subtree is a
/// contiguous range of supernodes (the subtree-parallel LLᵀ needs it; fill and flops are
/// unchanged).
fn permutation(pattern: &SparsityPattern, ordering: Ordering) -> Result<Vec<usize>, SolveError> {
    let n = pattern.dim();
    let fill_reducing = match ordering {
        Ordering::Identity => return Ok((0..n).collect()),
        Ordering::Metis => nested_dissection(pattern)?,
        Ordering::Amd | Ordering::Auto => {
            let (mut fwd, mut inv) = (vec![0usize; n], vec![0usize; n]);
            let nnz = pattern.nnz();
            let mut mem = MemBuffer::try_new(amd::order_maybe_unsorted_scratch::<usize>(n, nnz))
                .map_err(|_| SolveError::Analysis("out of memory for the AMD ordering".into()))?;
            amd::order_maybe_unsorted(
                &mut fwd,
                &mut inv,
                pattern.as_faer(),
                amd::Control::default(),
                MemStack::new(&mut mem),
            )
            .map_err(|e| SolveError::Analysis(format!("{e:?}")))?;
            fwd
        }
    };
    Ok(supernodal_tree::postorder_permutation(
        pattern,
        &fill_reducing,
    ))
}

/// The symbolic Cholesky factorization of `pattern` in the permutation `perm` (`perm[new] =
/// old`). Even the identity goes through a custom permutation: with
/// `SymmetricOrdering::Identity` faer's numeric phase transposes A instead of extracting the
/// `Side` triangle, so the simplicial path would read both triangles of our storage and
/// compute garbage.
fn symbolic_analysis(
    pattern: &SparsityPattern,
    settings: &DirectSettings,
    perm: &[usize],
) -> Result<SymbolicCholesky<usize>, SolveError> {
    let inverse = inverse_permutation(perm);
    let threshold = match settings.supernodal {
        Supernodal::Auto => SupernodalThreshold::AUTO,
        Supernodal::Simplicial => SupernodalThreshold::FORCE_SIMPLICIAL,
        Supernodal::Supernodal => SupernodalThreshold::FORCE_SUPERNODAL,
    };
    let params = CholeskySymbolicParams {
        supernodal_flop_ratio_threshold: threshold,
        ..Default::default()
    };
    factorize_symbolic_cholesky(
        pattern.as_faer(),
        faer::Side::Lower,
        SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(
            perm,
            &inverse,
            pattern.dim(),
        )),
        params,
    )
    .map_err(|e| SolveError::Analysis(format!("{e:?}")))
}

/// `inv[perm[i]] = i`.
fn inverse_permutation(perm: &[usize]) -> Vec<usize> {
    let mut inv = vec![0; perm.len()];
    for (i, &p) in perm.iter().enumerate() {
        inv[p] = i;
    }
    inv
}

/// nnz(L) (diagonal included) and predicted flops from the exact column counts of L in the
/// permutation `perm` (the elimination tree, then Gilbert–Ng–Peyton column counts, in
/// O(nnz(A) α(n)) time). faer's supernodal storage would overcount: relaxed supernodes store
/// explicit zeros and the upper part of diagonal blocks. These are the counts CHOLMOD reports
/// (`lnz`, `fl`), so they compare across programs.
pub fn factor_cost(pattern: &SparsityPattern, perm: &[usize]) -> FactorCost {
    let (fwd, inv) = (perm, &inverse_permutation(perm)[..]);
    let parent = supernodal_tree::elimination_tree(pattern, fwd, inv);
    let counts = supernodal_tree::column_counts(pattern, fwd, inv, &parent);
    let mut cost = FactorCost::default();
    for c in counts {
        cost.add_column(c);
    }
    cost
}
