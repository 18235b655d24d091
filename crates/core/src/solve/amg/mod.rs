//! Smoothed-aggregation algebraic multigrid (Vaněk, Mandel, Brezina 1996) as a CG
//! preconditioner: one symmetric V-cycle per application.
//!
//! Elasticity needs the rigid-body modes as the near-null space: a tentative prolongator
//! built from translations alone lets rotations, which cost almost no energy, go uncorrected,
//! and CG's iterations then grow with the mesh. Setup, per level:
//! 1. strength of connection on node blocks at threshold θ, and the filtered matrix `A_F`
//!    (`strength.rs`);
//! 2. aggregates grown along strong connections, and the tentative prolongator: the
//!    near-null space restricted to each aggregate, orthonormalized (`aggregation.rs`);
//! 3. smoothed prolongator `P = (I − ω D_F⁻¹ A_F) P_tent` with `ω = 4/(3 ρ(D_F⁻¹A_F))`;
//! 4. Galerkin coarse matrix `Pᵀ A P`.
//!
//! The coarsest matrix (≤ [`COARSE_DOFS`] DOFs) is factored densely. Smoothing is one forward
//! Gauss–Seidel sweep before the coarse correction and one backward sweep after, so the cycle
//! is a symmetric positive definite operator, as CG requires; by default in the order of a
//! colouring of each level's nodes, parallel within a colour (`smoother.rs`).
//!
//! Threads: on a level of at least [`AmgSettings::parallel_min_rows`] rows (with
//! [`Parallelism::Rayon`]) the smoother's colours, the mat-vecs and the Galerkin products'
//! rows run in parallel, and so do a build's strength graph, symbolic products, renumberings
//! and power iterations (ranges of rows, concatenated in order); every entry is computed in
//! the same order whoever computes it, so results are the same for any thread count. The
//! aggregation and the colouring (greedy) stay sequential.
//!
//! Reuse: a Newton iteration changes the matrix's values, not its pattern. Within
//! [`AmgSettings::rebuild_every`] setups of a full build, a setup keeps the aggregates and
//! prolongators and recomputes only the Galerkin values `Pᵀ A P`, the smoother's diagonals
//! and the coarse factor — allocation-free, a fraction of a build. A build allocates (the
//! hierarchy's sizes come out of the aggregation); `apply` allocates nothing.

mod aggregation;
mod csr;
mod smoother;
mod strength;

use std::sync::Arc;

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use self::aggregation::{aggregate, near_null_space, tentative_prolongator};
use self::csr::Csr;
pub use self::smoother::AmgSmoother;
use self::smoother::{Sweep, colour_order};
use self::strength::strength;
use super::SolveError;
use crate::parallel::Parallelism;
use crate::sparse::{SparsityPattern, SymmetricMatrix};

/// Coarsest level size (DOFs) that is factored densely.
pub const COARSE_DOFS: usize = 600;
/// Levels at most (the finest included).
const MAX_LEVELS: usize = 12;
/// A lagged refresh ([`AmgSettings::galerkin_every`]) recomputes the coarse operators anyway
/// when some diagonal entry of the finest matrix moved by more than this fraction since they
/// were computed (a new time step size, a stiffening element): the coarse correction would be
/// off by about as much.
pub const GALERKIN_DRIFT: f64 = 0.1;
/// Power iterations for ρ(D⁻¹A).
const POWER_ITERATIONS: usize = 15;
/// Rows from which a level's smoother sweeps, mat-vecs and Galerkin products run on every
/// thread (with [`Parallelism::Rayon`]); below, on the calling thread. From
/// `cargo bench --bench thread_crossover -- amg` (see the crossover table in
/// `results/benchmarks/thread_crossover.md`).
pub const PARALLEL_MIN_ROWS: usize = 8192;

