//! A uniform grid over the bounding boxes of a tet mesh's tets, for point queries: which tets
//! may contain a point ([`TetGrid::candidates`]) and which tet is nearest to it
//! ([`TetGrid::nearest`]).
//!
//! Cells are cubes whose edge is half the mean largest bounding-box extent of a tet, so a tet
//! of typical size is listed in 8 to 27 cells and a cell lists a few dozen tets at most (22 on
//! average for the armadillo display vertices on `arma_6`). The lists are stored compressed (one
//! offset array and one index array), built by counting in two passes.

use nalgebra::Vector3;

/// Cell edge as a fraction of the mean largest bounding-box extent of a tet.
const CELL_FRACTION: f64 = 0.5;

/// The grid never has more than this many cells per tet (a few huge tets among tiny ones
/// would otherwise ask for a grid much larger than the mesh).
const MAX_CELLS_PER_TET: usize = 64;

/// A uniform grid of cubic cells over a tet mesh's bounding box; each cell lists the tets
/// whose bounding box overlaps it.
#[derive(Clone, Debug)]
pub struct TetGrid {
    origin: Vector3<f64>,
    /// Cell edge length (> 0).
    cell: f64,
    dims: [usize; 3],
    /// Cell `c` lists `tets[start[c]..start[c + 1]]`.
    start: Vec<u32>,
    tets: Vec<u32>,
}

impl TetGrid {
    /// Builds the grid over `tets` (0-based indices into `positions`, each `< positions.len()`).
    ///
    /// # Panics
    /// When a tet index is out of range, or there are 2^32 tets or more.
    pub fn new(positions: &[Vector3<f64>], tets: &[[usize; 4]]) -> Self {
        assert!(
            u32::try_from(tets.len()).is_ok(),
            "too many tets for a TetGrid"
        );
        let boxes: Vec<(Vector3<f64>, Vector3<f64>)> = tets
            .iter()
            .map(|t| {
                let p = t.map(|v| positions[v]);
                (
                    p[0].inf(&p[1]).inf(&p[2].inf(&p[3])),
                    p[0].sup(&p[1]).sup(&p[2].sup(&p[3])),
                )
            })
            .collect();
        let Some((lo, hi)) = boxes
            .iter()
            .copied()
            .reduce(|(a, b), (c, d)| (a.inf(&c), b.sup(&d)))
        else {
            return Self {
                origin: Vector3::zeros(),
                cell: 1.0,
                dims: [1, 1, 1],
                start: vec![0, 0],
                tets: Vec::new(),
            };
        };
        let extent = hi - lo;
        let mean = boxes.iter().map(|(a, b)| (b - a).max()).sum::<f64>() / boxes.len() as f64;
        let largest = extent.max();
        let mut cell = if mean > 0.0 {
            CELL_FRACTION * mean
        } else if largest > 0.0 {
            largest
        } else {
            1.0
        };
        let dims_for = |cell: f64| extent.map(|e| ((e / cell).ceil() as usize).max(1));
        let limit = MAX_CELLS_PER_TET * tets.len();
        while dims_for(cell).iter().product::<usize>() > limit {
            cell *= 1.25;
        }
        let d = dims_for(cell);
        let mut grid = Self {
            origin: lo,
            cell,
            dims: [d.x, d.y, d.z],
            start: Vec::new(),
            tets: Vec::new(),
        };
        // Count, then fill: cell c's tets go to tets[start[c]..start[c + 1]] in tet order.
        let mut start = vec![0u32; d.x * d.y * d.z + 1];
        for (lo, hi) in &boxes {
            grid.for_cells_in_box(lo, hi, |c| start[c + 1] += 1);
        }
        for c in 0..start.len() - 1 {
            start[c + 1] += start[c];
        }
        let mut next: Vec<u32> = start[..start.len() - 1].to_vec();
        let mut list = vec![0u32; *start.last().unwrap() as usize];
        for (t, (lo, hi)) in boxes.iter().enumerate() {
            grid.for_cells_in_box(lo, hi, |c| {
                list[next[c] as usize] = t as u32;
                next[c] += 1;
            });
        }
        grid.start = start;
        grid.tets = list;
        grid
    }

