//! The highest natural frequency of a model, `omega_max`, from which the stability study takes
//! the theoretical explicit step limit `dt = 2 / omega_max`.
//!
//! `omega_max^2` is the largest eigenvalue `lambda` of the symmetric pencil `K v = lambda M v`,
//! with `K` the Hessian of the potential over the free DOFs at a state `q` (elastic tets,
//! springs and vertex potentials, exactly as [`Model::hessian`] assembles them, unprojected)
//! and `M` the model's mass matrix, consistent or lumped.
//!
//! Method: Lanczos on `A = M^{-1} K`, which is self-adjoint in the `M` inner product
//! `<x, y>_M = x^T M y`. Each step costs one `K` mat-vec and one `M^{-1}` solve (`M` factored
//! once by [`MassInverse`]; a division for lumped mass), plus two `M` mat-vecs for the
//! reorthogonalization. The basis is kept and every new vector is `M`-orthogonalized against all
//! of it twice (classical Gram–Schmidt, "twice is enough"), so no spurious copies of converged
//! Ritz values appear; memory is `n` values per step, fine for ~200 steps at `n ~ 10^5`. The
//! Ritz values are the eigenvalues of the small tridiagonal matrix, found with nalgebra's
//! symmetric eigensolver. The largest Ritz value rises monotonically to `lambda_max` from below.
//!
//! `K` may be indefinite or only positive semi-definite (free bodies have zero-frequency rigid
//! modes): only its largest eigenvalue is sought.

use super::{HessianOptions, MassInverse, MassMatrix, Model, ModelError};
use crate::parallel::Parallelism;
use crate::rng::Rng;
use crate::solve::{SolveError, dot, symmetric_mul_vec};
use nalgebra::DMatrix;

/// Seed of the start vector: the result is the same on every run and machine.
const START_SEED: u64 = 0x5EC7_0000;

/// `beta` (the `M`-norm of the next Lanczos vector before normalization) at or below this
/// fraction of `|A|` (estimated by the spectral radius of the tridiagonal matrix) means the
/// Krylov space is exhausted: it is an invariant subspace, so its largest Ritz value is an
/// eigenvalue of `A` (the largest, since a random start vector has a component along every
/// eigenvector). Rounding leaves `beta ~ 1e-15 |A|` there.
const BREAKDOWN: f64 = 1e-10;

/// Settings of [`highest_mode`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpectrumSettings {
    /// At most this many Lanczos steps (each one `K` mat-vec and one `M^{-1}` solve), and the
    /// basis holds at most this many vectors. Default 200.
    pub max_iterations: usize,
    /// Converged when the largest Ritz value changes by at most this fraction of itself in one
    /// step. Default 1e-8. The remaining error is of the order of that last change, a small
    /// multiple of it when convergence is slow (1.5 on a 3888-DOF box whose top eigenvalues
    /// are clustered). With 0 the iteration runs until the Krylov space is exhausted or
    /// `max_iterations` is reached.
    pub tolerance: f64,
}

impl Default for SpectrumSettings {
    fn default() -> Self {
        Self {
            max_iterations: 200,
            tolerance: 1e-8,
        }
    }
}

/// The largest eigenvalue of the pencil (K, M) at `q`, and how it was found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HighestMode {
    /// The largest eigenvalue `lambda_max` of `K v = lambda M v` (1/s^2). A lower bound when
    /// not converged.
    pub omega_squared: f64,
    /// `omega_max = sqrt(lambda_max)` (rad/s); 0 when `lambda_max <= 0` (no oscillating mode).
    pub omega: f64,
    /// Lanczos steps taken (= `K` mat-vecs = `M^{-1}` solves).
    pub iterations: usize,
    /// Whether the tolerance was met or the Krylov space was exhausted (then the value is exact
    /// to rounding), as opposed to running out of iterations.
    pub converged: bool,
    /// `|theta_k - theta_{k-1}| / |theta_k|` for the largest Ritz value `theta` in the last
    /// step; infinite after a single step.
    pub relative_change: f64,
}

impl HighestMode {
    /// The theoretical explicit step limit `2 / omega_max` (s): the stability bound of the
    /// central-difference family (symplectic Euler, leapfrog) for the linearized undamped
    /// system. Infinite when `omega_max = 0`.
    pub fn explicit_limit(&self) -> f64 {
        2.0 / self.omega
    }
}

