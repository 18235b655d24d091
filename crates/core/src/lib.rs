//! softbench's numerical core: meshes, materials, the linear tetrahedron, the model, linear
//! solvers, integrators, contact and mass-spring bodies. It knows nothing of scene files, runs
//! or studies (`softbench-run` and `softbench-study` build on it); users normally name it
//! through the `softbench` crate, which re-exports every module.
//!
//! The three seams a reader looks for first:
//! - [`model::Model`]: a conservative system over the free DOFs (potential, gradient, sparse
//!   Hessian into a pattern built once, mass matrix, evaluation counters);
//! - [`integrate::Integrator`]: one time step of any method, with a [`integrate::StepReport`];
//! - [`solve::LinearSolver`]: analyze a pattern once, factor per matrix, solve.
//!
//! `DESIGN.md` at the root of the repository says how the crates and their modules fit
//! together.
//!
//! Conventions: SI units; f64 everywhere; stacked coordinates `q = [x0 y0 z0 x1 y1 z1 ...]`;
//! `vec(F)` is column-major (`F[(0,0)], F[(1,0)], F[(2,0)], F[(0,1)], ...`), which is nalgebra's
//! storage order.

pub mod colouring;
pub mod contact;
pub mod error_class;
pub mod fem;
pub mod integrate;
pub mod interrupt;
pub mod limits;
pub mod material;
pub mod mesh;
pub mod model;
pub mod names;
pub mod parallel;
pub mod quote;
pub mod registry;
pub mod rng;
pub mod solve;
pub mod sparse;
pub mod springs;
pub mod threads;
