//! Chebyshev semi-iteration (Wang 2015, "A Chebyshev semi-iterative approach for accelerating
//! projective and position-based dynamics").
//!
//! With `x̃ = G(x_k)` the plain iterate: `x_{k+1} = ω_{k+1} (x̃ − x_{k−1}) + x_{k−1}`, where
//! `ω = 1` for the first `S` iterations, `ω_S = 2/(2 − ρ²)` and `ω_{k+1} = 4/(4 − ρ² ω_k)`
//! after. ρ is the spectral radius of the plain iteration near the solution. Given
//! (`chebyshev_rho` > 0), the schedule starts at `S = 2`. Estimated (`chebyshev_rho = 0`), the
//! first [`ESTIMATION_ITERATIONS`] iterations are plain and ρ is the geometric mean of the
//! ratios of their successive update norms `‖G(x_k) − x_k‖` after the first, capped at
//! [`MAX_ESTIMATE`]; a ratio at or above 1 (the plain iteration is not contracting yet) leaves
//! the step unaccelerated (ρ = 0). The ρ used is reported per step.

use super::accelerate::Accelerate;
use crate::integrate::{StepError, StepReport};

/// Plain iterations whose update norms estimate ρ.
pub const ESTIMATION_ITERATIONS: u32 = 5;
/// Largest estimated ρ (the ω schedule grows without bound as ρ → 1).
pub const MAX_ESTIMATE: f64 = 0.995;
/// Iterations before the schedule starts when ρ is given.
const GIVEN_DELAY: u32 = 2;

/// The Chebyshev accelerator's state.
#[derive(Debug, Default)]
pub struct Chebyshev {
    /// The given ρ (0: estimate).
    given: f64,
    /// ρ of this step (0 while unknown or when the step stays plain).
    rho: f64,
    omega: f64,
    /// Iterations done in this step.
    k: u32,
    /// `x_k`, `x_{k−1}`.
    current: Vec<f64>,
    previous: Vec<f64>,
    /// Update norms of the estimation iterations.
    norms: [f64; ESTIMATION_ITERATIONS as usize],
}

impl Chebyshev {
    /// A Chebyshev accelerator for `chebyshev_rho` (0: estimate ρ each step).
    pub fn new(chebyshev_rho: f64) -> Self {
        Self {
            given: chebyshev_rho,
            ..Self::default()
        }
    }

    /// The ρ of the current step (0 before it is known).
    pub fn rho(&self) -> f64 {
        self.rho
    }

    fn delay(&self) -> u32 {
        if self.given > 0.0 {
            GIVEN_DELAY
        } else {
            ESTIMATION_ITERATIONS
        }
    }

    /// ρ from the update norms of the estimation iterations.
    fn estimate(norms: &[f64]) -> f64 {
        let (first, last) = (norms[1], norms[norms.len() - 1]);
        if !(first > 0.0 && last.is_finite()) {
            return 0.0;
        }
        let ratio = (last / first).powf(1.0 / (norms.len() - 2) as f64);
        if ratio >= 1.0 || !ratio.is_finite() {
            0.0
        } else {
            ratio.min(MAX_ESTIMATE)
        }
    }
}

impl Accelerate for Chebyshev {
    fn start(&mut self, x0: &[f64]) {
        self.current.clear();
        self.current.extend_from_slice(x0);
        self.previous.clear();
        self.previous.extend_from_slice(x0);
        self.k = 0;
        self.omega = 1.0;
        self.rho = self.given;
    }

    fn update(
        &mut self,
        x: &mut [f64],
        _energy: &mut dyn FnMut(&[f64]) -> Result<f64, StepError>,
    ) -> Result<(), StepError> {
        let k = self.k;
        self.k += 1;
        let delay = self.delay();
        if self.given == 0.0 && k < ESTIMATION_ITERATIONS {
            let d2: f64 = x
                .iter()
                .zip(&self.current)
                .map(|(a, b)| (a - b) * (a - b))
                .sum();
            self.norms[k as usize] = d2.sqrt();
            if k + 1 == ESTIMATION_ITERATIONS {
                self.rho = Self::estimate(&self.norms);
            }
        }
        if k >= delay && self.rho > 0.0 {
            let r2 = self.rho * self.rho;
            self.omega = if k == delay {
                2.0 / (2.0 - r2)
            } else {
                4.0 / (4.0 - r2 * self.omega)
            };
            let w = self.omega;
            for (xi, p) in x.iter_mut().zip(&self.previous) {
                *xi = w * (*xi - p) + p;
            }
        }
        std::mem::swap(&mut self.previous, &mut self.current);
        self.current.copy_from_slice(x);
        Ok(())
    }

    fn report(&self, report: &mut StepReport) {
        report.chebyshev_rho = self.rho;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_estimate_is_the_mean_contraction_and_off_when_not_contracting() {
        let norms = [5.0, 1.0, 0.5, 0.25, 0.125];
        assert!((Chebyshev::estimate(&norms) - 0.5).abs() < 1e-12);
        assert_eq!(Chebyshev::estimate(&[1.0, 1.0, 1.0, 1.2, 1.3]), 0.0);
        assert_eq!(Chebyshev::estimate(&[1.0, 0.0, 0.0, 0.0, 0.0]), 0.0);
        assert_eq!(
            Chebyshev::estimate(&[1.0, 1.0, 1.0, 1.0, 0.9999999]),
            MAX_ESTIMATE
        );
    }
}
