//! The linear tetrahedron with single-point quadrature: rest-shape data, the deformation
//! gradient, element energy, 12-vector gradient and 12×12 Hessian, element masses, and the
//! projection of element Hessians to positive semi-definite.
//!
//! Element vectors are ordered `[x_a, y_a, z_a]` for vertices a = 0..4 (index `3a + i`);
//! element matrices are stored column-major in a `[f64; 144]`-sized slice, entry
//! `(3a + i, 3b + k)` at `(3b + k) * 12 + 3a + i`.

mod mass;
mod projection;
mod tet;

pub use mass::{consistent_mass_matrix, lumped_vertex_mass};
pub use projection::{ProjectToPsd, project_to_psd};
pub use tet::{DegenerateTet, Matrix12, TetRest};
