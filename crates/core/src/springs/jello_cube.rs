//! The jello cube: an `n × n × n` particle lattice with springs between
//! - axis neighbours (structural), `3 n² (n − 1)` of them;
//! - face diagonals, `6 n (n − 1)²`, and space diagonals, `4 (n − 1)³` (both shear);
//! - every-other particles along the axes (bending), `3 n² (n − 2)`.
//!
//! (Per axis there are `n − 1` neighbour pairs on each of the `n²` lines; each of the three
//! families of coordinate planes holds `n` planes of `(n − 1)²` squares with 2 diagonals each;
//! each of the `(n − 1)³` cells has 4 space diagonals; per axis there are `n − 2` skip-one
//! pairs on each line.) For `n = 2` that is all 28 pairs of the 8 corners.

use super::{SpringBody, SpringCoefficients, SpringKind};
use crate::mesh::generate::box_mesh;
use nalgebra::Vector3;

/// Lattice offsets of each kind, one of each `±` pair (first non-zero component positive),
/// so every unordered pair of particles is visited once.
const STRUCTURAL: [[i64; 3]; 3] = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
const SHEAR: [[i64; 3]; 10] = [
    // face diagonals
    [1, 1, 0],
    [1, -1, 0],
    [1, 0, 1],
    [1, 0, -1],
    [0, 1, 1],
    [0, 1, -1],
    // space diagonals
    [1, 1, 1],
    [1, 1, -1],
    [1, -1, 1],
    [1, -1, -1],
];
const BENDING: [[i64; 3]; 3] = [[2, 0, 0], [0, 2, 0], [0, 0, 2]];

/// An `n × n × n` particle lattice of edge length `size` (m) with its minimum corner at
/// `origin`: particle `(i, j, k)` is at `origin + size (i, j, k) / (n − 1)` and has index
/// `i + n (j + n k)` (x fastest, the vertex order of [`box_mesh`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JelloCube {
    /// Particles per edge, >= 2.
    pub n: usize,
    /// Edge length (m), > 0.
    pub size: f64,
    /// The minimum corner (m).
    pub origin: Vector3<f64>,
}

impl JelloCube {
    /// The body, with each spring's stiffness and damping from `coefficients(kind)` (called
    /// for `Structural`, `Shear` and `Bending`). The body's tets are the Kuhn split of the
    /// lattice cells (6 per cell), for display.
    ///
    /// # Panics
    /// If `n < 2` or `size` is not positive and finite.
    pub fn build(&self, coefficients: impl Fn(SpringKind) -> SpringCoefficients) -> SpringBody {
        let n = self.n;
        assert!(n >= 2, "jello cube: n must be at least 2, got {n}");
        let mesh = box_mesh([n - 1; 3], [self.size; 3]);
        let mut body = SpringBody {
            positions: mesh.positions.iter().map(|p| p + self.origin).collect(),
            tets: mesh.tets,
            springs: Vec::new(),
            kinds: Vec::new(),
        };
        let index = |[i, j, k]: [i64; 3]| -> Option<usize> {
            let inside = |c: i64| (0..n as i64).contains(&c);
            (inside(i) && inside(j) && inside(k))
                .then(|| (i + n as i64 * (j + n as i64 * k)) as usize)
        };
        for (kind, offsets) in [
            (SpringKind::Structural, &STRUCTURAL[..]),
            (SpringKind::Shear, &SHEAR[..]),
            (SpringKind::Bending, &BENDING[..]),
        ] {
            let c = coefficients(kind);
            for k in 0..n as i64 {
                for j in 0..n as i64 {
                    for i in 0..n as i64 {
                        let a = index([i, j, k]).expect("inside");
                        for d in offsets {
                            if let Some(b) = index([i + d[0], j + d[1], k + d[2]]) {
                                body.push(a, b, kind, c);
                            }
                        }
                    }
                }
            }
        }
        body
    }
}
