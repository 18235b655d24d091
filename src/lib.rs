//! softbench: a harness for research on time integrators and solvers for deformable bodies.
//!
//! The pieces, in pipeline order:
//! - [`mesh`]: tetrahedral meshes (readers, generators, surface extraction, quality report);
//! - [`material`]: strain energy densities with closed-form stress and stress derivative;
//! - [`fem`]: the linear tetrahedron (shape gradients, element energy, gradient, Hessian, mass);
//! - [`model`]: the [`model::Model`], a conservative system over the free degrees of freedom
//!   whose potential, gradient and sparse Hessian the integrators ask for;
//! - [`sparse`]: the symmetric sparse matrix and its pattern, built once and refilled in place;
//! - [`solve`]: the [`solve::LinearSolver`] trait (analyze once, factor per matrix, solve) and
//!   its backends: sparse Cholesky and LDLᵀ (faer), preconditioned CG, dense Cholesky.
//!
//! Conventions: f64 everywhere; stacked coordinates `q = [x0 y0 z0 x1 y1 z1 ...]`;
//! `vec(F)` is column-major (`F[(0,0)], F[(1,0)], F[(2,0)], F[(0,1)], ...`), which is nalgebra's
//! storage order.

pub mod data;
pub mod fem;
pub mod material;
pub mod mesh;
pub mod model;
pub mod parallel;
pub mod rng;
pub mod solve;
pub mod sparse;