/// AMG settings (`solver.cg.amg` in a scene file).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AmgSettings {
    /// Strength-of-connection threshold θ: nodes k, m are connected when
    /// `‖A_km‖_F ≥ θ √(‖A_kk‖_F ‖A_mm‖_F)`; 0 keeps every connection (coarse operators then
    /// densify as the mesh grows). Default: [`AmgSettings::DEFAULT_THETA`].
    pub strength_threshold: f64,
    /// Setups between full hierarchy builds for one pattern: 1 rebuilds every time, k reuses
    /// the aggregates and prolongators for the next k − 1 setups (only the Galerkin values
    /// are recomputed), 0 never rebuilds until the pattern changes. Default:
    /// [`AmgSettings::DEFAULT_REBUILD_EVERY`].
    pub rebuild_every: usize,
    /// The order of the V-cycle's Gauss–Seidel sweeps. Default: multicolour (parallel).
    pub smoother: AmgSmoother,
    /// Setups between recomputations of the coarse operators `Pᵀ A P` within a kept
    /// hierarchy: 1 recomputes them at every setup; k > 1 refreshes only the finest level's
    /// values in between (the coarse operators lag by up to k − 1 setups; the cycle stays SPD),
    /// unless a diagonal entry moved by more than [`GALERKIN_DRIFT`]. Default:
    /// [`AmgSettings::DEFAULT_GALERKIN_EVERY`].
    pub galerkin_every: usize,
    /// Rows from which a level's loops run on every thread (with the run's parallelism).
    /// Default: [`PARALLEL_MIN_ROWS`].
    pub parallel_min_rows: usize,
}

impl AmgSettings {
    /// θ chosen on the refinement ladder of `tests/preconditioners.rs` (see DESIGN.md).
    pub const DEFAULT_THETA: f64 = 0.08;
    /// Full builds at most every this many setups (see DESIGN.md for the measurement).
    pub const DEFAULT_REBUILD_EVERY: usize = 10;
    /// Coarse operators recomputed every this many setups (see DESIGN.md).
    pub const DEFAULT_GALERKIN_EVERY: usize = 5;

    /// Checks the ranges; the error names the key.
    pub fn validate(&self) -> Result<(), String> {
        if self.galerkin_every == 0 {
            return Err("solver.cg.amg.galerkin_every must be >= 1 (1 = every setup)".into());
        }
        if !(self.strength_threshold.is_finite() && (0.0..1.0).contains(&self.strength_threshold)) {
            return Err(format!(
                "solver.cg.amg.strength_threshold must be in [0, 1), got {}",
                self.strength_threshold
            ));
        }
        Ok(())
    }
}

impl Default for AmgSettings {
    fn default() -> Self {
        Self {
            strength_threshold: Self::DEFAULT_THETA,
            rebuild_every: Self::DEFAULT_REBUILD_EVERY,
            smoother: AmgSmoother::default(),
            galerkin_every: Self::DEFAULT_GALERKIN_EVERY,
            parallel_min_rows: PARALLEL_MIN_ROWS,
        }
    }
}

/// The shape of the current hierarchy and how often it was built or reused, for reports.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AmgStats {
    /// Levels, the finest included (0 before a setup).
    pub levels: usize,
    /// Σ nnz(A_l) / nnz(A_0): the V-cycle's cost relative to a mat-vec, roughly.
    pub operator_complexity: f64,
    /// Σ n_l / n_0.
    pub grid_complexity: f64,
    /// DOFs of the coarsest level.
    pub coarse_dofs: usize,
    /// Full hierarchy builds (aggregation, prolongators, Galerkin products).
    pub builds: usize,
    /// Setups that kept the hierarchy's structure and recomputed only its values.
    pub reuses: usize,
    /// Of the reuses, those that refreshed only the finest level (coarse operators lagged,
    /// [`AmgSettings::galerkin_every`]).
    pub lagged: usize,
    /// Colours of the finest level's smoother (1: DOF order).
    pub fine_colours: usize,
}

