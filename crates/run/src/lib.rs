//! One softbench run: a scene file becomes a model and an integrator ([`scene`]), the run loop
//! steps it and decides how it ended ([`run`]), and [`pipeline`] wires the observers that write
//! what a run writes (rows, frames, pictures, `summary.json`). Files go through [`io`]'s
//! atomic writes; charts ([`plot`]) and pictures ([`render`]) are drawn in pure Rust.
//! Built on `softbench-core`; studies (`softbench-study`) build on it.

pub mod console;
pub mod data;
pub mod export;
pub mod io;
pub mod lock;
pub mod pipeline;
pub mod plot;
pub mod render;
pub mod run;
pub mod scene;
