//! Newton's Hessian filters (`integrator.newton.filter`): which element filter
//! ([`ElementFilter`], the eigenvalue map of `fem/filter.rs`) each assembly of the system
//! matrix uses, and which one the reassembly uses when the system turns out indefinite.
//!
//! With `ε = filter_epsilon` and `k` the Newton iteration within one solve (0 first; with
//! modified Newton, the factorizations within the solve, since only those assemble):
//!
//! | filter | first assembly | if the system is indefinite |
//! |---|---|---|
//! | `none` | exact element Hessians | every element clamped at ε |
//! | `clamp` | every element: `λ -> max(λ, ε)` | (PSD already) |
//! | `abs` | every element: `λ -> max(|λ|, ε)` | (PSD already) |
//! | `on-demand` | exact, except elements flagged: clamped at ε | elements with `λ < 0` clamped at ε and flagged |
//! | `progressive` | every element: `λ<0 -> max(2^-k |λ|, ε)`, `λ>=0 -> max(λ, ε)` | (PSD already) |
//!
//! `on-demand` differs from `clamp` through its memory, not its map. Per element, clamping
//! only elements with a negative eigenvalue *is* `clamp` at ε = 0 (a PSD element is left
//! bit-for-bit as it is by every filter), so the name takes the literature's meaning
//! (Longva et al. 2023, "Pitfalls of projection"): project only when the assembled system
//! asks for it. An element found with a negative eigenvalue in an indefinite system stays
//! flagged — clamped at every later assembly, across iterations and steps — until an
//! assembly finds it PSD; unflagged elements are never decomposed (no eigenvalue cost). Unlike
//! `none`, an iteration after a fallback starts from the flagged set instead of failing
//! once more on the exact matrix; unlike `clamp`, PSD elements keep eigenvalues below ε and
//! unflagged elements are not decomposed.
//!
//! `progressive` starts as `abs` (the stabler filter far from the solution, Chen et al. 2024)
//! and halves the weight of negative eigenvalues every iteration, toward `clamp`.

use crate::fem::{ElementFilter, FilterScope, FilterSpace};

crate::named_enum! {
    /// How element Hessians are filtered in the Newton loop (`integrator.newton.filter`).
    pub enum HessianFilter: "hessian filter", UnknownHessianFilter {
        /// Exact Hessians; clamped at ε only when the assembled system is indefinite.
        None = "none",
            "exact element Hessians; clamped at epsilon only if the system is indefinite",
        /// Every element's eigenvalues clamped at ε.
        Clamp = "clamp",
            "every element: eigenvalues max(lambda, epsilon)",
        /// Every element's eigenvalues replaced by their absolute value (floored at ε).
        Abs = "abs",
            "every element: eigenvalues max(|lambda|, epsilon)",
        /// Exact Hessians except elements found indefinite in an indefinite system.
        OnDemand = "on-demand",
            "clamp only elements found indefinite when the system was; they stay clamped until PSD",
        /// `abs` at the first iteration, then negative eigenvalues weighted 2^-k (toward clamp).
        Progressive = "progressive",
            "iteration k: negative lambda -> max(2^-k |lambda|, epsilon); abs first, then toward clamp",
    }
}

/// A filter with its parameters, as the system matrix uses it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterSettings {
    pub filter: HessianFilter,
    /// `ε` (>= 0), in the units of the space's eigenvalues.
    pub epsilon: f64,
    pub space: FilterSpace,
}

impl Default for FilterSettings {
    fn default() -> Self {
        Self {
            filter: HessianFilter::None,
            epsilon: 0.0,
            space: FilterSpace::Element,
        }
    }
}

impl FilterSettings {
    /// Clamp at `ε` on the element Hessian, with `only_indefinite` and `scope`.
    fn clamp(&self, only_indefinite: bool, scope: FilterScope) -> ElementFilter {
        ElementFilter {
            negative_weight: 0.0,
            epsilon: self.epsilon,
            only_indefinite,
            space: self.space,
            scope,
        }
    }

    /// The filter of the first assembly at Newton iteration `k` (0-based) of a solve.
    pub fn first(&self, k: u32) -> Option<ElementFilter> {
        let every = |w: f64| ElementFilter {
            negative_weight: w,
            ..self.clamp(false, FilterScope::Every)
        };
        match self.filter {
            HessianFilter::None => None,
            HessianFilter::Clamp => Some(every(0.0)),
            HessianFilter::Abs => Some(every(1.0)),
            HessianFilter::OnDemand => Some(self.clamp(true, FilterScope::Flagged)),
            HessianFilter::Progressive => Some(every(0.5f64.powi(k.min(1100) as i32))),
        }
    }

    /// The filter of the reassembly when the first assembly's system is indefinite; `None`
    /// when the first is PSD by construction.
    pub fn fallback(&self) -> Option<ElementFilter> {
        match self.filter {
            HessianFilter::None => Some(self.clamp(false, FilterScope::Every)),
            HessianFilter::OnDemand => Some(self.clamp(true, FilterScope::EveryFlagging)),
            HessianFilter::Clamp | HessianFilter::Abs | HessianFilter::Progressive => None,
        }
    }

    /// A PSD filter for iteration `k`, for callers that need a PSD matrix at once (the
    /// contact QP): the first filter if it is PSD by construction, else the fallback.
    pub fn psd(&self, k: u32) -> ElementFilter {
        match self.fallback() {
            Some(f) => f,
            None => self.first(k).expect("a filter PSD by construction"),
        }
    }
}
