//! Your own softbench: a program that registers a method of its own and then runs the whole
//! `softbench` command line with it — `run` (with `--shard`, `--only`, `--quick`), `merge`,
//! `slurm`, `plot`, `render`, `simulate`, `list` — so studies name the new method like a
//! built-in one.
//!
//! The method is given by its Butcher tableau: Heun's third-order Runge–Kutta method, run by
//! softbench's own explicit Runge–Kutta integrator (`runge_kutta::ExplicitRungeKutta`).
//!
//! `cargo run --release --example own_softbench -- list`
//! (`cargo test --all-targets` runs its test: a simulation of the soft beam with heun3)
//! `cargo run --release --example own_softbench -- simulate experiments/scenes/cantilever.toml --set integrator.method=heun3`

use softbench::integrate::methods::{MethodEntry, explicit};
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
    register_method(heun3()).expect("heun3 is not a built-in name");
    softbench::cli::main()
}

/// The method's registry entry: an explicit method of order 3 run by the tableau.
fn heun3() -> MethodEntry {
    explicit(
        "heun3",
        3,
        "Heun's third-order Runge-Kutta method",
        |_, _| Box::new(ExplicitRungeKutta::new(HEUN3)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::process::ExitCode;

    /// `cargo test --all-targets` runs this: the command line of this program simulates the
    /// soft beam with heun3 to the end.
    #[test]
    fn the_command_line_runs_the_registered_method() {
        register_method(heun3()).unwrap();
        let out = std::env::temp_dir().join(format!("own-softbench-{}", std::process::id()));
        let scene = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/experiments/scenes/soft_beam.toml"
        );
        let code = softbench::cli::run([
            "softbench",
            "simulate",
            scene,
            "--out",
            out.to_str().unwrap(),
            "--set",
            "integrator.method=heun3",
            "--set",
            "run.steps=50",
        ]);
        assert_eq!(code, ExitCode::SUCCESS);
        let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
        assert!(summary.contains("\"method\": \"heun3\""), "{summary}");
        let _ = std::fs::remove_dir_all(out);
    }
}
