//! Smoothed-aggregation algebraic multigrid (Vaněk, Mandel, Brezina 1996) as a CG
//! preconditioner: one symmetric V-cycle per application.
//!
//! Elasticity needs the rigid-body modes as the near-null space: a tentative prolongator
//! built from translations alone lets rotations, which cost almost no energy, go uncorrected,
//! and CG's iterations then grow with the mesh. Setup, per level:
//! 1. aggregate the node graph (a node is a vertex's 3 DOFs on the finest level, an
//!    aggregate's coarse DOFs below): seeds whose neighbours are all free take them, leftovers
//!    join a neighbouring aggregate;
//! 2. tentative prolongator: the near-null space restricted to each aggregate, orthonormalized
//!    (modified Gram–Schmidt, dependent columns dropped); the coefficients are the coarse
//!    near-null space;
//! 3. smoothed prolongator `P = (I − ω D⁻¹ A) P_tent` with `ω = 4/(3 ρ(D⁻¹A))` (ρ from power
//!    iterations);
//! 4. Galerkin coarse matrix `Pᵀ A P`.
//!
//! The coarsest matrix (≤ [`COARSE_DOFS`] DOFs) is factored densely. Smoothing is one forward
//! Gauss–Seidel sweep before the coarse correction and one backward sweep after, so the cycle
//! is a symmetric positive definite operator, as CG requires. Every loop runs in a fixed
//! order: results are the same for any thread count.
//!
//! Setup allocates (the hierarchy's sizes depend on the values through the Galerkin
//! products); `apply` does not.

use nalgebra::{DMatrix, DVector};

use super::SolveError;
use crate::sparse::SymmetricMatrix;

/// Coarsest level size (DOFs) that is factored densely.
pub const COARSE_DOFS: usize = 600;
/// Levels at most (the finest included).
const MAX_LEVELS: usize = 12;
/// Power iterations for ρ(D⁻¹A).
const POWER_ITERATIONS: usize = 15;

/// A sparse matrix in CSR (for a symmetric matrix, also its CSC).
#[derive(Clone, Debug, Default)]
struct Csr {
    nrows: usize,
    ncols: usize,
    ptr: Vec<usize>,
    idx: Vec<usize>,
    val: Vec<f64>,
}

impl Csr {
    fn row(&self, i: usize) -> (&[usize], &[f64]) {
        let (s, e) = (self.ptr[i], self.ptr[i + 1]);
        (&self.idx[s..e], &self.val[s..e])
    }

    /// `y = A x`.
    fn mul(&self, x: &[f64], y: &mut [f64]) {
        for (i, yi) in y.iter_mut().enumerate() {
            let (idx, val) = self.row(i);
            *yi = idx.iter().zip(val).map(|(&j, &v)| v * x[j]).sum();
        }
    }

    fn transpose(&self) -> Csr {
        let mut count = vec![0usize; self.ncols + 1];
        for &j in &self.idx {
            count[j + 1] += 1;
        }
        for j in 0..self.ncols {
            count[j + 1] += count[j];
        }
        let ptr = count.clone();
        let mut next = count;
        let mut idx = vec![0; self.idx.len()];
        let mut val = vec![0.0; self.val.len()];
        for i in 0..self.nrows {
            let (ri, rv) = self.row(i);
            for (&j, &v) in ri.iter().zip(rv) {
                idx[next[j]] = i;
                val[next[j]] = v;
                next[j] += 1;
            }
        }
        Csr {
            nrows: self.ncols,
            ncols: self.nrows,
            ptr,
            idx,
            val,
        }
    }

