//! Compressed sparse rows for the multigrid hierarchy, with products split into a symbolic
//! phase (the pattern, allocated once) and a numeric phase (values into that pattern,
//! allocation-free), so a hierarchy whose structure is kept recomputes only values.

/// A sparse matrix in CSR (for a symmetric matrix, also its CSC); columns sorted per row.
#[derive(Clone, Debug, Default)]
pub(super) struct Csr {
    pub nrows: usize,
    pub ncols: usize,
    pub ptr: Vec<usize>,
    pub idx: Vec<usize>,
    pub val: Vec<f64>,
}

impl Csr {
    pub fn row(&self, i: usize) -> (&[usize], &[f64]) {
        let (s, e) = (self.ptr[i], self.ptr[i + 1]);
        (&self.idx[s..e], &self.val[s..e])
    }

    pub fn nnz(&self) -> usize {
        self.idx.len()
    }

    /// `y = A x`.
    pub fn mul(&self, x: &[f64], y: &mut [f64]) {
        for (i, yi) in y.iter_mut().enumerate() {
            let (idx, val) = self.row(i);
            *yi = idx.iter().zip(val).map(|(&j, &v)| v * x[j]).sum();
        }
    }

    /// `Aᵀ` (columns come out sorted: rows are visited in order).
    pub fn transpose(&self) -> Csr {
        let mut ptr = vec![0usize; self.ncols + 1];
        for &j in &self.idx {
            ptr[j + 1] += 1;
        }
        for j in 0..self.ncols {
            ptr[j + 1] += ptr[j];
        }
        let mut next = ptr.clone();
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

    /// `A B`: the pattern (Gustavson, sorted rows), then the values through
    /// [`Csr::matmul_values`]. `marker` is scratch of length ≥ `b.ncols`, all `usize::MAX`
    /// on entry and on return.
    pub fn matmul(&self, b: &Csr, marker: &mut Vec<usize>) -> Csr {
        if marker.len() < b.ncols {
            marker.resize(b.ncols, usize::MAX);
        }
        let mut ptr = Vec::with_capacity(self.nrows + 1);
        ptr.push(0);
        let mut idx = Vec::new();
        for i in 0..self.nrows {
            let start = idx.len();
            for &k in self.row(i).0 {
                for &j in b.row(k).0 {
                    if marker[j] != i {
                        marker[j] = i;
                        idx.push(j);
                    }
                }
            }
            idx[start..].sort_unstable();
            ptr.push(idx.len());
        }
        marker[..b.ncols].fill(usize::MAX);
        let mut c = Csr {
            nrows: self.nrows,
            ncols: b.ncols,
            ptr,
            val: vec![0.0; idx.len()],
            idx,
        };
        self.matmul_values(b, &mut c, marker);
        c
    }

    /// The values of `A B` into `c`, whose pattern holds that product's (from
    /// [`Csr::matmul`] on the same patterns). Allocates nothing; `marker` as for `matmul`.
    pub fn matmul_values(&self, b: &Csr, c: &mut Csr, marker: &mut [usize]) {
        for i in 0..self.nrows {
            let (s, e) = (c.ptr[i], c.ptr[i + 1]);
            for p in s..e {
                marker[c.idx[p]] = p;
                c.val[p] = 0.0;
            }
            let (ai, av) = self.row(i);
            for (&k, &a) in ai.iter().zip(av) {
                let (bk, bv) = b.row(k);
                for (&j, &v) in bk.iter().zip(bv) {
                    c.val[marker[j]] += a * v;
                }
            }
            for p in s..e {
                marker[c.idx[p]] = usize::MAX;
            }
        }
    }

    /// The diagonal entries (0 where none is stored).
    pub fn diagonal_into(&self, out: &mut [f64]) {
        for (i, d) in out.iter_mut().enumerate() {
            let (idx, val) = self.row(i);
            *d = idx.binary_search(&i).map_or(0.0, |k| val[k]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dense(c: &Csr) -> Vec<Vec<f64>> {
        let mut d = vec![vec![0.0; c.ncols]; c.nrows];
        for (i, row) in d.iter_mut().enumerate() {
            let (idx, val) = c.row(i);
            for (&j, &v) in idx.iter().zip(val) {
                row[j] += v;
            }
        }
        d
    }

    fn csr(rows: &[&[(usize, f64)]], ncols: usize) -> Csr {
        let mut c = Csr {
            nrows: rows.len(),
            ncols,
            ptr: vec![0],
            ..Csr::default()
        };
        for r in rows {
            for &(j, v) in *r {
                c.idx.push(j);
                c.val.push(v);
            }
            c.ptr.push(c.idx.len());
        }
        c
    }

    #[test]
    fn product_and_transpose_match_dense_arithmetic() {
        let a = csr(
            &[&[(0, 2.0), (2, -1.0)], &[(1, 3.0)], &[(0, 1.0), (1, 4.0)]],
            3,
        );
        let b = csr(&[&[(1, 5.0)], &[(0, -2.0), (1, 1.0)], &[(0, 7.0)]], 2);
        let mut marker = Vec::new();
        let c = a.matmul(&b, &mut marker);
        // [2 0 -1; 0 3 0; 1 4 0] [0 5; -2 1; 7 0]
        assert_eq!(
            dense(&c),
            vec![vec![-7.0, 10.0], vec![-6.0, 3.0], vec![-8.0, 9.0]]
        );
        assert!(marker.iter().all(|&m| m == usize::MAX));
        let t = c.transpose();
        assert_eq!(
            dense(&t),
            vec![vec![-7.0, -6.0, -8.0], vec![10.0, 3.0, 9.0]]
        );
        // New values in the same patterns: only the values change.
        let mut a2 = a.clone();
        a2.val.iter_mut().for_each(|v| *v *= 2.0);
        let mut c2 = c.clone();
        a2.matmul_values(&b, &mut c2, &mut marker);
        assert_eq!(c2.idx, c.idx);
        assert!(c2.val.iter().zip(&c.val).all(|(x, y)| *x == 2.0 * y));
    }
}
