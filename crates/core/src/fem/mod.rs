//! The linear tetrahedron with single-point quadrature: rest-shape data, the deformation
//! gradient, element energy, 12-vector gradient and 12×12 Hessian, element masses, and the
//! projection of element Hessians to positive semi-definite and their eigenvalue filters
//! (`filter.rs`: clamp, absolute value, blends; on the 12×12 or on the 9×9 dP/dF).
//!
//! Element vectors are ordered `[x_a, y_a, z_a]` for vertices a = 0..4 (index `3a + i`).
//! Element matrices are stored *block-major* in a 144-entry slice: the 3×3 block coupling
//! vertices a (rows) and b (columns) occupies 9 consecutive entries starting at
//! [`block_offset`]`(4, a, b)`, column-major within the block, so assembly reads each block
//! as one contiguous run.

mod filter;
mod mass;
mod projection;
mod tet;

pub use filter::{
    ElementFilter, FilterScope, FilterSpace, Filterable, ROUNDOFF, UnknownFilterSpace,
};
pub use mass::{consistent_mass_matrix, lumped_vertex_mass};
pub use projection::{ProjectToPsd, project_to_psd};
pub use tet::{DegenerateTet, Matrix12, TetRest};

/// Start of block (a, b) of an element matrix over `nodes` vertices in block-major layout.
#[inline]
pub const fn block_offset(nodes: usize, a: usize, b: usize) -> usize {
    (b * nodes + a) * 9
}

/// Read a block-major element matrix into a dense 12×12 matrix.
pub fn unpack_matrix12(buf: &[f64]) -> Matrix12 {
    Matrix12::from_fn(|r, c| buf[block_offset(4, r / 3, c / 3) + 3 * (c % 3) + r % 3])
}

/// Write a dense 12×12 matrix into block-major layout.
pub fn pack_matrix12(m: &Matrix12, buf: &mut [f64]) {
    for c in 0..12 {
        for r in 0..12 {
            buf[block_offset(4, r / 3, c / 3) + 3 * (c % 3) + r % 3] = m[(r, c)];
        }
    }
}