/// One level of the hierarchy: its matrix, the prolongator to it from the next coarser level,
/// and work vectors.
struct Level {
    a: Csr,
    inv_diag: Vec<f64>,
    sweep: Sweep,
    /// Whether this level's loops run on every thread ([`AmgSettings::parallel_min_rows`]).
    par: Parallelism,
    /// Prolongator from the next level, its transpose and the product `A P` (kept for its
    /// pattern); `None` on the coarsest level.
    p: Option<Transfer>,
    x: Vec<f64>,
    b: Vec<f64>,
    r: Vec<f64>,
}

struct Transfer {
    p: Csr,
    pt: Csr,
    ap: Csr,
    /// This level's renumbering (new → old), applied to the rows of `p` in
    /// [`Level::finish_transfer`] (a build forms `P` before the level is renumbered).
    rows: Option<Vec<usize>>,
}

impl Level {
    /// Completes this level's transfer once the next coarser level's numbering is final:
    /// renumbers the rows of `P` by this level's renumbering and its columns by `inverse`
    /// (old → new coarse DOF), then forms `Pᵀ` and `A P` (recomputed: renumbering the
    /// build's `A P`, whose rows are long, costs more than the product).
    fn finish_transfer(&mut self, inverse: Option<&[usize]>, markers: &mut [Vec<usize>]) {
        let par = self.par;
        let t = self.p.as_mut().expect("a finer level has a transfer");
        let rows = t.rows.take();
        if rows.is_some() || inverse.is_some() {
            let rows = rows.unwrap_or_else(|| (0..t.p.nrows).collect());
            let identity: Vec<usize>;
            let cols = match inverse {
                Some(inverse) => inverse,
                None => {
                    identity = (0..t.p.ncols).collect();
                    &identity
                }
            };
            t.p = t.p.permuted(&rows, cols, par).0;
        }
        t.pt = t.p.transpose();
        t.ap = self.a.matmul(&t.p, markers, par);
    }
}

/// The smoothed-aggregation hierarchy.
#[derive(Default)]
pub(crate) struct Amg {
    settings: AmgSettings,
    parallelism: Parallelism,
    levels: Vec<Level>,
    coarse: Option<nalgebra::Cholesky<f64, nalgebra::Dyn>>,
    coarse_rhs: DVector<f64>,
    /// Positions of the DOFs (stacked xyz), for the rotations of the near-null space.
    coordinates: Option<Vec<f64>>,
    /// The pattern the hierarchy was built for, and setups since that build.
    pattern: Option<Arc<SparsityPattern>>,
    since_build: usize,
    /// The finest level's renumbering when it is smoothed colour by colour: the DOF
    /// permutation (new → old) and, per stored entry of the renumbered matrix, its position
    /// among the input matrix's values.
    fine_order: Option<(Vec<usize>, Vec<usize>)>,
    /// The finest level's inverse diagonal when the coarse operators were last computed.
    galerkin_diagonal: Vec<f64>,
    /// Scratch of the products' values: one marker per task of a parallel product (one per
    /// pool thread), all `usize::MAX` between calls.
    markers: Vec<Vec<usize>>,
    pub stats: AmgStats,
}

impl Amg {
    pub fn new(settings: AmgSettings, parallelism: Parallelism) -> Self {
        let tasks = match parallelism {
            Parallelism::Sequential => 1,
            Parallelism::Rayon => rayon::current_num_threads().max(1),
        };
        Self {
            settings,
            parallelism,
            markers: vec![Vec::new(); tasks],
            ..Self::default()
        }
    }

    /// The parallelism of a level of `rows` rows.
    fn level_parallelism(&self, rows: usize) -> Parallelism {
        if rows >= self.settings.parallel_min_rows {
            self.parallelism
        } else {
            Parallelism::Sequential
        }
    }

    /// Uses `positions` (stacked xyz, one triple per vertex) for the rigid-body modes of the
    /// next builds; without them the near-null space is the translations.
    pub fn set_coordinates(&mut self, positions: &[f64]) {
        let c = self.coordinates.get_or_insert_with(Vec::new);
        c.clear();
        c.extend_from_slice(positions);
    }

