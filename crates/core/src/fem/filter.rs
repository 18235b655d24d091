//! Eigenvalue filters of symmetric element matrices: the element-level half of Newton's
//! Hessian filters (`integrator.newton.filter`; which filter runs when is decided in
//! `integrate::filter`).
//!
//! A filter decomposes a symmetric matrix `A = Q diag(λ) Qᵀ` and rebuilds it as
//! `Q diag(φ(λ)) Qᵀ` with one eigenvalue map for every filter:
//!
//! `φ(λ) = max(λ, ε)` for `λ >= 0` and `φ(λ) = max(w |λ|, ε)` for `λ < 0`,
//!
//! so `w = 0` clamps at ε, `w = 1` takes absolute values (floored at ε), and `w` in between
//! blends the two. Every `φ(λ)` is `>= 0`: the result is positive semi-definite.
//!
//! An element whose smallest eigenvalue is not below `ε` (up to the decomposition's own
//! round-off, [`ROUNDOFF`] times the largest `|λ|`) is left bit-for-bit unchanged and not
//! counted as filtered. With `only_indefinite`, so is every element without a negative
//! eigenvalue, whatever ε.
//!
//! Where the filter decomposes ([`FilterSpace`]): the 12×12 element Hessian (the generic
//! path, ε in N/m), or the 9×9 stress derivative `dP/dF` before it is mapped by
//! `V Bᵀ (dP/dF) B` to the element Hessian (ε in Pa). The map is a congruence, so a PSD
//! 9×9 gives a PSD 12×12; the 9×9 decomposition is cheaper and never touches the three
//! translation modes, which the element Hessian has as exact zeros.
//! A material with its dP/dF eigensystem in closed form (`Material::stress_eigensystem`:
//! stable Neo-Hookean) skips the 9×9 decomposition ([`ElementFilter::apply_eigensystem`]).

use nalgebra::{SMatrix, SVector, SymmetricEigen};

crate::named_enum! {
    /// Which matrix an element filter decomposes (`integrator.newton.filter_space`).
    pub enum FilterSpace: "hessian filter space", UnknownFilterSpace {
        /// The 12×12 element Hessian: the generic path, any element.
        Element = "element",
            "decompose the 12x12 element Hessian (generic; epsilon in N/m)",
        /// The 9×9 `dP/dF` of the element's material, before the map to the element.
        Stress = "stress",
            "decompose the material's 9x9 dP/dF before V B^T D B (epsilon in Pa)",
    }
}

/// Relative size, in units of the largest `|λ|`, of eigenvalues taken as round-off of the
/// decomposition (a negative eigenvalue above `-ROUNDOFF max|λ|` counts as zero).
pub const ROUNDOFF: f64 = 64.0 * f64::EPSILON;

/// Which elements a filter evaluation touches (the on-demand filter's memory).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FilterScope {
    /// Every element is decomposed and filtered.
    #[default]
    Every,
    /// Only elements flagged by an earlier evaluation are decomposed; a flagged element
    /// found without a negative eigenvalue is unflagged. The others keep their exact matrix.
    Flagged,
    /// Every element is decomposed; those with a negative eigenvalue are filtered and
    /// flagged.
    EveryFlagging,
}

/// One element filter: the eigenvalue map and where it applies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ElementFilter {
    /// `w`, the weight of `|λ|` for negative eigenvalues (0 clamps, 1 takes absolute values).
    pub negative_weight: f64,
    /// `ε`, the floor of every filtered eigenvalue (>= 0).
    pub epsilon: f64,
    /// Filter only elements with a negative eigenvalue (leave PSD ones as they are, even
    /// when some eigenvalue is below ε).
    pub only_indefinite: bool,
    pub space: FilterSpace,
    pub scope: FilterScope,
}

impl ElementFilter {
    /// Eigenvalues clamped at 0 on the element Hessian: the projection softbench always had.
    pub const CLAMP: ElementFilter = ElementFilter {
        negative_weight: 0.0,
        epsilon: 0.0,
        only_indefinite: false,
        space: FilterSpace::Element,
        scope: FilterScope::Every,
    };

    /// `φ(λ)` (see the module docs).
    #[inline]
    pub fn map(&self, l: f64) -> f64 {
        if l >= 0.0 {
            l.max(self.epsilon)
        } else {
            (-l * self.negative_weight).max(self.epsilon)
        }
    }

    /// Whether eigenvalues with smallest `min` and largest magnitude `max_abs` need the
    /// filter (see the module docs).
    #[inline]
    pub fn needed(&self, min: f64, max_abs: f64) -> bool {
        let tol = ROUNDOFF * max_abs;
        if self.only_indefinite {
            min < -tol
        } else {
            min < self.epsilon - tol
        }
    }

    /// Filter the symmetric matrix `m` in place; returns whether it changed (otherwise it is
    /// bit-for-bit what it was). Allocates nothing.
    pub fn apply<M: Filterable>(&self, m: &mut M) -> bool {
        m.filter_with(self)
    }
}

impl ElementFilter {
    /// Filter the 9×9 `m` whose eigensystem is known in closed form (`values`, orthonormal
    /// `vectors` as columns): `m` becomes `Q diag(φ(λ)) Qᵀ` when the filter is needed,
    /// otherwise it is left bit-for-bit as it is. Returns whether it changed.
    pub fn apply_eigensystem(
        &self,
        values: &SVector<f64, 9>,
        vectors: &SMatrix<f64, 9, 9>,
        m: &mut SMatrix<f64, 9, 9>,
    ) -> bool {
        if !self.needed(values.min(), values.amax()) {
            return false;
        }
        let mut scaled = *vectors;
        for (mut col, l) in scaled.column_iter_mut().zip(values.iter()) {
            col *= self.map(*l);
        }
        *m = scaled * vectors.transpose();
        true
    }
}

/// Symmetric matrices an [`ElementFilter`] applies to (3×3 to 12×12).
pub trait Filterable {
    /// See [`ElementFilter::apply`].
    fn filter_with(&mut self, filter: &ElementFilter) -> bool;
}

macro_rules! impl_filterable {
    ($($n:literal),*) => {$(
        impl Filterable for SMatrix<f64, $n, $n> {
            fn filter_with(&mut self, filter: &ElementFilter) -> bool {
                let eig = SymmetricEigen::new(*self);
                let min = eig.eigenvalues.min();
                let max_abs = eig.eigenvalues.amax();
                if !filter.needed(min, max_abs) {
                    return false;
                }
                let mut scaled = eig.eigenvectors;
                for (mut col, l) in scaled.column_iter_mut().zip(eig.eigenvalues.iter()) {
                    col *= filter.map(*l);
                }
                *self = scaled * eig.eigenvectors.transpose();
                true
            }
        }
    )*};
}

impl_filterable!(3, 6, 9, 12);
