//! Compressed sparse rows for the multigrid hierarchy, with products split into a symbolic
//! phase (the pattern, allocated once) and a numeric phase (values into that pattern,
//! allocation-free), so a hierarchy whose structure is kept recomputes only values.

use std::ops::Range;

use crate::parallel::Parallelism;

/// Rows per task of a parallel mat-vec.
const ROWS_PER_TASK: usize = 1024;
/// Rows (or nodes) per task of a parallel hierarchy build step: a symbolic product, a
/// renumbering, the strength graph.
pub(super) const BUILD_ROWS_PER_TASK: usize = 2048;

/// `f` on contiguous ranges covering `0..items` (`per_task` items each), in parallel with
/// [`Parallelism::Rayon`], each task with scratch from `init`; the outputs in range order.
/// Sequentially (or on a pool of one thread), one range. When `f`'s output for an item does
/// not depend on the range it falls in, concatenating the outputs gives the same result for
/// any thread count.
pub(super) fn map_ranges<S, T>(
    items: usize,
    per_task: usize,
    par: Parallelism,
    init: impl Fn() -> S + Sync + Send,
    f: impl Fn(Range<usize>, &mut S) -> T + Sync + Send,
) -> Vec<T>
where
    T: Send,
{
    if par == Parallelism::Sequential || items <= per_task || rayon::current_num_threads() < 2 {
        return vec![f(0..items, &mut init())];
    }
    use rayon::prelude::*;
    let tasks = items.div_ceil(per_task);
    (0..tasks)
        .into_par_iter()
        .map_init(init, |scratch, t| {
            f(t * per_task..((t + 1) * per_task).min(items), scratch)
        })
        .collect()
}

/// Rows of a matrix under construction (a range of them, in [`map_ranges`]): each row's
/// entries pushed, then [`RowChunk::end_row`]; `src` optionally records, per entry, where it
/// came from.
#[derive(Default)]
pub(super) struct RowChunk {
    /// End of each row's entries within this chunk.
    pub ends: Vec<usize>,
    pub idx: Vec<usize>,
    pub val: Vec<f64>,
    pub src: Vec<usize>,
}

impl RowChunk {
    pub fn end_row(&mut self) {
        self.ends.push(self.idx.len());
    }

