//! Per-element measures for output (frames, diagnostics): the elastic tets as the model uses
//! them, and per tet the volume ratio `J = det F` and the elastic energy `volume * psi(F)`.
//! Not on any hot path: evaluated sequentially, not counted in [`super::EvalCounters`].

use super::{FIXED, Model, ModelError};
use nalgebra::Vector3;

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
        let position = |v: usize| match self.dofs.free_index(v) {
            FIXED => self.positions[v],
            f => {
                let f = 3 * f as usize;
                Vector3::new(q[f], q[f + 1], q[f + 2])
            }
        };
        for (e, (tet, rest)) in body.tets.iter().zip(&body.rest).enumerate() {
            let f = rest.deformation_gradient(&tet.map(position));
            det_f[e] = f.determinant();
            energy[e] = body
                .material
                .energy_density(&f)
                .map_or(f64::NAN, |psi| rest.volume * psi);
        }
        Ok(())
    }
}
