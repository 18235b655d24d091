//! Aggregation for smoothed aggregation: the near-null space (rigid-body modes), aggregates
//! grown along strong connections, and the tentative prolongator that restricts the
//! near-null space to each aggregate.

use nalgebra::DMatrix;

use super::csr::Csr;
use super::strength::Strength;

/// The near-null space of the finest level, column-major `n × k`: translations, plus
/// rotations about the centroid (scaled by the body's size) when positions are known.
pub(super) fn near_null_space(n: usize, block: usize, coordinates: Option<&[f64]>) -> DMatrix<f64> {
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

/// Aggregate of each node, grown along the strong connections of `strength`: a free node
/// whose strong neighbours are all free seeds an aggregate with them; leftovers join the
/// aggregate of their first strong neighbour that has one; nodes with no aggregated strong
/// neighbour form their own. Every node ends in an aggregate.
pub(super) fn aggregate(strength: &Strength) -> Vec<usize> {
    let count = strength.adj_ptr.len() - 1;
    const FREE: usize = usize::MAX;
    let mut agg = vec![FREE; count];
    let mut n_agg = 0;
    for k in 0..count {
        if agg[k] == FREE && strength.neighbours(k).iter().all(|&m| agg[m] == FREE) {
            agg[k] = n_agg;
            for &m in strength.neighbours(k) {
                agg[m] = n_agg;
            }
            n_agg += 1;
        }
    }
    let after_pass1 = agg.clone();
    for (k, a) in agg.iter_mut().enumerate() {
        if *a == FREE
            && let Some(&m) = strength
                .neighbours(k)
                .iter()
                .find(|&&m| after_pass1[m] != FREE)
        {
            *a = after_pass1[m];
        }
    }
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
pub(super) fn tentative_prolongator(
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
