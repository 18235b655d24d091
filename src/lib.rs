//! softbench: a harness for research on time integrators and solvers for deformable bodies.
//!
//! This is the crate users name. It holds the command line ([`cli`]) and re-exports the
//! modules of the three crates below it, so every path is `softbench::<module>`:
//! - `softbench-core`: [`mesh`], [`material`], [`fem`], [`model`], [`solve`], [`integrate`],
//!   [`contact`], [`springs`] and their utilities;
//! - `softbench-run`: one run — [`scene`], [`run`], [`pipeline`], [`export`], [`render`],
//!   [`plot`], [`data`], [`io`];
//! - `softbench-study`: [`study`], [`ledger`], [`slurm`].
//!
//! The three seams a reader looks for first:
//! - [`model::Model`]: a conservative system over the free DOFs (potential, gradient, sparse
//!   Hessian into a pattern built once, mass matrix, evaluation counters);
//! - [`integrate::Integrator`]: one time step of any method, with a [`integrate::StepReport`];
//! - [`solve::LinearSolver`]: analyze a pattern once, factor per matrix, solve.
//!
//! How the crates and modules fit together is `DESIGN.md` at the root of the repository; how
//! to use softbench (scene and study files, the command line, outputs) is `README.md` and the
//! book under `docs/`.
//!
//! Conventions: SI units; f64 everywhere; stacked coordinates `q = [x0 y0 z0 x1 y1 z1 ...]`;
//! `vec(F)` is column-major (`F[(0,0)], F[(1,0)], F[(2,0)], F[(0,1)], ...`), which is nalgebra's
//! storage order.

pub mod cli;
pub mod error;

pub use softbench_core::{
    colouring, contact, error_class, fem, integrate, interrupt, limits, material, mesh, model,
    named_enum, names, parallel, quote, registry, registry_handle, rng, solve, sparse, springs,
    threads,
};
pub use softbench_run::{console, data, export, io, lock, pipeline, plot, render, run, scene};
pub use softbench_study::{ledger, slurm, study};