    /// Sets up the hierarchy for `a`: a refresh of the current one when its pattern is `a`'s
    /// and the rebuild interval allows, else a full build.
    pub fn setup(&mut self, a: &SymmetricMatrix) -> Result<(), SolveError> {
        let same_pattern = self
            .pattern
            .as_ref()
            .is_some_and(|p| Arc::ptr_eq(p, a.pattern()) || **p == **a.pattern());
        let k = self.settings.rebuild_every;
        let due = k != 0 && self.since_build + 1 >= k;
        let g = self.settings.galerkin_every;
        // A one-level hierarchy is the finest level's dense factor: nothing to lag.
        let galerkin_due =
            g <= 1 || self.levels.len() < 2 || (self.since_build + 1).is_multiple_of(g);
        if same_pattern && !due && !self.levels.is_empty() {
            let mut lagged = false;
            let refreshed = if galerkin_due {
                self.refresh(a)
            } else {
                self.refresh_finest(a).and_then(|()| {
                    lagged = self.diagonal_drift() <= GALERKIN_DRIFT;
                    if lagged { Ok(()) } else { self.refresh(a) }
                })
            };
            if refreshed.is_ok() {
                self.since_build += 1;
                self.stats.reuses += 1;
                if lagged {
                    self.stats.lagged += 1;
                } else {
                    self.remember_galerkin_diagonal();
                }
                return Ok(());
            }
        }
        self.build(a)?;
        self.remember_galerkin_diagonal();
        self.pattern = Some(a.pattern().clone());
        self.since_build = 0;
        self.stats.builds += 1;
        Ok(())
    }

