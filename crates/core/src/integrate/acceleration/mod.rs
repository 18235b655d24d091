//! Acceleration of the local solvers' fixed-point iterations (`acceleration` in
//! `[integrator.vbd]` and `[integrator.projective_dynamics]`).
//!
//! VBD's sweep and projective dynamics' local/global iteration are fixed-point maps
//! `x_{k+1} = G(x_k)` on the free DOFs (stacked xyz) that converge to the minimizer of the
//! backward Euler incremental potential `E`. An [`Accelerate`] sees each plain iterate
//! `G(x_k)` and replaces it by a better one, from the history it keeps:
//! - `chebyshev` ([`chebyshev`]): Wang 2015's semi-iteration, `x_{k+1} = ω_{k+1} (G(x_k) −
//!   x_{k−1}) + x_{k−1}` with the ω schedule of a spectral radius ρ, given or estimated;
//! - `anderson` ([`anderson`]): type-II Anderson acceleration with history m, safeguarded by
//!   `E` (an iterate that raises `E` above the plain one's is rejected and the history
//!   restarted).
//!
//! The family is [`Acceleration`] (kind.rs), one table line per entry whose facts hold its
//! builder, so adding one is one file and one line; the trait is in accelerate.rs. Buffers
//! are sized in [`Accelerate::start`] when the number of DOFs or the history changes; an
//! iteration allocates nothing.

mod accelerate;
pub mod anderson;
pub mod chebyshev;
pub mod energy;
mod kind;

pub use accelerate::Accelerate;
pub use energy::IncrementalPotential;
pub use kind::{
    Acceleration, AccelerationFacts, AccelerationSettings, MAX_ANDERSON_HISTORY,
    UnknownAcceleration,
};
