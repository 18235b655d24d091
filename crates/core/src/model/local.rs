//! Read access for integrators that work element by element or vertex by vertex (vertex
//! block descent, projective dynamics, XPBD) instead of through assembled gradients and
//! Hessians: the tets with their rest data and material, and the lumped vertex masses.

use super::Model;
use crate::fem::TetRest;
use crate::material::MaterialModel;

/// The tet elements of a model's elastic body.
#[derive(Clone, Copy, Debug)]
pub struct ElasticElements<'a> {
    /// The elastic material of every tet.
    pub material: &'a MaterialModel,
    /// Vertex indices of each tet (all vertices, fixed ones included), positively oriented.
    pub tets: &'a [[usize; 4]],
    /// Rest data of each tet (same order as `tets`).
    pub rest: &'a [TetRest],
}

impl Model {
    /// The elastic tets, or `None` for a body without tet elasticity.
    pub fn elastic_elements(&self) -> Option<ElasticElements<'_>> {
        self.elastic.as_ref().map(|e| ElasticElements {
            material: &e.material,
            tets: &e.tets,
            rest: &e.rest,
        })
    }
}