    /// `A B` (Gustavson, columns of each row in first-touch order, then sorted).
    fn matmul(&self, b: &Csr) -> Csr {
        let mut pos = vec![usize::MAX; b.ncols];
        let mut ptr = vec![0];
        let mut idx = Vec::new();
        let mut val = Vec::new();
        for i in 0..self.nrows {
            let start = idx.len();
            let (ai, av) = self.row(i);
            for (&k, &a) in ai.iter().zip(av) {
                let (bk, bv) = b.row(k);
                for (&j, &v) in bk.iter().zip(bv) {
                    if pos[j] == usize::MAX {
                        pos[j] = idx.len();
                        idx.push(j);
                        val.push(a * v);
                    } else {
                        val[pos[j]] += a * v;
                    }
                }
            }
            for &j in &idx[start..] {
                pos[j] = usize::MAX;
            }
            sort_row(&mut idx[start..], &mut val[start..]);
            ptr.push(idx.len());
        }
        Csr {
            nrows: self.nrows,
            ncols: b.ncols,
            ptr,
            idx,
            val,
        }
    }

    fn diagonal(&self) -> Vec<f64> {
        (0..self.nrows)
            .map(|i| {
                let (idx, val) = self.row(i);
                idx.iter().position(|&j| j == i).map_or(0.0, |k| val[k])
            })
            .collect()
    }
}

/// Sorts a row's entries by column.
fn sort_row(idx: &mut [usize], val: &mut [f64]) {
    let mut pairs: Vec<(usize, f64)> = idx.iter().copied().zip(val.iter().copied()).collect();
    pairs.sort_unstable_by_key(|p| p.0);
    for (k, (j, v)) in pairs.into_iter().enumerate() {
        idx[k] = j;
        val[k] = v;
    }
}

/// One level of the hierarchy: its matrix, the prolongator to it from the next coarser level,
/// and work vectors.
struct Level {
    a: Csr,
    inv_diag: Vec<f64>,
    /// Prolongator from the next level (`None` on the coarsest) and its transpose.
    p: Option<(Csr, Csr)>,
    x: Vec<f64>,
    b: Vec<f64>,
    r: Vec<f64>,
}

/// Sizes of a built hierarchy, for reports.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AmgShape {
    pub levels: usize,
    /// Σ nnz(A_l) / nnz(A_0).
    pub operator_complexity: f64,
    /// DOFs of the coarsest level.
    pub coarse_dofs: usize,
}

/// The smoothed-aggregation hierarchy.
#[derive(Default)]
pub(crate) struct Amg {
    levels: Vec<Level>,
    coarse: Option<nalgebra::Cholesky<f64, nalgebra::Dyn>>,
    coarse_rhs: DVector<f64>,
    /// Positions of the DOFs (stacked xyz), for the rotations of the near-null space.
    coordinates: Option<Vec<f64>>,
    pub shape: AmgShape,
}

impl Amg {
    /// Uses `positions` (stacked xyz, one triple per vertex) for the rigid-body modes of the
    /// next setups; without them the near-null space is the translations.
    pub fn set_coordinates(&mut self, positions: &[f64]) {
        let c = self.coordinates.get_or_insert_with(Vec::new);
        c.clear();
        c.extend_from_slice(positions);
    }