    /// The chunks' rows one after the other: a matrix of `ncols` columns, and the
    /// concatenated `src`.
    pub fn concat(chunks: Vec<RowChunk>, ncols: usize) -> (Csr, Vec<usize>) {
        let rows: usize = chunks.iter().map(|c| c.ends.len()).sum();
        let nnz: usize = chunks.iter().map(|c| c.idx.len()).sum();
        let mut c = Csr {
            nrows: rows,
            ncols,
            ptr: Vec::with_capacity(rows + 1),
            idx: Vec::with_capacity(nnz),
            val: Vec::with_capacity(nnz),
        };
        let mut src = Vec::with_capacity(chunks.iter().map(|c| c.src.len()).sum());
        c.ptr.push(0);
        for chunk in chunks {
            let base = c.idx.len();
            c.ptr.extend(chunk.ends.iter().map(|e| base + e));
            c.idx.extend_from_slice(&chunk.idx);
            c.val.extend_from_slice(&chunk.val);
            src.extend_from_slice(&chunk.src);
        }
        (c, src)
    }
}

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
        self.mul_rows(0, x, y);
    }

    /// `y = A x`, rows in parallel chunks with [`Parallelism::Rayon`] (each row's sum in the
    /// same order: the result does not depend on the thread count).
    pub fn mul_par(&self, x: &[f64], y: &mut [f64], par: Parallelism) {
        match par {
            Parallelism::Sequential => self.mul(x, y),
            Parallelism::Rayon => {
                use rayon::prelude::*;
                y.par_chunks_mut(ROWS_PER_TASK)
                    .enumerate()
                    .for_each(|(c, ys)| self.mul_rows(c * ROWS_PER_TASK, x, ys));
            }
        }
    }

    /// Rows `first..first + y.len()` of `A x` into `y`.
    fn mul_rows(&self, first: usize, x: &[f64], y: &mut [f64]) {
        for (k, yi) in y.iter_mut().enumerate() {
            let (idx, val) = self.row(first + k);
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

    /// `A B`: the pattern (Gustavson, sorted rows; row ranges on every thread with
    /// [`Parallelism::Rayon`]), then the values through [`Csr::matmul_values_par`].
    /// `markers` as for that function.
    pub fn matmul(&self, b: &Csr, markers: &mut [Vec<usize>], par: Parallelism) -> Csr {
        let chunks = map_ranges(
            self.nrows,
            BUILD_ROWS_PER_TASK,
            par,
            || vec![usize::MAX; b.ncols],
            |rows, marker| {
                let mut chunk = RowChunk::default();
                for i in rows {
                    let start = chunk.idx.len();
                    for &k in self.row(i).0 {
                        for &j in b.row(k).0 {
                            if marker[j] != i {
                                marker[j] = i;
                                chunk.idx.push(j);
                            }
                        }
                    }
                    chunk.idx[start..].sort_unstable();
                    chunk.end_row();
                }
                chunk.val.resize(chunk.idx.len(), 0.0);
                chunk
            },
        );
        let mut c = RowChunk::concat(chunks, b.ncols).0;
        self.matmul_values_par(b, &mut c, markers, par);
        c
    }

    /// The values of `A B` into `c`, whose pattern holds that product's (from
    /// [`Csr::matmul`] on the same patterns). Allocates nothing; `marker` as for `matmul`.
    pub fn matmul_values(&self, b: &Csr, c: &mut Csr, marker: &mut [usize]) {
        let rows = 0..self.nrows;
        self.matmul_rows(b, &c.ptr, &c.idx, rows, &mut c.val, marker);
    }

    /// [`Csr::matmul_values`] with the rows split into one contiguous range per marker, the
    /// ranges in parallel with [`Parallelism::Rayon`]. Each entry is summed in the same order
    /// by whichever task holds its row: the result does not depend on the split.
    pub fn matmul_values_par(
        &self,
        b: &Csr,
        c: &mut Csr,
        markers: &mut [Vec<usize>],
        par: Parallelism,
    ) {
        for m in markers.iter_mut() {
            if m.len() < b.ncols {
                m.resize(b.ncols, usize::MAX);
            }
        }
        if par == Parallelism::Sequential || markers.len() < 2 {
            self.matmul_values(b, c, &mut markers[0]);
            return;
        }
        let Csr { ptr, idx, val, .. } = c;
        self.matmul_split(b, ptr, idx, 0..self.nrows, val, markers);
    }

    fn matmul_split(
        &self,
        b: &Csr,
        ptr: &[usize],
        idx: &[usize],
        rows: Range<usize>,
        val: &mut [f64],
        markers: &mut [Vec<usize>],
    ) {
        if markers.len() == 1 {
            self.matmul_rows(b, ptr, idx, rows, val, &mut markers[0]);
            return;
        }
        let (left_markers, right_markers) = markers.split_at_mut(markers.len() / 2);
        let mid = rows.start
            + rows.len() * left_markers.len() / (left_markers.len() + right_markers.len());
        let (left, right) = val.split_at_mut(ptr[mid] - ptr[rows.start]);
        rayon::join(
            || self.matmul_split(b, ptr, idx, rows.start..mid, left, left_markers),
            || self.matmul_split(b, ptr, idx, mid..rows.end, right, right_markers),
        );
    }

    /// The values of rows `rows` of `A B` into `val` (those rows' entries of the product's
    /// pattern `ptr`, `idx`).
    fn matmul_rows(
        &self,
        b: &Csr,
        ptr: &[usize],
        idx: &[usize],
        rows: Range<usize>,
        val: &mut [f64],
        marker: &mut [usize],
    ) {
        let base = ptr[rows.start];
        for i in rows {
            let (s, e) = (ptr[i], ptr[i + 1]);
            for p in s..e {
                marker[idx[p]] = p - base;
                val[p - base] = 0.0;
            }
            let (ai, av) = self.row(i);
            for (&k, &a) in ai.iter().zip(av) {
                let (bk, bv) = b.row(k);
                for (&j, &v) in bk.iter().zip(bv) {
                    val[marker[j]] += a * v;
                }
            }
            for p in s..e {
                marker[idx[p]] = usize::MAX;
            }
        }
    }

    /// `Π_r A Π_cᵀ`: row `r` of the result is row `rows[r]` of `A`, column `j` becomes
    /// `new_col[j]` (columns sorted again). Also returns, per stored entry of the result, its
    /// position in `A` (to gather new values of the same pattern). Row ranges on every thread
    /// with [`Parallelism::Rayon`].
    pub fn permuted(
        &self,
        rows: &[usize],
        new_col: &[usize],
        par: Parallelism,
    ) -> (Csr, Vec<usize>) {
        let chunks = map_ranges(
            rows.len(),
            BUILD_ROWS_PER_TASK,
            par,
            Vec::<(usize, usize)>::new,
            |range, entries| {
                let mut chunk = RowChunk::default();
                for &old in &rows[range] {
                    entries.clear();
                    entries.extend(
                        (self.ptr[old]..self.ptr[old + 1]).map(|p| (new_col[self.idx[p]], p)),
                    );
                    entries.sort_unstable();
                    for &(j, p) in entries.iter() {
                        chunk.idx.push(j);
                        chunk.val.push(self.val[p]);
                        chunk.src.push(p);
                    }
                    chunk.end_row();
                }
                chunk
            },
        );
        RowChunk::concat(chunks, self.ncols)
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
        let mut markers = vec![Vec::new()];
        let c = a.matmul(&b, &mut markers, Parallelism::Sequential);
        // [2 0 -1; 0 3 0; 1 4 0] [0 5; -2 1; 7 0]
        assert_eq!(
            dense(&c),
            vec![vec![-7.0, 10.0], vec![-6.0, 3.0], vec![-8.0, 9.0]]
        );
        assert!(markers[0].iter().all(|&m| m == usize::MAX));
        let t = c.transpose();
        assert_eq!(
            dense(&t),
            vec![vec![-7.0, -6.0, -8.0], vec![10.0, 3.0, 9.0]]
        );
        // New values in the same patterns: only the values change.
        let mut a2 = a.clone();
        a2.val.iter_mut().for_each(|v| *v *= 2.0);
        let mut c2 = c.clone();
        a2.matmul_values(&b, &mut c2, &mut markers[0]);
        assert_eq!(c2.idx, c.idx);
        assert!(c2.val.iter().zip(&c.val).all(|(x, y)| *x == 2.0 * y));
    }

    /// A banded matrix of `n` rows with a row-dependent pattern and irrational-ish values.
    fn banded(n: usize, ncols: usize) -> Csr {
        let mut c = Csr {
            nrows: n,
            ncols,
            ptr: vec![0],
            ..Csr::default()
        };
        for i in 0..n {
            let mut cols: Vec<usize> = (0..1 + i % 5).map(|k| (i * 7 + k * 13) % ncols).collect();
            cols.sort_unstable();
            cols.dedup();
            for j in cols {
                c.idx.push(j);
                c.val.push(((i * 31 + j) as f64).sin());
            }
            c.ptr.push(c.idx.len());
        }
        c
    }

    /// The row-parallel symbolic product and renumbering give the matrices the sequential
    /// ones do, bit for bit, on a pool of three threads (ranges of `BUILD_ROWS_PER_TASK`).
    #[test]
    fn parallel_products_and_renumberings_are_the_sequential_ones() {
        let n = 5 * BUILD_ROWS_PER_TASK + 17;
        let a = banded(n, n);
        let b = banded(n, 900);
        let rows: Vec<usize> = (0..n).map(|i| (i * 7919) % n).collect();
        let cols: Vec<usize> = (0..n).rev().collect();
        let run = |par| {
            let mut markers = vec![Vec::new(); 3];
            let c = a.matmul(&b, &mut markers, par);
            let (p, src) = a.permuted(&rows, &cols, par);
            (c, p, src)
        };
        let (c1, p1, s1) = run(Parallelism::Sequential);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap();
        let (c3, p3, s3) = pool.install(|| run(Parallelism::Rayon));
        assert_eq!((&c1.ptr, &c1.idx, &c1.val), (&c3.ptr, &c3.idx, &c3.val));
        assert_eq!(
            (&p1.ptr, &p1.idx, &p1.val, &s1),
            (&p3.ptr, &p3.idx, &p3.val, &s3)
        );
        // The renumbering is a renumbering: entry k of the result is entry src[k] of `a`.
        for (k, &p) in s1.iter().enumerate() {
            assert_eq!(p1.val[k], a.val[p]);
        }
        assert_eq!(c1.nnz(), c1.val.len());
    }
}