    /// A full build: aggregation, prolongators, Galerkin products, coarse factor.
    fn build(&mut self, a: &SymmetricMatrix) -> Result<(), SolveError> {
        self.pattern = None;
        self.fine_order = None;
        let p = a.pattern();
        let n = a.dim();
        let fine = Csr {
            nrows: n,
            ncols: n,
            ptr: p.col_ptr().to_vec(),
            idx: p.row_idx().to_vec(),
            val: a.values().to_vec(),
        };
        let block = if n.is_multiple_of(3) { 3 } else { 1 };
        let mut nodes: Vec<usize> = (0..=n / block).map(|k| block * k).collect();
        let mut b = near_null_space(n, block, self.coordinates.as_deref());
        self.levels.clear();
        let mut current = fine;
        loop {
            let inv_diag = inverse_diagonal(&current)?;
            let dofs = current.nrows;
            let par = self.level_parallelism(dofs);
            let coarsen = dofs > COARSE_DOFS && self.levels.len() + 1 < MAX_LEVELS;
            let next = if coarsen {
                let strong = strength(&current, &nodes, self.settings.strength_threshold, par);
                let aggregates = aggregate(&strong);
                let (tentative, coarse_b, coarse_nodes) =
                    tentative_prolongator(&aggregates, &nodes, &b, dofs);
                if tentative.ncols * 10 > dofs * 9 {
                    None // coarsening stalled
                } else {
                    let p = smooth_prolongator(
                        &strong.filtered,
                        &inv_diag,
                        &tentative,
                        &mut self.markers,
                        par,
                    );
                    drop(strong);
                    let ap = current.matmul(&p, &mut self.markers, par);
                    let coarse = p.transpose().matmul(&ap, &mut self.markers, par);
                    Some((p, coarse, coarse_b, coarse_nodes))
                }
            } else {
                None
            };
            // Renumber a smoothed level colour by colour (the coarsest is factored, not
            // smoothed): its matrix, its prolongator's rows, the finer prolongator's columns.
            let coloured =
                self.settings.smoother == AmgSmoother::MulticolourGaussSeidel && next.is_some();
            let (sweep, order) = if coloured {
                let (perm, new_nodes, start) = colour_order(&current, &nodes);
                let mut inverse = vec![0; dofs];
                for (new, &old) in perm.iter().enumerate() {
                    inverse[old] = new;
                }
                let (renumbered, src) = current.permuted(&perm, &inverse, par);
                current = renumbered;
                if self.levels.is_empty() {
                    self.fine_order = Some((perm.clone(), src));
                }
                (Sweep::coloured(new_nodes, start), Some((perm, inverse)))
            } else {
                (Sweep::Lexicographic, None)
            };
            let inv_diag = match &order {
                Some(_) => inverse_diagonal(&current)?,
                None => inv_diag,
            };
            if let Some(finer) = self.levels.last_mut() {
                let inverse = order.as_ref().map(|(_, inverse)| &inverse[..]);
                finer.finish_transfer(inverse, &mut self.markers);
            }
            let perm = order.map(|(perm, _)| perm);
            let next = next.map(|(p, coarse, coarse_b, coarse_nodes)| {
                let transfer = Transfer {
                    p,
                    pt: Csr::default(),
                    ap: Csr::default(),
                    rows: perm,
                };
                (transfer, coarse, coarse_b, coarse_nodes)
            });
            let level = |a: Csr, p| Level {
                inv_diag,
                sweep,
                par,
                p,
                x: vec![0.0; dofs],
                b: vec![0.0; dofs],
                r: vec![0.0; dofs],
                a,
            };
            match next {
                Some((transfer, coarse, coarse_b, coarse_nodes)) => {
                    self.levels.push(level(current, Some(transfer)));
                    current = coarse;
                    b = coarse_b;
                    nodes = coarse_nodes;
                }
                None => {
                    self.coarse = None;
                    self.coarse_rhs = DVector::zeros(dofs);
                    self.levels.push(level(current, None));
                    break;
                }
            }
        }
        self.factor_coarsest()?;
        let (fine_nnz, fine_dofs) = (self.levels[0].a.nnz().max(1), self.levels[0].a.nrows.max(1));
        self.stats.levels = self.levels.len();
        self.stats.operator_complexity =
            self.levels.iter().map(|l| l.a.nnz()).sum::<usize>() as f64 / fine_nnz as f64;
        self.stats.grid_complexity =
            self.levels.iter().map(|l| l.a.nrows).sum::<usize>() as f64 / fine_dofs as f64;
        self.stats.coarse_dofs = self.levels.last().map_or(0, |l| l.a.nrows);
        self.stats.fine_colours = self.levels[0].sweep.colours();
        Ok(())
    }

    /// New values on the finest level only (its matrix and smoother diagonal); the coarse
    /// operators keep their last Galerkin values. The V-cycle stays symmetric positive
    /// definite for any SPD coarse operators, so CG still converges; only the coarse
    /// correction is a little off.
    fn refresh_finest(&mut self, a: &SymmetricMatrix) -> Result<(), SolveError> {
        self.gather_finest(a);
        let level = &mut self.levels[0];
        inverse_diagonal_into(&level.a, &mut level.inv_diag)
    }

    /// The largest relative change of the finest level's inverse diagonal since the coarse
    /// operators were last computed.
    fn diagonal_drift(&self) -> f64 {
        let now = &self.levels[0].inv_diag;
        now.iter()
            .zip(&self.galerkin_diagonal)
            .map(|(x, y)| (x / y - 1.0).abs())
            .fold(0.0, f64::max)
    }

    fn remember_galerkin_diagonal(&mut self) {
        self.galerkin_diagonal.clear();
        self.galerkin_diagonal
            .extend_from_slice(&self.levels[0].inv_diag);
    }

    /// `a`'s values into the finest level (through its renumbering, if any).
    fn gather_finest(&mut self, a: &SymmetricMatrix) {
        match &self.fine_order {
            Some((_, src)) => {
                let values = a.values();
                for (v, &k) in self.levels[0].a.val.iter_mut().zip(src) {
                    *v = values[k];
                }
            }
            None => self.levels[0].a.val.copy_from_slice(a.values()),
        }
    }