    /// Builds the hierarchy for `a`.
    pub fn setup(&mut self, a: &SymmetricMatrix) -> Result<(), SolveError> {
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
        let fine_nnz = current.idx.len().max(1) as f64;
        let mut total_nnz = 0.0;
        loop {
            let inv_diag = inverse_diagonal(&current)?;
            total_nnz += current.idx.len() as f64;
            let dofs = current.nrows;
            let coarsen = dofs > COARSE_DOFS && self.levels.len() + 1 < MAX_LEVELS;
            let next = if coarsen {
                let aggregates = aggregate(&current, &nodes);
                let (tentative, coarse_b, coarse_nodes) =
                    tentative_prolongator(&aggregates, &nodes, &b, dofs);
                if tentative.ncols * 10 > dofs * 9 {
                    None // coarsening stalled
                } else {
                    let p = smooth_prolongator(&current, &inv_diag, &tentative);
                    let pt = p.transpose();
                    let coarse = pt.matmul(&current.matmul(&p));
                    Some((p, pt, coarse, coarse_b, coarse_nodes))
                }
            } else {
                None
            };
            let level = |a: Csr, p| Level {
                inv_diag,
                p,
                x: vec![0.0; dofs],
                b: vec![0.0; dofs],
                r: vec![0.0; dofs],
                a,
            };
            match next {
                Some((p, pt, coarse, coarse_b, coarse_nodes)) => {
                    self.levels.push(level(current, Some((p, pt))));
                    current = coarse;
                    b = coarse_b;
                    nodes = coarse_nodes;
                }
                None => {
                    let dense = DMatrix::from_fn(dofs, dofs, |i, j| {
                        let (idx, val) = current.row(i);
                        idx.binary_search(&j).map_or(0.0, |k| val[k])
                    });
                    let dense = 0.5 * (&dense + dense.transpose());
                    self.coarse = Some(
                        nalgebra::Cholesky::new(dense)
                            .ok_or(SolveError::NotPositiveDefinite { column: 0 })?,
                    );
                    self.coarse_rhs = DVector::zeros(dofs);
                    self.levels.push(level(current, None));
                    break;
                }
            }
        }
        self.shape = AmgShape {
            levels: self.levels.len(),
            operator_complexity: total_nnz / fine_nnz,
            coarse_dofs: self.levels.last().map_or(0, |l| l.a.nrows),
        };
        Ok(())
    }

    /// `z = M⁻¹ r`: one V-cycle from zero.
    pub fn apply(&mut self, r: &[f64], z: &mut [f64]) {
        self.levels[0].b.copy_from_slice(r);
        self.cycle(0);
        z.copy_from_slice(&self.levels[0].x);
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
            gauss_seidel(&level.a, &level.inv_diag, &level.b, &mut level.x, false);
            level.a.mul(&level.x, &mut level.r);
            for (ri, bi) in level.r.iter_mut().zip(&level.b) {
                *ri = bi - *ri;
            }
        }
        {
            let (fine, coarse) = self.levels.split_at_mut(l + 1);
            let (_, pt) = fine[l].p.as_ref().expect("not the coarsest");
            pt.mul(&fine[l].r, &mut coarse[0].b);
        }
        self.cycle(l + 1);
        let (fine, coarse) = self.levels.split_at_mut(l + 1);
        let level = &mut fine[l];
        let (p, _) = level.p.as_ref().expect("not the coarsest");
        // r = P x_c, then x += r.
        p.mul(&coarse[0].x, &mut level.r);
        for (xi, ci) in level.x.iter_mut().zip(&level.r) {
            *xi += ci;
        }
        gauss_seidel(&level.a, &level.inv_diag, &level.b, &mut level.x, true);
    }
}

/// One Gauss–Seidel sweep on `A x = b`, forward or backward.
fn gauss_seidel(a: &Csr, inv_diag: &[f64], b: &[f64], x: &mut [f64], backward: bool) {
    let mut update = |i: usize| {
        let (idx, val) = a.row(i);
        let mut s = b[i];
        for (&j, &v) in idx.iter().zip(val) {
            if j != i {
                s -= v * x[j];
            }
        }
        x[i] = s * inv_diag[i];
    };
    if backward {
        (0..a.nrows).rev().for_each(&mut update);
    } else {
        (0..a.nrows).for_each(&mut update);
    }
}

fn inverse_diagonal(a: &Csr) -> Result<Vec<f64>, SolveError> {
    a.diagonal()
        .into_iter()
        .enumerate()
        .map(|(i, d)| {
            if d > 0.0 && d.is_finite() {
                Ok(1.0 / d)
            } else {
                Err(SolveError::NotPositiveDefinite { column: i })
            }
        })
        .collect()
}

