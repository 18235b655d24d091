//! AMG on a refinement ladder at several strength thresholds θ: CG iterations to 1e-8,
//! operator and grid complexity, levels, setup (full build) and solve times, one thread.
//! The evidence behind `AmgSettings::DEFAULT_THETA` (see DESIGN.md).
//!
//! The body is the 48 cm box of tests/preconditioners.rs at cells of 4, 2, 1.33 and 1 cm
//! (2.6k to 166k tets; dt² k/m grows as the cells shrink, as in a finely meshed body).
//!
//! `cargo run --release --example amg_ladder -- [theta ...]` (default 0 0.02 0.05 0.08 0.15)

#[path = "../tests/support/fem_system.rs"]
mod fem_system;

use std::time::Instant;

use fem_system::fem_box_sized;
use softbench::solve::{AmgSettings, CgSettings, CgSolver, LinearSolver, Preconditioner};

fn main() {
    let thetas: Vec<f64> = {
        let args: Vec<f64> = std::env::args()
            .skip(1)
            .map(|a| a.parse().expect("θ must be a number"))
            .collect();
        if args.is_empty() {
            vec![0.0, 0.02, 0.05, 0.08, 0.15]
        } else {
            args
        }
    };
    let ladder = [
        ([12, 6, 6], 0.04),
        ([24, 12, 12], 0.02),
        ([36, 18, 18], 0.04 / 3.0),
        ([48, 24, 24], 0.01),
    ];
    println!(
        "tets,theta,iterations,operator_complexity,grid_complexity,levels,coarse_dofs,build_s,solve_s"
    );
    for (cells, h) in ladder {
        let system = fem_box_sized(cells, h);
        let a = &system.matrix;
        let tets = 6 * cells.iter().product::<usize>();
        for &theta in &thetas {
            let mut s = CgSolver::new(CgSettings {
                preconditioner: Preconditioner::Amg,
                amg: AmgSettings {
                    strength_threshold: theta,
                    rebuild_every: 1,
                    ..AmgSettings::default()
                },
                max_iterations: 5000,
                ..CgSettings::default()
            });
            s.analyze(a.pattern()).unwrap();
            s.set_coordinates(&system.positions);
            let t = Instant::now();
            s.factor(a).unwrap();
            let build = t.elapsed().as_secs_f64();
            let mut x: Vec<f64> = (0..a.dim())
                .map(|i| {
                    let p = &system.positions[3 * (i / 3)..3 * (i / 3) + 3];
                    match i % 3 {
                        0 => -p[2],
                        1 => -1.0 + 0.1 * p[0],
                        _ => p[0],
                    }
                })
                .collect();
            let t = Instant::now();
            let r = s.solve(&mut x).unwrap();
            let solve = t.elapsed().as_secs_f64();
            let amg = s.stats().amg;
            println!(
                "{tets},{theta},{},{:.3},{:.3},{},{},{build:.4},{solve:.4}",
                r.iterations,
                amg.operator_complexity,
                amg.grid_complexity,
                amg.levels,
                amg.coarse_dofs
            );
        }
    }
}
