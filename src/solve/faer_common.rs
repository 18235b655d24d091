//! What faer's Cholesky and LDLᵀ backends share: the symbolic analysis, the factor's value
//! storage and the scratch memory, all allocated once per pattern.

use faer::Par;
use faer::dyn_stack::{MemBuffer, StackReq};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};

use super::{DirectSettings, Ordering, SolveError, Supernodal};
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
}

impl FaerFactor {
    /// Orders and symbolically factors `pattern` (read as its lower triangle) and allocates
    /// the value and scratch storage.
    pub fn analyze(
        pattern: &SparsityPattern,
        settings: &DirectSettings,
        kind: ScratchKind,
    ) -> Result<Self, SolveError> {
        // Identity goes through a custom identity permutation: with `SymmetricOrdering::Identity`
        // faer's numeric phase transposes A instead of extracting the `Side` triangle, so the
        // simplicial path would read both triangles of our storage and compute garbage.
        let identity: Vec<usize> = (0..pattern.dim()).collect();
        let ordering = match settings.ordering {
            Ordering::Amd => SymmetricOrdering::Amd,
            Ordering::Identity => SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(
                &identity,
                &identity,
                pattern.dim(),
            )),
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
        let symbolic =
            factorize_symbolic_cholesky(pattern.as_faer(), faer::Side::Lower, ordering, params)
                .map_err(|e| SolveError::Analysis(format!("{e:?}")))?;
        let par = match settings.parallelism {
            Parallelism::Sequential => Par::Seq,
            Parallelism::Rayon => Par::rayon(0),
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
        let nnz = exact_nnz(&symbolic);
        Ok(Self {
            symbolic,
            values,
            mem,
            par,
            nnz,
        })
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

/// nnz(L) with the diagonal: supernodes store their diagonal block densely (upper part
/// included), so `len_val` overcounts.
fn exact_nnz(symbolic: &SymbolicCholesky<usize>) -> usize {
    match symbolic.raw() {
        SymbolicCholeskyRaw::Simplicial(s) => s.len_val(),
        SymbolicCholeskyRaw::Supernodal(s) => (0..s.n_supernodes())
            .map(|k| {
                let ncols = s.supernode_end()[k] - s.supernode_begin()[k];
                ncols * (ncols + 1) / 2 + s.supernode(k).pattern().len() * ncols
            })
            .sum(),
    }
}
