//! The complex linear systems of Radau IIA's transformed Newton iteration
//! ([`super::radau_iia`]): `(K + ν² M + ν D) x = b` with a complex shift `ν`, over the model's
//! Hessian pattern. The matrix is complex symmetric, not Hermitian, so neither Cholesky nor
//! CG applies: it is factored by faer's sparse LU with partial pivoting (COLAMD ordering,
//! symbolic analysis once per pattern; numeric factor, scratch and values kept between steps,
//! so no step allocates after the first).

use crate::solve::SolveError;
use crate::sparse::SparsityPattern;
use faer::c64;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::LuError;
use faer::sparse::linalg::lu::{NumericLu, SymbolicLu, factorize_symbolic_lu};
use faer::{Conj, MatMut, Par};
use std::sync::Arc;

/// A complex matrix over a symmetric pattern (both triangles), its LU factor and scratch.
pub struct ComplexShifted {
    pattern: Option<Arc<SparsityPattern>>,
    symbolic: Option<SymbolicLu<usize>>,
    numeric: NumericLu<usize, c64>,
    mem: MemBuffer,
    /// The matrix values, one per pattern entry; filled by the caller before [`Self::factor`].
    pub values: Vec<c64>,
    rhs: Vec<c64>,
}

impl Default for ComplexShifted {
    fn default() -> Self {
        Self {
            pattern: None,
            symbolic: None,
            numeric: NumericLu::new(),
            mem: MemBuffer::new(StackReq::empty()),
            values: Vec::new(),
            rhs: Vec::new(),
        }
    }
}

fn lu_error(e: LuError) -> SolveError {
    match e {
        LuError::SymbolicSingular { index } => SolveError::SingularMatrix { column: index },
        LuError::Generic(_) => SolveError::SingularMatrix { column: 0 },
    }
}

impl ComplexShifted {
    /// Size `values` for `pattern`, analysing it when it is new. Returns whether a symbolic
    /// analysis was done.
    pub fn prepare(&mut self, pattern: &Arc<SparsityPattern>) -> Result<bool, SolveError> {
        if self
            .pattern
            .as_ref()
            .is_some_and(|p| Arc::ptr_eq(p, pattern))
        {
            return Ok(false);
        }
        let symbolic = factorize_symbolic_lu(pattern.as_faer(), Default::default())
            .map_err(|_| SolveError::SingularMatrix { column: 0 })?;
        let req = StackReq::any_of(&[
            symbolic.factorize_numeric_lu_scratch::<c64>(Par::Seq, Default::default()),
            symbolic.solve_in_place_scratch::<c64>(1, Par::Seq),
        ]);
        self.mem = MemBuffer::new(req);
        self.symbolic = Some(symbolic);
        self.values = vec![c64::new(0.0, 0.0); pattern.nnz()];
        self.rhs = vec![c64::new(0.0, 0.0); pattern.dim()];
        self.pattern = Some(pattern.clone());
        Ok(true)
    }

    /// Factor the matrix in `values`.
    pub fn factor(&mut self) -> Result<(), SolveError> {
        let (Some(pattern), Some(symbolic)) = (&self.pattern, &self.symbolic) else {
            panic!("ComplexShifted::factor before prepare");
        };
        let matrix = SparseColMatRef::new(pattern.as_faer(), &self.values);
        symbolic
            .factorize_numeric_lu(
                &mut self.numeric,
                matrix,
                Par::Seq,
                MemStack::new(&mut self.mem),
                Default::default(),
            )
            .map_err(lu_error)?;
        Ok(())
    }

    /// Solve with the last factor: `(re, im)` is the right-hand side on entry and the
    /// solution on return.
    pub fn solve(&mut self, re: &mut [f64], im: &mut [f64]) -> Result<(), SolveError> {
        let symbolic = self.symbolic.as_ref().expect("factored");
        for ((r, a), b) in self.rhs.iter_mut().zip(re.iter()).zip(im.iter()) {
            *r = c64::new(*a, *b);
        }
        let n = self.rhs.len();
        let lu = faer::sparse::linalg::lu::LuRef::new_unchecked(symbolic, &self.numeric);
        lu.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut self.rhs, n, 1),
            Par::Seq,
            MemStack::new(&mut self.mem),
        );
        for (k, ((r, a), b)) in self
            .rhs
            .iter()
            .zip(re.iter_mut())
            .zip(im.iter_mut())
            .enumerate()
        {
            if !(r.re.is_finite() && r.im.is_finite()) {
                return Err(SolveError::SingularMatrix { column: k });
            }
            *a = r.re;
            *b = r.im;
        }
        Ok(())
    }
}