/// Why [`highest_mode`] could not run.
#[derive(Debug, thiserror::Error)]
pub enum SpectrumError {
    /// Every vertex is fixed: there is no mode.
    #[error("the model has no free DOFs, so it has no vibration modes")]
    NoFreeDofs,
    /// A setting is out of range.
    #[error("spectrum settings: {field} = {value} is invalid: {expected}")]
    InvalidSetting {
        field: &'static str,
        value: String,
        expected: &'static str,
    },
    /// The Hessian could not be evaluated at `q` (wrong length, inverted element).
    #[error("Hessian: {0}")]
    Model(#[from] ModelError),
    /// The Hessian at `q` has a NaN or infinite entry in this column.
    #[error("the Hessian has a non-finite entry in column {column}")]
    NonFiniteHessian { column: usize },
    /// The consistent mass matrix could not be factored or solved with.
    #[error("mass matrix: {0}")]
    Mass(#[from] SolveError),
    /// The iteration produced a non-finite value (overflow).
    #[error("Lanczos produced a non-finite value at step {iteration}")]
    NonFinite { iteration: usize },
}

impl crate::error_class::Classify for SpectrumError {
    fn class(&self) -> crate::error_class::ErrorClass {
        match self {
            Self::NoFreeDofs | Self::InvalidSetting { .. } => {
                crate::error_class::ErrorClass::BadInput
            }
            Self::Model(e) => crate::error_class::Classify::class(e),
            _ => crate::error_class::ErrorClass::Failure,
        }
    }
}

/// The largest eigenvalue of `K(q) v = lambda M v` by Lanczos in the `M` inner product (see the
/// module docs). `q` is a state over the free DOFs, usually [`Model::rest_state`].
///
/// Evaluates one Hessian (counted in the model's counters) and factors `M` once. Stops when the
/// largest Ritz value changes by at most `settings.tolerance` relative, when the Krylov space
/// is exhausted (at the latest after `n` steps for `n` DOFs, so small models give the exact
/// value), or after `settings.max_iterations` steps (then `converged` is false).
pub fn highest_mode(
    model: &mut Model,
    q: &[f64],
    settings: &SpectrumSettings,
) -> Result<HighestMode, SpectrumError> {
    check_settings(settings)?;
    let n = model.num_dofs();
    if n == 0 {
        return Err(SpectrumError::NoFreeDofs);
    }
    let mut k = model.new_hessian();
    model.hessian(q, &mut k, HessianOptions::default())?;
    if let Some(entry) = k.values().iter().position(|v| !v.is_finite()) {
        let column = k.pattern().col_ptr().partition_point(|&p| p <= entry) - 1;
        return Err(SpectrumError::NonFiniteHessian { column });
    }
    let mass = model.mass();
    let mut mass_inverse = MassInverse::new(mass)?;
    let par = model.parallelism();
    let max_steps = settings.max_iterations.min(n);

    // Basis vectors v_0, v_1, ... stored one after the other; grows by n per step.
    let mut basis: Vec<f64> = Vec::with_capacity(n * max_steps.min(16));
    let mut coefficients = Vec::with_capacity(max_steps);
    let (mut alphas, mut betas) = (Vec::with_capacity(max_steps), Vec::new());
    let mut v = start_vector(n);
    let mut z = vec![0.0; n];
    let mut mz = vec![0.0; n];
    mass_mul(mass, &v, &mut mz, par);
    let norm = dot(&v, &mz).sqrt();
    v.iter_mut().for_each(|x| *x /= norm);

    let mut previous = f64::NAN;
    for step in 1..=max_steps {
        basis.extend_from_slice(&v);
        // z = K v, alpha = v^T K v, then z = M^{-1} K v.
        symmetric_mul_vec(&k, &v, &mut z, par);
        let alpha = dot(&v, &z);
        mass_inverse.apply(&mut z)?;
        // z -= sum_i <z, v_i>_M v_i (this removes alpha v + beta v_prev and any drift).
        for _ in 0..2 {
            m_orthogonalize(mass, &basis, &mut z, &mut mz, &mut coefficients, par);
        }
        mass_mul(mass, &z, &mut mz, par);
        let beta = dot(&z, &mz).max(0.0).sqrt();
        if !(alpha.is_finite() && beta.is_finite()) {
            return Err(SpectrumError::NonFinite { iteration: step });
        }
        alphas.push(alpha);

        let (theta, radius) = largest_ritz_value(&alphas, &betas);
        let exhausted = step == n || beta <= BREAKDOWN * radius;
        let change = (theta - previous).abs();
        let relative_change = match step {
            1 => f64::INFINITY,
            _ if change == 0.0 => 0.0,
            _ => change / theta.abs(),
        };
        let converged = exhausted || relative_change <= settings.tolerance;
        if converged || step == max_steps {
            return Ok(HighestMode {
                omega_squared: theta,
                omega: theta.max(0.0).sqrt(),
                iterations: step,
                converged,
                relative_change,
            });
        }
        previous = theta;
        betas.push(beta);
        v.iter_mut().zip(&z).for_each(|(vi, zi)| *vi = zi / beta);
    }
    unreachable!("the loop returns at step max_steps >= 1")
}

fn check_settings(s: &SpectrumSettings) -> Result<(), SpectrumError> {
    if s.max_iterations == 0 {
        return Err(SpectrumError::InvalidSetting {
            field: "max_iterations",
            value: "0".into(),
            expected: "at least 1",
        });
    }
    if !(s.tolerance.is_finite() && s.tolerance >= 0.0) {
        return Err(SpectrumError::InvalidSetting {
            field: "tolerance",
            value: s.tolerance.to_string(),
            expected: "a finite, non-negative relative change",
        });
    }
    Ok(())
}

/// A fixed pseudo-random vector, uniform in [-1, 1) per entry: with probability one it has a
/// component along every eigenvector, and it is the same on every run.
fn start_vector(n: usize) -> Vec<f64> {
    let mut rng = Rng::new(START_SEED);
    (0..n).map(|_| rng.range(-1.0, 1.0)).collect()
}

/// `y = M x`, in parallel for the consistent matrix when asked.
fn mass_mul(mass: &MassMatrix, x: &[f64], y: &mut [f64], par: Parallelism) {
    match mass {
        MassMatrix::Consistent(m) => symmetric_mul_vec(m, x, y, par),
        lumped => lumped.mul_vec(x, y),
    }
}

/// One classical Gram–Schmidt pass in the `M` inner product: `z -= V c` with `c = V^T M z`,
/// for the basis `V` stored column after column in `basis`. `mz` and `coefficients` are
/// scratch. Every entry is summed in a fixed order, so the result does not depend on `par`.
fn m_orthogonalize(
    mass: &MassMatrix,
    basis: &[f64],
    z: &mut [f64],
    mz: &mut [f64],
    coefficients: &mut Vec<f64>,
    par: Parallelism,
) {
    use rayon::prelude::*;
    /// Rows per task when updating `z`; also the size below which nothing runs in parallel.
    const ROWS: usize = 4096;
    let n = z.len();
    mass_mul(mass, z, mz, par);
    let columns = basis.chunks_exact(n);
    coefficients.resize(columns.len(), 0.0);
    let parallel = par == Parallelism::Rayon && n > ROWS;
    if parallel {
        coefficients
            .par_iter_mut()
            .zip(basis.par_chunks_exact(n))
            .for_each(|(c, v)| *c = dot(v, mz));
    } else {
        coefficients
            .iter_mut()
            .zip(columns)
            .for_each(|(c, v)| *c = dot(v, mz));
    }
    let update = |start: usize, rows: &mut [f64]| {
        for (c, v) in coefficients.iter().zip(basis.chunks_exact(n)) {
            let v = &v[start..start + rows.len()];
            rows.iter_mut().zip(v).for_each(|(zi, vi)| *zi -= c * vi);
        }
    };
    if parallel {
        z.par_chunks_mut(ROWS)
            .enumerate()
            .for_each(|(chunk, rows)| update(chunk * ROWS, rows));
    } else {
        update(0, z);
    }
}

/// The largest eigenvalue of the symmetric tridiagonal matrix with diagonal `alphas` and
/// off-diagonal `betas` (one shorter), and its spectral radius (an estimate of `|A|`).
fn largest_ritz_value(alphas: &[f64], betas: &[f64]) -> (f64, f64) {
    let m = alphas.len();
    let t = DMatrix::from_fn(m, m, |i, j| {
        if i == j {
            alphas[i]
        } else if i.abs_diff(j) == 1 {
            betas[i.min(j)]
        } else {
            0.0
        }
    });
    let eigenvalues = t.symmetric_eigenvalues();
    let largest = eigenvalues.max();
    (largest, largest.abs().max(eigenvalues.min().abs()))
}