    /// Number of cells along x, y and z.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// The cell edge length.
    pub fn cell_size(&self) -> f64 {
        self.cell
    }

    /// The cell index along `axis` of coordinate `x`, clamped to the grid.
    fn axis_cell(&self, x: f64, axis: usize) -> usize {
        let i = ((x - self.origin[axis]) / self.cell).floor();
        if i.is_nan() || i < 0.0 {
            0
        } else {
            (i as usize).min(self.dims[axis] - 1)
        }
    }

    fn linear(&self, [i, j, k]: [usize; 3]) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    fn list(&self, cell: [usize; 3]) -> &[u32] {
        let c = self.linear(cell);
        &self.tets[self.start[c] as usize..self.start[c + 1] as usize]
    }

    fn for_cells_in_box(&self, lo: &Vector3<f64>, hi: &Vector3<f64>, mut f: impl FnMut(usize)) {
        let a: [usize; 3] = std::array::from_fn(|d| self.axis_cell(lo[d], d));
        let b: [usize; 3] = std::array::from_fn(|d| self.axis_cell(hi[d], d));
        for k in a[2]..=b[2] {
            for j in a[1]..=b[1] {
                for i in a[0]..=b[0] {
                    f(self.linear([i, j, k]));
                }
            }
        }
    }

    /// The tets whose bounding box overlaps the cell holding `p` (every tet that contains `p`
    /// is among them); empty when `p` is outside the grid.
    pub fn candidates(&self, p: &Vector3<f64>) -> &[u32] {
        let inside = (0..3).all(|d| {
            let x = (p[d] - self.origin[d]) / self.cell;
            x >= 0.0 && x <= self.dims[d] as f64
        });
        if !inside {
            return &[];
        }
        self.list(std::array::from_fn(|d| self.axis_cell(p[d], d)))
    }

    /// The tet nearest to `p` and its distance, given `distance(t)`, the distance from `p` to
    /// tet `t` (0 inside). Searches shells of cells around `p`'s (clamped) cell until no unseen
    /// tet can be nearer. Ties go to the tet seen first (deterministic). `None` without tets.
    pub fn nearest(
        &self,
        p: &Vector3<f64>,
        mut distance: impl FnMut(usize) -> f64,
    ) -> Option<(usize, f64)> {
        if self.tets.is_empty() {
            return None;
        }
        let c: [usize; 3] = std::array::from_fn(|d| self.axis_cell(p[d], d));
        let mut best: Option<(usize, f64)> = None;
        for r in 0usize.. {
            let lo: [usize; 3] = std::array::from_fn(|d| c[d].saturating_sub(r));
            let hi: [usize; 3] = std::array::from_fn(|d| (c[d] + r).min(self.dims[d] - 1));
            for k in lo[2]..=hi[2] {
                for j in lo[1]..=hi[1] {
                    for i in lo[0]..=hi[0] {
                        let shell =
                            [i, j, k].iter().zip(&c).map(|(&a, &b)| a.abs_diff(b)).max() == Some(r);
                        if !shell {
                            continue;
                        }
                        for &t in self.list([i, j, k]) {
                            let d = distance(t as usize);
                            if best.is_none_or(|(_, b)| d < b) {
                                best = Some((t as usize, d));
                            }
                        }
                    }
                }
            }
            // Every unseen tet lies in cells beyond the searched block: bound its distance.
            let mut bound = f64::INFINITY;
            for d in 0..3 {
                if c[d] > r {
                    let face = self.origin[d] + (c[d] - r) as f64 * self.cell;
                    bound = bound.min((p[d] - face).max(0.0));
                }
                if c[d] + r + 1 < self.dims[d] {
                    let face = self.origin[d] + (c[d] + r + 1) as f64 * self.cell;
                    bound = bound.min((face - p[d]).max(0.0));
                }
            }
            match best {
                Some((_, b)) if b <= bound => break,
                _ if bound == f64::INFINITY => break,
                _ => {}
            }
        }
        best
    }
}
