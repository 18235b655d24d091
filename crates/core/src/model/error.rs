//! Errors from building or evaluating a [`super::Model`].

/// What went wrong building or evaluating a model. Messages name the field or element.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// Tets with negative signed volume, refused unless the model is told to reorient them.
    #[error(
        "{count} inverted tet(s) (negative volume), first: {first:?}; fix the mesh or set reorient = true"
    )]
    InvertedTets { count: usize, first: Vec<usize> },
    /// Tets with (numerically) zero volume, which have no deformation gradient.
    #[error("{count} degenerate tet(s) (zero volume), first: {first:?}")]
    DegenerateTets { count: usize, first: Vec<usize> },
    /// A tet refers to a vertex that does not exist.
    #[error("tet {tet} refers to vertex {vertex}, but the mesh has {vertices} vertices")]
    TetIndexOutOfRange {
        tet: usize,
        vertex: usize,
        vertices: usize,
    },
    /// A parameter is out of its valid range.
    #[error("{field} = {value} is invalid: {expected}")]
    InvalidParameter {
        field: String,
        value: String,
        expected: String,
    },
    /// Invalid material constants.
    #[error(transparent)]
    Material(#[from] crate::material::MaterialError),
    /// A fixed-vertex index is out of range.
    #[error("fixed.indices: vertex {index} does not exist (the mesh has {vertices} vertices)")]
    FixedIndexOutOfRange { index: usize, vertices: usize },
    /// A spring refers to a missing vertex or joins a vertex to itself.
    #[error(
        "spring {spring} joins vertices {i} and {j}; both must exist ({vertices} vertices) and differ"
    )]
    InvalidSpring {
        spring: usize,
        i: usize,
        j: usize,
        vertices: usize,
    },
    /// A free vertex has no mass, so M would be singular.
    #[error("vertex {vertex} is free but has zero mass (no tet and no point mass)")]
    MasslessVertex { vertex: usize },
    /// An element's energy is undefined at the current state (e.g. J <= 0 for the course Neo-Hookean).
    #[error(
        "tet {tet} is inverted or collapsed (det F = {det_f:.3e}); {material} is undefined there"
    )]
    InvertedElement {
        tet: usize,
        det_f: f64,
        material: &'static str,
    },
    /// The state vector has the wrong length.
    #[error("state has {got} entries, the model has {expected} free DOFs")]
    StateLength { got: usize, expected: usize },
}

impl crate::error_class::Classify for ModelError {
    /// The model's construction errors are its input's (mesh, parameters, fixed set); an
    /// element inverted at some state is the computation's.
    fn class(&self) -> crate::error_class::ErrorClass {
        match self {
            Self::InvertedElement { .. } => crate::error_class::ErrorClass::Failure,
            Self::Material(e) => crate::error_class::Classify::class(e),
            _ => crate::error_class::ErrorClass::BadInput,
        }
    }
}