    /// New values in the kept hierarchy: `A_0 = a`, `A_{l+1} = P_lᵀ A_l P_l`, diagonals,
    /// coarse factor. Allocates nothing.
    fn refresh(&mut self, a: &SymmetricMatrix) -> Result<(), SolveError> {
        self.gather_finest(a);
        for l in 0..self.levels.len() {
            let (fine, coarse) = self.levels.split_at_mut(l + 1);
            let level = &mut fine[l];
            inverse_diagonal_into(&level.a, &mut level.inv_diag)?;
            if let Some(t) = level.p.as_mut() {
                let par = level.par;
                level
                    .a
                    .matmul_values_par(&t.p, &mut t.ap, &mut self.markers, par);
                t.pt.matmul_values_par(&t.ap, &mut coarse[0].a, &mut self.markers, par);
            }
        }
        self.factor_coarsest()
    }

    /// Dense Cholesky of the coarsest matrix, reusing the previous factor's storage.
    fn factor_coarsest(&mut self) -> Result<(), SolveError> {
        let last = self.levels.last().expect("at least one level");
        let n = last.a.nrows;
        let mut dense = match self.coarse.take() {
            Some(c) if c.l_dirty().nrows() == n => c.unpack_dirty(),
            _ => DMatrix::zeros(n, n),
        };
        dense.fill(0.0);
        for i in 0..n {
            let (idx, val) = last.a.row(i);
            for (&j, &v) in idx.iter().zip(val) {
                // Average the triangles so the matrix is exactly symmetric.
                dense[(i, j)] += 0.5 * v;
                dense[(j, i)] += 0.5 * v;
            }
        }
        self.coarse = Some(
            nalgebra::Cholesky::new(dense).ok_or(SolveError::NotPositiveDefinite { column: 0 })?,
        );
        Ok(())
    }

    /// `z = M⁻¹ r`: one V-cycle from zero.
    pub fn apply(&mut self, r: &[f64], z: &mut [f64]) {
        match self.fine_order.take() {
            Some((perm, src)) => {
                for (b, &old) in self.levels[0].b.iter_mut().zip(&perm) {
                    *b = r[old];
                }
                self.cycle(0);
                for (x, &old) in self.levels[0].x.iter().zip(&perm) {
                    z[old] = *x;
                }
                self.fine_order = Some((perm, src));
            }
            None => {
                self.levels[0].b.copy_from_slice(r);
                self.cycle(0);
                z.copy_from_slice(&self.levels[0].x);
            }
        }
    }

    fn cycle(&mut self, l: usize) {
        let last = l + 1 == self.levels.len();
        if last {
            let level = &mut self.levels[l];
            self.coarse_rhs.as_mut_slice().copy_from_slice(&level.b);
            let chol = self.coarse.as_ref().expect("set up");
            chol.solve_mut(&mut self.coarse_rhs);
            level.x.copy_from_slice(self.coarse_rhs.as_slice());
            return;
        }
        {
            let level = &mut self.levels[l];
            level.x.fill(0.0);
            let par = level.par;
            (level.sweep).run(
                &level.a,
                &level.inv_diag,
                &level.b,
                &mut level.x,
                false,
                par,
            );
            level.a.mul_par(&level.x, &mut level.r, par);
            for (ri, bi) in level.r.iter_mut().zip(&level.b) {
                *ri = bi - *ri;
            }
        }
        {
            let (fine, coarse) = self.levels.split_at_mut(l + 1);
            let t = fine[l].p.as_ref().expect("not the coarsest");
            t.pt.mul_par(&fine[l].r, &mut coarse[0].b, fine[l].par);
        }
        self.cycle(l + 1);
        let (fine, coarse) = self.levels.split_at_mut(l + 1);
        let level = &mut fine[l];
        let t = level.p.as_ref().expect("not the coarsest");
        // r = P x_c, then x += r.
        let par = level.par;
        t.p.mul_par(&coarse[0].x, &mut level.r, par);
        for (xi, ci) in level.x.iter_mut().zip(&level.r) {
            *xi += ci;
        }
        (level.sweep).run(&level.a, &level.inv_diag, &level.b, &mut level.x, true, par);
    }
}

