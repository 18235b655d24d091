//! The error in the lowest vibration modes: a run's positions projected on the `modes` lowest
//! `M`-orthonormal eigenvectors of the body at rest, against the reference's. A method that
//! damps the high modes (backward Euler, every L-stable method) leaves the ringing a reference
//! keeps; the pointwise error then measures the ringing and plateaus, while the error in the
//! lowest modes measures the motion a user sees and falls at the method's order.

use crate::study::vocabulary::format::cell;
use crate::study::vocabulary::measured::Measured;
use crate::study::vocabulary::shared_store::{bits, from_bits};
use softbench_core::model::{Model, Modes, lowest_modes};

/// The runs.csv columns: the modal error (empty when not scored), the reference's own
/// difference in it, the modes counted and the highest of their frequencies (rad/s).
pub const MODAL_COLUMNS: [&str; 4] = [
    "modal_error",
    "reference_modal_difference",
    "modal_modes",
    "modal_omega_cutoff",
];

/// The modes of a reference.
#[derive(Clone, Debug, PartialEq)]
pub struct ModalBasis {
    modes: Modes,
}

impl ModalBasis {
    /// The `count` lowest modes of `model` at its rest state.
    pub fn of(model: &mut Model, count: usize) -> Result<Self, String> {
        let rest = model.rest_state();
        const OFF: &str = "(`modes = 0` in the reference table measures no modal error)";
        let modes = lowest_modes(model, &rest, count)
            .map_err(|e| format!("the lowest modes for the modal error: {e} {OFF}"))?;
        if !modes.converged {
            return Err(format!(
                "the {count} lowest modes for the modal error did not converge in {} subspace \
                 iterations {OFF}",
                modes.iterations
            ));
        }
        Ok(Self { modes })
    }

    /// The highest frequency kept (rad/s).
    pub fn cutoff(&self) -> f64 {
        self.modes.omega.last().copied().unwrap_or(0.0)
    }

    /// The number of modes.
    pub fn count(&self) -> usize {
        self.modes.len()
    }

    /// `sqrt(Σ_k |P(a_k - b_k)|²) / sqrt(Σ_k |P(b_k - rest)|²)` over the sample times `k`,
    /// with `P` the modal coordinates: the relative L2 error of `a` against `b` in the lowest
    /// modes. `None` unless `a` covers every time of `b` and the lengths fit the modes.
    pub fn relative_error(&self, a: &[Vec<f64>], b: &[Vec<f64>], rest: &[f64]) -> Option<f64> {
        let n = rest.len();
        if a.len() < b.len() || self.modes.mass_weighted.len() != n * self.count() {
            return None;
        }
        let mut d = vec![0.0; n];
        let mut c = vec![0.0; self.count()];
        let mut squared = |x: &[f64], y: &[f64]| {
            d.iter_mut()
                .zip(x.iter().zip(y))
                .for_each(|(d, (p, q))| *d = p - q);
            self.modes.coordinates(&d, &mut c);
            c.iter().map(|v| v * v).sum::<f64>()
        };
        let (mut error, mut motion) = (0.0, 0.0);
        for (x, r) in a.iter().zip(b) {
            if x.len() != n || r.len() != n {
                return None;
            }
            error += squared(x, r);
            motion += squared(r, rest);
        }
        (!b.is_empty()).then(|| error.sqrt() / motion.sqrt().max(f64::MIN_POSITIVE))
    }

    /// As stored by shards: the frequencies and `M v_i`, as f64 bits.
    pub fn stored(&self) -> StoredModes {
        let all = |v: &[f64]| v.iter().map(|x| bits(*x)).collect();
        StoredModes {
            omega: all(&self.modes.omega),
            mass_weighted: all(&self.modes.mass_weighted),
            iterations: self.modes.iterations,
            converged: self.modes.converged,
        }
    }

    /// From [`Self::stored`].
    pub fn from_stored(s: &StoredModes) -> Self {
        let all = |v: &[u64]| v.iter().map(|b| from_bits(*b)).collect();
        Self {
            modes: Modes {
                omega: all(&s.omega),
                mass_weighted: all(&s.mass_weighted),
                iterations: s.iterations,
                converged: s.converged,
            },
        }
    }
}

/// [`ModalBasis`] as the shards of a study store it: every number as its f64 bits.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct StoredModes {
    omega: Vec<u64>,
    mass_weighted: Vec<u64>,
    iterations: usize,
    converged: bool,
}

/// The modal cells of a run whose positions at the sample times are `positions`: its error
/// when above `floor` (else empty), the reference's own difference, the modes and cut-off.
pub(in crate::study) fn set_modal_cells(
    m: &mut Measured,
    basis: Option<&ModalBasis>,
    error: Option<f64>,
    difference: Option<f64>,
    floor_factor: f64,
) {
    let [err, diff, count, cutoff] = MODAL_COLUMNS;
    let scored = |e: f64| difference.is_none_or(|d| e > floor_factor * d);
    m.set(err, cell(error.filter(|&e| scored(e))));
    m.set(diff, cell(difference));
    m.set(
        count,
        basis.map_or(String::new(), |b| b.count().to_string()),
    );
    m.set(cutoff, cell(basis.map(ModalBasis::cutoff)));
}