/// The near-null space of the finest level, column-major `n × k`: translations, plus
/// rotations about the centroid (scaled by the body's size) when positions are known.
fn near_null_space(n: usize, block: usize, coordinates: Option<&[f64]>) -> DMatrix<f64> {
    if block == 1 {
        return DMatrix::from_element(n, 1, 1.0);
    }
    let vertices = n / 3;
    let coordinates = coordinates.filter(|c| c.len() == n);
    let k = if coordinates.is_some() { 6 } else { 3 };
    let mut b = DMatrix::zeros(n, k);
    for v in 0..vertices {
        for d in 0..3 {
            b[(3 * v + d, d)] = 1.0;
        }
    }
    if let Some(x) = coordinates {
        let mut c = [0.0; 3];
        for v in 0..vertices {
            for d in 0..3 {
                c[d] += x[3 * v + d] / vertices as f64;
            }
        }
        let size = (0..vertices)
            .map(|v| (0..3).map(|d| (x[3 * v + d] - c[d]).powi(2)).sum::<f64>())
            .fold(0.0f64, f64::max)
            .sqrt()
            .max(f64::MIN_POSITIVE);
        for v in 0..vertices {
            let p = [0, 1, 2].map(|d| (x[3 * v + d] - c[d]) / size);
            // Rotations about x, y, z: ω × p.
            b[(3 * v + 1, 3)] = -p[2];
            b[(3 * v + 2, 3)] = p[1];
            b[(3 * v, 4)] = p[2];
            b[(3 * v + 2, 4)] = -p[0];
            b[(3 * v, 5)] = -p[1];
            b[(3 * v + 1, 5)] = p[0];
        }
    }
    b
}

/// Node of each node's aggregate, from the node graph of `a` (`nodes[k]..nodes[k + 1]` are
/// node k's DOFs). Every node ends in an aggregate.
fn aggregate(a: &Csr, nodes: &[usize]) -> Vec<usize> {
    let count = nodes.len() - 1;
    let mut node_of = vec![0; a.nrows];
    for k in 0..count {
        node_of[nodes[k]..nodes[k + 1]].fill(k);
    }
    // Node adjacency (CSR over nodes), without self loops.
    let mut adj_ptr = vec![0];
    let mut adj = Vec::new();
    let mut seen = vec![usize::MAX; count];
    for k in 0..count {
        for i in nodes[k]..nodes[k + 1] {
            for &j in a.row(i).0 {
                let m = node_of[j];
                if m != k && seen[m] != k {
                    seen[m] = k;
                    adj.push(m);
                }
            }
        }
        adj_ptr.push(adj.len());
    }
    let neighbours = |k: usize| &adj[adj_ptr[k]..adj_ptr[k + 1]];
    const FREE: usize = usize::MAX;
    let mut agg = vec![FREE; count];
    let mut n_agg = 0;
    // Pass 1: a free node whose neighbours are all free seeds an aggregate with them.
    for k in 0..count {
        if agg[k] == FREE && neighbours(k).iter().all(|&m| agg[m] == FREE) {
            agg[k] = n_agg;
            for &m in neighbours(k) {
                agg[m] = n_agg;
            }
            n_agg += 1;
        }
    }
    // Pass 2: leftovers join the aggregate of a neighbour (the first aggregated one).
    let after_pass1 = agg.clone();
    for (k, a) in agg.iter_mut().enumerate() {
        if *a == FREE
            && let Some(&m) = neighbours(k).iter().find(|&&m| after_pass1[m] != FREE)
        {
            *a = after_pass1[m];
        }
    }
    // Pass 3: isolated nodes form their own aggregates.
    for a in agg.iter_mut() {
        if *a == FREE {
            *a = n_agg;
            n_agg += 1;
        }
    }
    agg
}