fn inverse_diagonal(a: &Csr) -> Result<Vec<f64>, SolveError> {
    let mut d = vec![0.0; a.nrows];
    inverse_diagonal_into(a, &mut d)?;
    Ok(d)
}

/// `1 / a_ii` into `out`; `NotPositiveDefinite` at the first non-positive diagonal entry.
fn inverse_diagonal_into(a: &Csr, out: &mut [f64]) -> Result<(), SolveError> {
    a.diagonal_into(out);
    for (i, d) in out.iter_mut().enumerate() {
        if *d > 0.0 && d.is_finite() {
            *d = 1.0 / *d;
        } else {
            return Err(SolveError::NotPositiveDefinite { column: i });
        }
    }
    Ok(())
}

/// `(I − ω D_F⁻¹ A_F) P_tent` with `ω = 4 / (3 ρ(D_F⁻¹ A_F))`; D_F is the filtered
/// diagonal, or A's where lumping left it non-positive.
fn smooth_prolongator(
    filtered: &Csr,
    inv_diag: &[f64],
    tentative: &Csr,
    markers: &mut [Vec<usize>],
    par: Parallelism,
) -> Csr {
    let mut inv_df = vec![0.0; filtered.nrows];
    filtered.diagonal_into(&mut inv_df);
    for (d, fallback) in inv_df.iter_mut().zip(inv_diag) {
        *d = if *d > 0.0 && d.is_finite() {
            1.0 / *d
        } else {
            *fallback
        };
    }
    let rho = spectral_radius(filtered, &inv_df, par);
    let omega = 4.0 / (3.0 * rho);
    // S = I − ω D_F⁻¹ A_F, then S P_tent.
    let mut s = filtered.clone();
    for (i, d) in inv_df.iter().enumerate() {
        let (start, end) = (s.ptr[i], s.ptr[i + 1]);
        for k in start..end {
            let v = -omega * d * s.val[k];
            s.val[k] = if s.idx[k] == i { 1.0 + v } else { v };
        }
    }
    s.matmul(tentative, markers, par)
}

