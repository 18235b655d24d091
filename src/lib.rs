//! softbench: a harness for research on time integrators and solvers for deformable bodies.
//!
//! The three seams a reader looks for first:
//! - [`model::Model`]: a conservative system over the free DOFs (potential, gradient, sparse
//!   Hessian into a pattern built once, mass matrix, evaluation counters);
//! - [`integrate::Integrator`]: one time step of any method, with a [`integrate::StepReport`];
//! - [`solve::LinearSolver`]: analyze a pattern once, factor per matrix, solve.
//!
//! The map of the modules (what each one holds and why the code is shaped as it is) is
//! `DESIGN.md` at the root of the repository; how to use softbench (scene and study files, the
//! command line, outputs) is `README.md` and the book under `docs/`.
//!
//! Conventions: SI units; f64 everywhere; stacked coordinates `q = [x0 y0 z0 x1 y1 z1 ...]`;
//! `vec(F)` is column-major (`F[(0,0)], F[(1,0)], F[(2,0)], F[(0,1)], ...`), which is nalgebra's
//! storage order.

pub mod cli;
pub mod colouring;
pub mod console;
pub mod contact;
pub mod data;
pub mod export;
pub mod fem;
pub mod integrate;
pub mod interrupt;
pub mod io;
pub mod ledger;
pub mod limits;
pub mod lock;
pub mod material;
pub mod mesh;
pub mod model;
pub mod names;
pub mod parallel;
pub mod pipeline;
pub mod plot;
pub mod quote;
pub mod registry;
pub mod render;
pub mod rng;
pub mod run;
pub mod scene;
pub mod slurm;
pub mod solve;
pub mod sparse;
pub mod springs;
pub mod study;
