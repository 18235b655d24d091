//! Surface extraction and edge topology, by sorting keys (O(n log n), no hash maps).
//!
//! Orientation: for a positively oriented tet `[a, b, c, d]` (see [`TetMesh::signed_volume6`])
//! the faces `(b, c, d)`, `(a, d, c)`, `(a, b, d)`, `(a, c, b)` have normals (right-hand rule)
//! pointing away from the opposite vertex, i.e. out of the tet. Boundary faces keep that winding,
//! so the boundary of a positively oriented mesh is wound counter-clockwise seen from outside,
//! like an OBJ file. The winding follows the index order, not the current geometry: a tet that is
//! inverted by deformation keeps the faces of its rest orientation.

use super::{SurfaceMesh, TetMesh};

/// Local vertex indices of the 4 faces of a tet `[a, b, c, d]`, wound outward for a positively
/// oriented tet; face `i` is opposite vertex `i`.
pub const TET_FACES: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

/// Local vertex pairs of the 6 edges of a tet.
pub const TET_EDGES: [[usize; 2]; 6] = [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]];

/// How the faces of a tet mesh are shared.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FaceClassification {
    /// Faces owned by exactly one tet, wound outward, in order of (tet, local face).
    pub boundary: Vec<[usize; 3]>,
    /// The tet that owns each boundary face (parallel to `boundary`).
    pub boundary_tets: Vec<usize>,
    /// Faces shared by exactly two tets.
    pub interior: usize,
    /// Interior faces whose two tets wind them the same way (the tets' orientations disagree).
    pub misoriented: usize,
    /// Faces shared by more than two tets (a non-conforming or overlapping mesh).
    pub overshared: usize,
}

/// Edge topology of a triangle set.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EdgeCheck {
    /// Unique undirected edges.
    pub edges: usize,
    /// Edges used by exactly one triangle (holes).
    pub open: usize,
    /// Edges used by more than two triangles.
    pub nonmanifold: usize,
    /// Edges whose two triangles run them in the same direction (inconsistent winding).
    pub misoriented: usize,
    /// Triangles that repeat a vertex.
    pub degenerate_triangles: usize,
}

impl EdgeCheck {
    /// Every edge is shared by exactly two triangles that run it in opposite directions
    /// (an edge-manifold, consistently wound, closed surface; vertex links are not checked).
    pub fn is_closed_manifold(&self) -> bool {
        self.edges > 0
            && self.open == 0
            && self.nonmanifold == 0
            && self.misoriented == 0
            && self.degenerate_triangles == 0
    }
}

/// Sort keys: `u32` when every index fits (half the memory and faster sorting), else `u64`.
trait Key: Copy + Ord {
    fn key(x: usize) -> Self;
    fn index(self) -> usize;
}

impl Key for u32 {
    fn key(x: usize) -> Self {
        x as u32
    }
    fn index(self) -> usize {
        self as usize
    }
}

impl Key for u64 {
    fn key(x: usize) -> Self {
        x as u64
    }
    fn index(self) -> usize {
        self as usize
    }
}

fn fits_u32(largest: usize) -> bool {
    largest < u32::MAX as usize
}

fn max_index<const N: usize>(cells: &[[usize; N]]) -> usize {
    cells.iter().flatten().copied().max().unwrap_or(0)
}

/// Sorted copy of a triple.
fn sorted3<K: Key>(f: [usize; 3]) -> [K; 3] {
    let [mut a, mut b, mut c] = f;
    if a > b {
        std::mem::swap(&mut a, &mut b);
    }
    if b > c {
        std::mem::swap(&mut b, &mut c);
    }
    if a > b {
        std::mem::swap(&mut a, &mut b);
    }
    [K::key(a), K::key(b), K::key(c)]
}

/// Face `local` of tet `tet`, wound as in [`TET_FACES`].
fn tet_face(tet: &[usize; 4], local: usize) -> [usize; 3] {
    TET_FACES[local].map(|i| tet[i])
}

/// Whether `g` is `f` with the opposite winding.
fn opposite(f: [usize; 3], g: [usize; 3]) -> bool {
    let r = [f[0], f[2], f[1]];
    g == r || g == [r[1], r[2], r[0]] || g == [r[2], r[0], r[1]]
}

/// Classifies the faces of a tet mesh by how many tets share them.
pub fn classify_faces(tets: &[[usize; 4]]) -> FaceClassification {
    if fits_u32(max_index(tets).max(4 * tets.len())) {
        classify::<u32>(tets)
    } else {
        classify::<u64>(tets)
    }
}