/// The tentative prolongator (orthonormal columns per aggregate), the coarse near-null space
/// and the coarse node ranges.
fn tentative_prolongator(
    agg: &[usize],
    nodes: &[usize],
    b: &DMatrix<f64>,
    dofs: usize,
) -> (Csr, DMatrix<f64>, Vec<usize>) {
    let n_agg = agg.iter().copied().max().map_or(0, |m| m + 1);
    let k = b.ncols();
    // DOFs of each aggregate, in node order.
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); n_agg];
    for (node, &g) in agg.iter().enumerate() {
        members[g].extend(nodes[node]..nodes[node + 1]);
    }
    // Entries (row, col, value) of P_tent, and the coarse B rows.
    let mut entries: Vec<(usize, usize, f64)> = Vec::new();
    let mut coarse_rows: Vec<Vec<f64>> = Vec::new();
    let mut coarse_nodes = vec![0];
    for rows in &members {
        let mut q: Vec<Vec<f64>> = Vec::new();
        let mut r_rows: Vec<Vec<f64>> = Vec::new();
        for c in 0..k {
            let original: Vec<f64> = rows.iter().map(|&i| b[(i, c)]).collect();
            let norm0 = original.iter().map(|v| v * v).sum::<f64>().sqrt();
            let mut v = original;
            let mut coeffs = vec![0.0; q.len()];
            for _ in 0..2 {
                for (t, qt) in q.iter().enumerate() {
                    let d: f64 = qt.iter().zip(&v).map(|(a, b)| a * b).sum();
                    coeffs[t] += d;
                    v.iter_mut().zip(qt).for_each(|(vi, qi)| *vi -= d * qi);
                }
            }
            let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            // R's column c: the coefficients on the kept columns.
            for (t, ct) in coeffs.iter().enumerate() {
                r_rows[t][c] = *ct;
            }
            if norm0 > 0.0 && norm > 1e-8 * norm0 {
                v.iter_mut().for_each(|x| *x /= norm);
                q.push(v);
                let mut row = vec![0.0; k];
                row[c] = norm;
                r_rows.push(row);
            }
        }
        let first_col = *coarse_nodes.last().expect("starts with 0");
        for (t, qt) in q.iter().enumerate() {
            for (&i, &v) in rows.iter().zip(qt) {
                entries.push((i, first_col + t, v));
            }
        }
        coarse_rows.extend(r_rows);
        coarse_nodes.push(first_col + q.len());
    }
    let ncols = *coarse_nodes.last().expect("nonempty");
    entries.sort_unstable_by_key(|e| (e.0, e.1));
    let mut ptr = vec![0; dofs + 1];
    for e in &entries {
        ptr[e.0 + 1] += 1;
    }
    for i in 0..dofs {
        ptr[i + 1] += ptr[i];
    }
    let p = Csr {
        nrows: dofs,
        ncols,
        ptr,
        idx: entries.iter().map(|e| e.1).collect(),
        val: entries.iter().map(|e| e.2).collect(),
    };
    let coarse_b = DMatrix::from_fn(ncols, k, |i, j| coarse_rows[i][j]);
    (p, coarse_b, coarse_nodes)
}

/// `(I − ω D⁻¹ A) P_tent` with `ω = 4 / (3 ρ(D⁻¹ A))`.
fn smooth_prolongator(a: &Csr, inv_diag: &[f64], tentative: &Csr) -> Csr {
    let rho = spectral_radius(a, inv_diag);
    let omega = 4.0 / (3.0 * rho);
    // S = I − ω D⁻¹ A, then S P_tent.
    let mut s = a.clone();
    for (i, d) in inv_diag.iter().enumerate() {
        let (start, end) = (s.ptr[i], s.ptr[i + 1]);
        for k in start..end {
            let v = -omega * d * s.val[k];
            s.val[k] = if s.idx[k] == i { 1.0 + v } else { v };
        }
    }
    s.matmul(tentative)
}

/// ρ(D⁻¹A) by power iteration from a fixed vector, with a 10 % margin (an underestimate
/// would make the smoothed prolongator amplify the highest modes).
fn spectral_radius(a: &Csr, inv_diag: &[f64]) -> f64 {
    let n = a.nrows;
    let mut x: Vec<f64> = (0..n)
        .map(|i| 1.0 + ((i * 7919) % 17) as f64 / 17.0)
        .collect();
    let mut y = vec![0.0; n];
    let mut rho = 1.0;
    for _ in 0..POWER_ITERATIONS {
        a.mul(&x, &mut y);
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
