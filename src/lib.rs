//! softbench: a harness for research on time integrators and solvers for deformable bodies.
//!
//! The three seams a reader looks for first:
//! - [`model::Model`]: a conservative system over the free DOFs (potential, gradient, sparse
//!   Hessian into a pattern built once, mass matrix, evaluation counters);
//! - [`integrate::Integrator`]: one time step of any method, with a [`integrate::StepReport`];
//! - [`solve::LinearSolver`]: analyze a pattern once, factor per matrix, solve.
//!
//! The pieces, in pipeline order:
//! - [`scene`]: scene files (TOML, `--set` overrides) built into a model and initial state;
//! - [`mesh`]: tetrahedral meshes (readers, generators, surface extraction, quality report);
//! - [`data`]: where data files are found (the scene's folder, then `SOFTBENCH_DATA`);
//! - [`material`]: strain energy densities with closed-form stress and stress derivative;
//! - [`fem`]: the linear tetrahedron (shape gradients, element energy, gradient, Hessian, mass);
//! - [`model`]: elastic, spring and gravity potentials assembled over free DOFs, and the
//!   highest natural frequency of the linearized model (the explicit step limit);
//! - [`springs`]: mass-spring bodies (jello cube, jello sphere, springs along tet edges);
//! - [`sparse`]: the symmetric sparse matrix and its pattern, built once and refilled in place;
//! - [`solve`]: sparse Cholesky and LDLᵀ (faer), preconditioned CG, dense Cholesky;
//! - [`integrate`]: explicit, adaptive and implicit integrators, and Newton's method;
//! - [`contact`]: obstacles (signed distances) and four contact responses;
//! - [`run`]: running a scene and measuring it (energies, momenta, blow-up detection);
//! - [`io`]: writing results atomically;
//! - [`plot`]: charts of the experiment runner (PNG and SVG);
//! - [`export`]: frames for viewers (VTU + PVD, OBJ; skinned display meshes);
//! - [`pipeline`]: one run of a scene as `simulate`, studies and programs run it (the model
//!   and integrator built once, one observer wiring, one picture surface, `summary.json`).
//!
//! Conventions: SI units; f64 everywhere; stacked coordinates `q = [x0 y0 z0 x1 y1 z1 ...]`;
//! `vec(F)` is column-major (`F[(0,0)], F[(1,0)], F[(2,0)], F[(0,1)], ...`), which is nalgebra's
//! storage order.

pub mod console;
pub mod contact;
pub mod data;
pub mod export;
pub mod fem;
pub mod integrate;
pub mod interrupt;
pub mod io;
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