/// ρ(D⁻¹A) by power iteration from a fixed vector, with a 10 % margin (an underestimate
/// would make the smoothed prolongator amplify the highest modes).
fn spectral_radius(a: &Csr, inv_diag: &[f64], par: Parallelism) -> f64 {
    let n = a.nrows;
    let mut x: Vec<f64> = (0..n)
        .map(|i| 1.0 + ((i * 7919) % 17) as f64 / 17.0)
        .collect();
    let mut y = vec![0.0; n];
    let mut rho = 1.0;
    for _ in 0..POWER_ITERATIONS {
        a.mul_par(&x, &mut y, par);
        y.iter_mut().zip(inv_diag).for_each(|(v, d)| *v *= d);
        let norm = y.iter().map(|v| v * v).sum::<f64>().sqrt();
        let xnorm = x.iter().map(|v| v * v).sum::<f64>().sqrt();
        if norm == 0.0 || xnorm == 0.0 {
            break;
        }
        rho = norm / xnorm;
        for (xi, yi) in x.iter_mut().zip(&y) {
            *xi = yi / norm;
        }
    }
    1.1 * rho
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sparse::SparsityPattern;

    /// A 1D Laplacian-like SPD matrix of `n` nodes × 3 DOFs (blocks coupled along the chain).
    fn chain(n: usize, scale: f64) -> SymmetricMatrix {
        let dofs = 3 * n;
        let (mut col_ptr, mut row_idx, mut values) = (vec![0], Vec::new(), Vec::new());
        for c in 0..dofs {
            for r in 0..dofs {
                let (vc, vr) = (c / 3, r / 3);
                if vc.abs_diff(vr) <= 1 && (c % 3 == r % 3 || vc == vr) {
                    row_idx.push(r);
                    values.push(if r == c {
                        scale * (2.5 + 0.001 * r as f64)
                    } else if vr == vc {
                        0.1
                    } else {
                        -1.0
                    });
                }
            }
            col_ptr.push(row_idx.len());
        }
        let pattern = Arc::new(SparsityPattern::from_csc(dofs, col_ptr, row_idx));
        let mut m = SymmetricMatrix::zeros(pattern);
        m.values_mut().copy_from_slice(&values);
        m
    }

    #[test]
    fn a_refresh_recomputes_every_galerkin_product_of_the_kept_prolongators() {
        let mut amg = Amg::new(
            AmgSettings {
                rebuild_every: 0,
                ..AmgSettings::default()
            },
            Parallelism::Sequential,
        );
        amg.setup(&chain(400, 1.0)).unwrap();
        assert!(amg.levels.len() >= 2);
        let b = chain(400, 1.7);
        amg.setup(&b).unwrap();
        assert_eq!((amg.stats.builds, amg.stats.reuses), (1, 1));
        let (_, src) = amg
            .fine_order
            .as_ref()
            .expect("renumbered colour by colour");
        let gathered: Vec<f64> = src.iter().map(|&k| b.values()[k]).collect();
        assert_eq!(amg.levels[0].a.val, gathered);
        let mut markers = vec![Vec::new()];
        let seq = Parallelism::Sequential;
        for l in 0..amg.levels.len() - 1 {
            let t = amg.levels[l].p.as_ref().unwrap();
            let ap = amg.levels[l].a.matmul(&t.p, &mut markers, seq);
            assert_eq!(
                (&ap.ptr, &ap.idx),
                (&t.ap.ptr, &t.ap.idx),
                "kept A P pattern"
            );
            let expected = t.pt.matmul(&ap, &mut markers, seq);
            assert_eq!(expected.idx, amg.levels[l + 1].a.idx);
            for (x, y) in expected.val.iter().zip(&amg.levels[l + 1].a.val) {
                assert!((x - y).abs() <= 1e-12 * x.abs().max(1.0));
            }
        }
    }

    /// Between Galerkin recomputations a setup refreshes only the finest level, unless a
    /// diagonal entry moved by more than [`GALERKIN_DRIFT`]: a 0.5 % change is lagged, a 70 %
    /// change recomputes the coarse operators.
    #[test]
    fn small_changes_lag_the_coarse_operators_and_large_ones_recompute_them() {
        let mut amg = Amg::new(
            AmgSettings {
                rebuild_every: 0,
                galerkin_every: 10,
                ..AmgSettings::default()
            },
            Parallelism::Sequential,
        );
        amg.setup(&chain(400, 1.0)).unwrap();
        let coarse = amg.levels[1].a.val.clone();
        amg.setup(&chain(400, 1.005)).unwrap();
        assert_eq!((amg.stats.reuses, amg.stats.lagged), (1, 1));
        assert_eq!(amg.levels[1].a.val, coarse, "coarse operators kept");
        amg.setup(&chain(400, 1.7)).unwrap();
        assert_eq!((amg.stats.reuses, amg.stats.lagged), (2, 1));
        assert_ne!(amg.levels[1].a.val, coarse, "coarse operators recomputed");
        // One level (the dense factor of the matrix itself) is never lagged.
        let mut small = Amg::new(
            AmgSettings {
                rebuild_every: 0,
                galerkin_every: 10,
                ..AmgSettings::default()
            },
            Parallelism::Sequential,
        );
        small.setup(&chain(100, 1.0)).unwrap();
        assert_eq!(small.levels.len(), 1);
        small.setup(&chain(100, 1.005)).unwrap();
        assert_eq!((small.stats.reuses, small.stats.lagged), (1, 0));
    }
}
