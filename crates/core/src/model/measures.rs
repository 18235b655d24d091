//! Per-element measures for output (frames, diagnostics): the elastic tets as the model uses
//! them, per tet the volume ratio `J = det F` and the elastic energy `volume * psi(F)`, and the
//! number of inverted tets (which the run loop counts after every step). Evaluated
//! sequentially, not counted in [`super::EvalCounters`].

use super::{FIXED, Model, ModelError};
use nalgebra::{Matrix3, Vector3};

impl Model {
    /// The elastic tets (0-based vertex indices), after any reorientation of inverted rest tets;
    /// empty when the model has no elastic material. Element measures are in this order.
    pub fn tets(&self) -> &[[usize; 4]] {
        self.elastic.as_ref().map_or(&[], |e| &e.tets)
    }

    /// For state `q`, writes per elastic tet (in [`Self::tets`] order) the volume ratio
    /// `det F` to `det_f` and the elastic energy `volume * psi(F)` (J) to `energy`; the energies
    /// sum to the elastic part of [`Self::potential_parts`] up to round-off. Where `psi` is
    /// undefined (an inverted tet for a material that does not handle inversion) the energy
    /// is NaN. Fails only when `q` has the wrong length.
    ///
    /// # Panics
    /// When `det_f` or `energy` does not have one entry per tet.
    pub fn element_measures(
        &self,
        q: &[f64],
        det_f: &mut [f64],
        energy: &mut [f64],
    ) -> Result<(), ModelError> {
        if q.len() != self.num_dofs() {
            return Err(ModelError::StateLength {
                got: q.len(),
                expected: self.num_dofs(),
            });
        }
        let tets = self.tets();
        assert_eq!(det_f.len(), tets.len(), "det_f needs one entry per tet");
        assert_eq!(energy.len(), tets.len(), "energy needs one entry per tet");
        let Some(body) = &self.elastic else {
            return Ok(());
        };
        self.for_each_deformation_gradient(q, |e, f| {
            det_f[e] = f.determinant();
            energy[e] = body
                .material
                .energy_density(f)
                .map_or(f64::NAN, |psi| body.rest[e].volume * psi);
        });
        Ok(())
    }

    /// The number of elastic tets with `det F <= 0` (inverted or flat) in state `q`; 0 without
    /// an elastic material. Cheap enough to call after every step (one F per tet, nothing
    /// allocated). Fails only when `q` has the wrong length.
    pub fn inverted_elements(&self, q: &[f64]) -> Result<usize, ModelError> {
        if q.len() != self.num_dofs() {
            return Err(ModelError::StateLength {
                got: q.len(),
                expected: self.num_dofs(),
            });
        }
        let mut inverted = 0;
        self.for_each_deformation_gradient(q, |_, f| {
            // A non-finite F is not counted: the run loop stops on a non-finite state.
            if f.determinant() <= 0.0 {
                inverted += 1;
            }
        });
        Ok(inverted)
    }

    /// Calls `each(e, F)` for every elastic tet `e` (in [`Self::tets`] order) in state `q`
    /// (of the right length): the one place measures compute F.
    fn for_each_deformation_gradient(&self, q: &[f64], mut each: impl FnMut(usize, &Matrix3<f64>)) {
        let Some(body) = &self.elastic else {
            return;
        };
        let position = |v: usize| match self.dofs.free_index(v) {
            FIXED => self.positions[v],
            f => {
                let f = 3 * f as usize;
                Vector3::new(q[f], q[f + 1], q[f + 2])
            }
        };
        for (e, (tet, rest)) in body.tets.iter().zip(&body.rest).enumerate() {
            each(e, &rest.deformation_gradient(&tet.map(position)));
        }
    }
}