fn classify<K: Key>(tets: &[[usize; 4]]) -> FaceClassification {
    let mut keys: Vec<([K; 3], K)> = Vec::with_capacity(4 * tets.len());
    for (t, tet) in tets.iter().enumerate() {
        for local in 0..4 {
            keys.push((sorted3(tet_face(tet, local)), K::key(4 * t + local)));
        }
    }
    keys.sort_unstable();
    let face = |id: K| tet_face(&tets[id.index() / 4], id.index() % 4);
    let mut result = FaceClassification::default();
    let mut boundary_ids = Vec::new();
    for run in keys.chunk_by(|x, y| x.0 == y.0) {
        match run {
            [(_, id)] => boundary_ids.push(*id),
            [(_, i), (_, j)] => {
                result.interior += 1;
                if !opposite(face(*i), face(*j)) {
                    result.misoriented += 1;
                }
            }
            _ => result.overshared += 1,
        }
    }
    boundary_ids.sort_unstable();
    result.boundary_tets = boundary_ids.iter().map(|id| id.index() / 4).collect();
    result.boundary = boundary_ids.into_iter().map(face).collect();
    result
}

/// The boundary faces of a tet mesh (faces owned by exactly one tet), wound outward.
pub fn boundary_faces(tets: &[[usize; 4]]) -> Vec<[usize; 3]> {
    classify_faces(tets).boundary
}

/// Number of unique edges of a tet mesh.
pub fn count_tet_edges(tets: &[[usize; 4]]) -> usize {
    let pairs = tets
        .iter()
        .flat_map(|t| TET_EDGES.iter().map(move |&[i, j]| [t[i], t[j]]));
    if fits_u32(max_index(tets)) {
        count_unique::<u32>(pairs)
    } else {
        count_unique::<u64>(pairs)
    }
}

fn count_unique<K: Key>(pairs: impl Iterator<Item = [usize; 2]>) -> usize {
    let mut keys: Vec<[K; 2]> = pairs
        .map(|[a, b]| [K::key(a.min(b)), K::key(a.max(b))])
        .collect();
    keys.sort_unstable();
    keys.dedup();
    keys.len()
}

/// Checks the edge topology of a triangle set.
pub fn check_edges(triangles: &[[usize; 3]]) -> EdgeCheck {
    if fits_u32(max_index(triangles)) {
        edges::<u32>(triangles)
    } else {
        edges::<u64>(triangles)
    }
}

fn edges<K: Key>(triangles: &[[usize; 3]]) -> EdgeCheck {
    let mut result = EdgeCheck::default();
    let mut keys: Vec<([K; 2], bool)> = Vec::with_capacity(3 * triangles.len());
    for &[a, b, c] in triangles {
        if a == b || b == c || c == a {
            result.degenerate_triangles += 1;
            continue;
        }
        for (u, v) in [(a, b), (b, c), (c, a)] {
            keys.push(([K::key(u.min(v)), K::key(u.max(v))], u < v));
        }
    }
    keys.sort_unstable();
    for run in keys.chunk_by(|x, y| x.0 == y.0) {
        result.edges += 1;
        match run {
            [_] => result.open += 1,
            [(_, d1), (_, d2)] => {
                if d1 == d2 {
                    result.misoriented += 1;
                }
            }
            _ => result.nonmanifold += 1,
        }
    }
    result
}

/// Whether a triangle set is a closed, consistently wound, edge-manifold surface.
pub fn is_closed_manifold(triangles: &[[usize; 3]]) -> bool {
    check_edges(triangles).is_closed_manifold()
}

impl TetMesh {
    /// The boundary surface: all of this mesh's vertices (so indices match) and its boundary
    /// faces, wound outward.
    pub fn boundary_surface(&self) -> SurfaceMesh {
        SurfaceMesh {
            positions: self.positions.clone(),
            triangles: boundary_faces(&self.tets),
        }
    }
}

impl SurfaceMesh {
    /// Number of vertices (including any no triangle uses).
    pub fn num_vertices(&self) -> usize {
        self.positions.len()
    }

    /// Number of triangles.
    pub fn num_triangles(&self) -> usize {
        self.triangles.len()
    }

    /// Signed volume enclosed by the triangles (divergence theorem): positive for a closed
    /// surface wound counter-clockwise from outside; meaningless for an open one. Measured
    /// from the first triangle's first vertex, which keeps round-off small far from the origin.
    pub fn enclosed_volume(&self) -> f64 {
        let p = &self.positions;
        let Some(&[o, _, _]) = self.triangles.first() else {
            return 0.0;
        };
        let o = p[o];
        self.triangles
            .iter()
            .map(|&[a, b, c]| (p[a] - o).dot(&(p[b] - o).cross(&(p[c] - o))))
            .sum::<f64>()
            / 6.0
    }

    /// See [`is_closed_manifold`].
    pub fn is_closed_manifold(&self) -> bool {
        is_closed_manifold(&self.triangles)
    }
}
