//! Your own softbench: a program that registers a method of its own and then runs the whole
//! `softbench` command line with it — `run` (with `--shard`, `--only`, `--quick`), `merge`,
//! `slurm`, `plot`, `render`, `simulate`, `list` — so studies name the new method like a
//! built-in one.
//!
//! The method is given by its Butcher tableau: Heun's third-order Runge–Kutta method, run by
//! softbench's own explicit Runge–Kutta integrator (`runge_kutta::ExplicitRungeKutta`).
//!
//! `cargo run --release --example own_softbench -- list`
//! `cargo run --release --example own_softbench -- simulate experiments/scenes/cantilever.toml --set integrator.method=heun3`

use softbench::integrate::methods::explicit;
use softbench::integrate::register_method;
use softbench::integrate::runge_kutta::{ExplicitRungeKutta, Tableau};

/// Heun's third-order method: `c = (0, 1/3, 2/3)`, `b = (1/4, 0, 3/4)`.
const HEUN3: Tableau = Tableau {
    name: "heun3",
    order: 3,
    a: &[&[], &[1.0 / 3.0], &[0.0, 2.0 / 3.0]],
    b: &[0.25, 0.0, 0.75],
    b_embedded: None,
};

fn main() -> std::process::ExitCode {
    let heun3 = explicit(
        "heun3",
        3,
        "Heun's third-order Runge-Kutta method",
        |_, _| Box::new(ExplicitRungeKutta::new(HEUN3)),
    );
    register_method(heun3).expect("heun3 is not a built-in name");
    softbench::cli::main()
}
