//! What faer's Cholesky and LDLᵀ backends share: the symbolic analysis, the factor's value
//! storage and the scratch memory, all allocated once per pattern.

use faer::Par;
use faer::dyn_stack::{MemBuffer, StackReq};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};

use super::ordering::{FactorCost, Ordering, nested_dissection};
use super::{DirectSettings, SolveError, Supernodal};
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
}

/// Predicted factorization flops from which the numeric phase runs on rayon's pool. Measured
/// with `cargo bench --bench ordering` (two cores): see DESIGN.md, "Threads that reach the
/// solver".
pub const PARALLEL_MIN_FLOPS: f64 = 2.0e9;

impl FaerFactor {
    /// Orders and symbolically factors `pattern` (read as its lower triangle) and allocates
    /// the value and scratch storage. With `Ordering::Auto` both AMD and nested dissection
    /// are analyzed and the one with fewer predicted flops is kept.
    pub fn analyze(
        pattern: &SparsityPattern,
        settings: &DirectSettings,
        kind: ScratchKind,
    ) -> Result<Self, SolveError> {
        let (symbolic, ordering, cost) = match settings.ordering {
            Ordering::Auto => {
                let amd = symbolic_analysis(pattern, settings, Ordering::Amd)?;
                let nd = symbolic_analysis(pattern, settings, Ordering::Metis)?;
                let (amd_cost, nd_cost) = (factor_cost(pattern, &amd), factor_cost(pattern, &nd));
                if nd_cost.flops < amd_cost.flops {
                    (nd, Ordering::Metis, nd_cost)
                } else {
                    (amd, Ordering::Amd, amd_cost)
                }
            }
            o => {
                let s = symbolic_analysis(pattern, settings, o)?;
                let cost = factor_cost(pattern, &s);
                (s, o, cost)
            }
        };
        let par = match settings.parallelism {
            Parallelism::Rayon
                if cost.flops >= PARALLEL_MIN_FLOPS && rayon::current_num_threads() > 1 =>
            {
                Par::rayon(0)
            }
            _ => Par::Seq,
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
        })
    }

    /// Whether the numeric phase runs on several threads.
    pub fn is_parallel(&self) -> bool {
        !matches!(self.par, Par::Seq)
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

/// The symbolic Cholesky factorization of `pattern` in the given ordering (not `Auto`).
fn symbolic_analysis(
    pattern: &SparsityPattern,
    settings: &DirectSettings,
    ordering: Ordering,
) -> Result<SymbolicCholesky<usize>, SolveError> {
    // Identity goes through a custom identity permutation: with `SymmetricOrdering::Identity`
    // faer's numeric phase transposes A instead of extracting the `Side` triangle, so the
    // simplicial path would read both triangles of our storage and compute garbage.
    let custom: Vec<usize> = match ordering {
        Ordering::Identity => (0..pattern.dim()).collect(),
        Ordering::Metis => nested_dissection(pattern)?,
        Ordering::Amd | Ordering::Auto => Vec::new(),
    };
    let inverse = inverse_permutation(&custom);
    let faer_ordering = match ordering {
        Ordering::Amd | Ordering::Auto => SymmetricOrdering::Amd,
        Ordering::Identity | Ordering::Metis => SymmetricOrdering::Custom(
            faer::perm::PermRef::new_checked(&custom, &inverse, pattern.dim()),
        ),
    };
    let threshold = match settings.supernodal {
        Supernodal::Auto => SupernodalThreshold::AUTO,
        Supernodal::Simplicial => SupernodalThreshold::FORCE_SIMPLICIAL,
        Supernodal::Supernodal => SupernodalThreshold::FORCE_SUPERNODAL,
    };
    let params = CholeskySymbolicParams {
        supernodal_flop_ratio_threshold: threshold,
        ..Default::default()
    };
    factorize_symbolic_cholesky(pattern.as_faer(), faer::Side::Lower, faer_ordering, params)
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
/// analysis's ordering: the elimination tree (Liu's algorithm with path compression), then
/// each row's subtree (O(nnz(L)) time, O(n) memory). faer's supernodal storage would
/// overcount: relaxed supernodes store explicit zeros and the upper part of diagonal blocks.
/// These are the counts CHOLMOD reports (`lnz`, `fl`), so they compare across programs.
pub fn factor_cost(pattern: &SparsityPattern, symbolic: &SymbolicCholesky<usize>) -> FactorCost {
    let n = pattern.dim();
    let identity: Vec<usize>;
    let (fwd, inv) = match symbolic.perm() {
        Some(p) => p.arrays(),
        None => {
            identity = (0..n).collect();
            (&identity[..], &identity[..])
        }
    };
    let (cp, ri) = (pattern.col_ptr(), pattern.row_idx());
    // Entries of new column k above the diagonal, in the new order (= row k left of it).
    let upper = |k: usize| ri[cp[fwd[k]]..cp[fwd[k] + 1]].iter().map(|&r| inv[r]);
    const NONE: usize = usize::MAX;
    let mut parent = vec![NONE; n];
    let mut ancestor = vec![NONE; n];
    for k in 0..n {
        for mut i in upper(k) {
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
    let mut counts = vec![1usize; n];
    let mut mark = ancestor;
    mark.fill(NONE);
    for k in 0..n {
        mark[k] = k;
        for i in upper(k) {
            let mut j = i;
            while j < k && mark[j] != k {
                counts[j] += 1;
                mark[j] = k;
                j = parent[j];
            }
        }
    }
    let mut cost = FactorCost::default();
    for c in counts {
        cost.add_column(c);
    }
    cost
}
