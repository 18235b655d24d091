//! Where a second thread starts to pay, for each loop whose threads are decided by a rule:
//! XPBD's colour sweep (tets per chunk, [`XpbdSettings::parallel_min_tets`]), the element
//! loops of assembly (chunks of 256 tets, [`MIN_PARALLEL_CHUNKS`]), CG's mat-vec (columns) and
//! the sparse Cholesky factorization (predicted flops, [`PARALLEL_MIN_FLOPS`]). Each row times
//! one thread against two with the rule switched off (so both sides of the rule are
//! measured), called as `softbench` calls them (from a thread outside rayon's global pool of
//! two threads), as the median of interleaved rounds, and each table ends with the
//! crossover: the smallest size from which two threads were at least 3% faster at every
//! larger size.
//! The defaults in the library are set from this output on a quiet two-core machine.
//!
//! `cargo bench --bench thread_crossover` (add `-- --quick` for fewer rounds; `-- xpbd`,
//! `elements`, `matvec`, `amg`, `factor`, `dense`, `bandwidth`, `solve` or `step` for one
//! table). The `step` table is the whole converged backward-Euler step, one thread against
//! two (issue 31's 49k box); the `dense` and `bandwidth` tables are the machine's ceilings
//! for compute and memory traffic. The factorization, dense, solve and step tables also
//! print each side's CPU time per wall time and the CPU time of two threads against one
//! (see [`process_cpu_seconds`]).

#[path = "support/clamped_box.rs"]
mod clamped_box;
#[path = "../tests/support/fem_system.rs"]
mod fem_system;

use clamped_box::clamped_box;

use fem_system::{fem_ball, fem_box};
use nalgebra::Vector3;
use softbench::fem::TetRest;
use softbench::integrate::xpbd::{PARALLEL_MIN_TETS, Xpbd, XpbdSettings};
use softbench::integrate::{Integrator, IntegratorSettings, State};
use softbench::material::{LameParameters, Material, StableNeoHookean};
use softbench::mesh::generate::box_mesh;
use softbench::parallel::{Parallelism, for_each_chunk_from};
use softbench::solve::symmetric_mul_vec;
use softbench::solve::{
    AMG_PARALLEL_MIN_ROWS, AmgSettings, AmgSmoother, CgSettings, CgSolver, CholeskySolver,
    DirectSettings, LinearSolver, LinearSolverKind, Ordering, PARALLEL_MIN_FLOPS, Preconditioner,
};
use std::hint::black_box;
use std::time::Instant;

/// Whether this is the smoke run of `cargo test` (see `main`).
static SMOKE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// The sizes a table measures: all of them, or the two smallest in the smoke run.
fn sizes<T: Clone>(all: &[T]) -> Vec<T> {
    let n = if SMOKE.load(std::sync::atomic::Ordering::Relaxed) {
        2.min(all.len())
    } else {
        all.len()
    };
    all[..n].to_vec()
}

/// Median seconds of `rounds` interleaved runs of `one` and `two` (each run `reps` calls).
fn interleaved(rounds: usize, reps: usize, one: impl FnMut(), two: impl FnMut()) -> (f64, f64) {
    interleaved_cpu(rounds, reps, one, two).0
}

/// What [`interleaved_cpu`] measures besides the times: the medians over the rounds of each
/// side's CPU time per wall time and of the two-thread side's CPU time against the one-thread
/// side's (see [`process_cpu_seconds`]).
struct CpuUse {
    per_wall: (f64, f64),
    work: f64,
}

impl CpuUse {
    /// `CPU/wall a → b, work ×w`: with a about 1, the speed-up is about b / w.
    fn describe(&self) -> String {
        format!(
            "CPU/wall {:.2} → {:.2}, work ×{:.2}",
            self.per_wall.0, self.per_wall.1, self.work
        )
    }
}

/// [`interleaved`], and each round's CPU time on both sides.
fn interleaved_cpu(
    rounds: usize,
    reps: usize,
    mut one: impl FnMut(),
    mut two: impl FnMut(),
) -> ((f64, f64), CpuUse) {
    // Seconds of wall and CPU time of `reps` calls.
    let time = |f: &mut dyn FnMut()| {
        let (t, cpu) = (Instant::now(), process_cpu_seconds());
        for _ in 0..reps {
            f();
        }
        let cpu = process_cpu_seconds() - cpu;
        (t.elapsed().as_secs_f64(), cpu)
    };
    one();
    two();
    let (mut a, mut b) = (Vec::new(), Vec::new());
    let (mut wall_a, mut wall_b, mut work) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..rounds {
        let (ta, ca) = time(&mut one);
        let (tb, cb) = time(&mut two);
        a.push(ta / reps as f64);
        b.push(tb / reps as f64);
        wall_a.push(ca / ta);
        wall_b.push(cb / tb);
        work.push(cb / ca);
    }
    let cpu = CpuUse {
        per_wall: (median(wall_a), median(wall_b)),
        work: median(work),
    };
    ((median(a), median(b)), cpu)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// CPU seconds used so far by every thread of this process (`CLOCK_PROCESS_CPUTIME_ID`).
/// Against wall time it separates the two reasons a second thread gains less than 2x: idle
/// time (a thread waiting: CPU / wall below 2) and work that takes longer when both cores are
/// busy (shared caches, memory bandwidth: more CPU time than on one thread). Idle workers
/// spin briefly before they sleep (rayon's, and faer's inside its parallel kernels), and that
/// spinning counts as busy: CPU time above one thread's is an upper bound on how much the work
/// slowed (a profile of the 49k box's step put 4.5 % of the workers' samples in those loops).
fn process_cpu_seconds() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one plain struct we own.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime(CLOCK_PROCESS_CPUTIME_ID)");
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// Print a row and remember whether two threads won.
struct Table {
    name: &'static str,
    unit: &'static str,
    rows: Vec<(f64, bool)>,
}

impl Table {
    fn new(name: &'static str, unit: &'static str, columns: &str) -> Self {
        println!(
            "\n## {name}\n\n| {columns} | 1 thread | 2 threads | speed-up |\n|---|---|---|---|"
        );
        Self {
            name,
            unit,
            rows: Vec::new(),
        }
    }

    fn row(&mut self, label: &str, size: f64, (one, two): (f64, f64)) {
        println!(
            "| {label} | {:.3} ms | {:.3} ms | {:.2}x |",
            one * 1e3,
            two * 1e3,
            one / two
        );
        // A win is at least 3% faster: closer than that is the noise of this machine.
        self.rows.push((size, two < 0.97 * one));
    }

    /// The smallest size from which two threads won at every larger size.
    fn crossover(&self) {
        let mut sorted = self.rows.clone();
        sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
        let from = (0..sorted.len())
            .find(|&i| sorted[i..].iter().all(|r| r.1))
            .map(|i| sorted[i].0);
        match from {
            Some(size) => println!(
                "\n{}: two threads faster from {size:.3e} {}",
                self.name, self.unit
            ),
            None => println!(
                "\n{}: two threads never faster at the largest size",
                self.name
            ),
        }
    }
}

const BOXES: [[usize; 3]; 6] = [
    [4, 2, 2],
    [8, 4, 4],
    [12, 6, 6],
    [16, 8, 8],
    [20, 10, 10],
    [32, 16, 16],
];

fn xpbd(rounds: usize) {
    for chunk in [32, 64, 128] {
        let mut table = Table::new(
            if chunk == PARALLEL_MIN_TETS {
                "xpbd, default chunk"
            } else {
                "xpbd"
            },
            "tets",
            &format!("box, 50 substeps, {chunk} tets per chunk"),
        );
        for cells in sizes(&BOXES) {
            let mut model = clamped_box("xpbd-neo-hookean", cells);
            let tets = model.elastic_elements().unwrap().tets.len();
            let start = State::at_rest(&model);
            let settings = XpbdSettings {
                substeps: 50,
                parallel_min_tets: chunk,
                ..Default::default()
            };
            let mut one = Xpbd::new(settings);
            let mut two = Xpbd::new(settings);
            let reps = (4000 / tets).max(1);
            let mut m1 = clamped_box("xpbd-neo-hookean", cells);
            m1.set_parallelism(Parallelism::Sequential);
            let times = interleaved(
                rounds,
                reps,
                || {
                    one.step(&mut m1, &mut start.clone(), 0.01).unwrap();
                },
                || {
                    two.step(&mut model, &mut start.clone(), 0.01).unwrap();
                },
            );
            table.row(&format!("{tets} tets"), tets as f64, times);
        }
        table.crossover();
    }
}

/// The element loops' work in chunks of 256 tets: the energy loop's (F and ψ), the gradient
/// loop's (F, P and the 12 gradient entries) and the Hessian loop's (F and dP/dF); each loop
/// has its own rule in `model::elastic` (`*_MIN_CHUNKS`).
fn elements(rounds: usize) {
    let m = StableNeoHookean::new(LameParameters::from_youngs_poisson(1e6, 0.45).unwrap());
    for (kind, width) in [("energies", 1), ("gradients", 12), ("Hessians", 81)] {
        let mut table = Table::new(
            kind,
            "tets",
            &format!("element {kind}, tets in chunks of 256"),
        );
        for tets in sizes(&[256usize, 512, 1024, 2048, 4096, 8192, 16384, 32768]) {
            let mesh = box_mesh([tets.div_ceil(6), 1, 1], [1.0, 0.1, 0.1]);
            let rest: Vec<TetRest> = mesh
                .tets
                .iter()
                .take(tets)
                .map(|t| TetRest::new(&t.map(|v| mesh.positions[v])).unwrap())
                .collect();
            let x: Vec<Vector3<f64>> = mesh.positions.iter().map(|p| p * 1.01).collect();
            let run = |par, buf: &mut [f64]| {
                for_each_chunk_from(par, buf, width * 256, 1, |ci, out| {
                    for (k, h) in out.chunks_exact_mut(width).enumerate() {
                        let e = ci * 256 + k;
                        let t = &mesh.tets[e];
                        let f = rest[e].deformation_gradient(&t.map(|v| x[v]));
                        match width {
                            1 => h[0] = rest[e].volume * m.energy_density(&f).unwrap(),
                            12 => rest[e].gradient_from_stress(&m.first_piola(&f).unwrap(), h),
                            _ => {
                                h.copy_from_slice(m.first_piola_derivative(&f).unwrap().as_slice())
                            }
                        }
                    }
                    Ok::<(), ()>(())
                })
                .unwrap();
            };
            let (mut buf, mut buf2) = (vec![0.0; width * tets], vec![0.0; width * tets]);
            let times = interleaved(
                rounds,
                (400_000 / tets).max(1),
                || run(Parallelism::Sequential, &mut buf),
                || run(Parallelism::Rayon, &mut buf2),
            );
            table.row(&format!("{tets}"), tets as f64, times);
            black_box(&buf2);
        }
        table.crossover();
    }
}

fn matvec(rounds: usize) {
    let mut table = Table::new("CG mat-vec", "rows", "matrix (box), rows");
    for cells in sizes(&[
        [6, 3, 3],
        [10, 5, 5],
        [14, 7, 7],
        [20, 10, 10],
        [32, 16, 16],
    ]) {
        let a = fem_box(cells).matrix;
        let n = a.dim();
        let x = vec![1.0; n];
        let (mut y1, mut y2) = (vec![0.0; n], vec![0.0; n]);
        let times = interleaved(
            rounds,
            (2_000_000 / n).max(1),
            || symmetric_mul_vec(&a, &x, &mut y1, Parallelism::Sequential),
            || symmetric_mul_vec(&a, &x, &mut y2, Parallelism::Rayon),
        );
        table.row(&format!("{cells:?}, {n}"), n as f64, times);
    }
    table.crossover();
}

/// One CG + AMG solve to 1e-8 (the hierarchy built once), per smoother and thread count: the
/// multicolour smoother on one thread and on two (its rows from
/// [`AMG_PARALLEL_MIN_ROWS`] switched off, so both sides of the rule are measured), and the
/// DOF-order Gauss–Seidel on one, with the CG iterations of each (the order changes the
/// iteration, not only its speed).
fn amg(rounds: usize) {
    println!(
        "\n## CG + AMG solve (library rule: levels of {AMG_PARALLEL_MIN_ROWS} rows or more parallel)\n\n| matrix (box), rows | DOF-order GS, 1 thread | multicolour, 1 thread | multicolour, 2 threads | speed-up (2 vs 1) | iterations DOF-order / multicolour |\n|---|---|---|---|---|---|"
    );
    let mut table_rows = Vec::new();
    for cells in sizes(&[
        [10, 5, 5],
        [14, 7, 7],
        [20, 10, 10],
        [32, 16, 16],
        [52, 26, 26],
    ]) {
        let system = fem_box(cells);
        let a = &system.matrix;
        let n = a.dim();
        let solver = |smoother, par| {
            let mut s = CgSolver::new(CgSettings {
                preconditioner: Preconditioner::Amg,
                tolerance: 1e-8,
                max_iterations: 1000,
                amg: AmgSettings {
                    smoother,
                    parallel_min_rows: 0,
                    ..AmgSettings::default()
                },
                parallelism: par,
                ..CgSettings::default()
            });
            s.analyze(a.pattern()).unwrap();
            s.set_coordinates(&system.positions);
            s.factor(a).unwrap();
            s
        };
        let mut lex = solver(AmgSmoother::GaussSeidel, Parallelism::Sequential);
        let mut one = solver(AmgSmoother::MulticolourGaussSeidel, Parallelism::Sequential);
        let mut two = solver(AmgSmoother::MulticolourGaussSeidel, Parallelism::Rayon);
        let rhs: Vec<f64> = (0..n).map(|i| ((i % 7) as f64 - 3.0) * 1e-3).collect();
        let solve = |s: &mut CgSolver| {
            let mut x = rhs.clone();
            s.solve(&mut x).unwrap().iterations
        };
        let (it_lex, it_mc) = (solve(&mut lex), solve(&mut one));
        let reps = (2_000_000 / n).clamp(1, 20);
        let (t_one, t_two) = interleaved(
            rounds,
            reps,
            || {
                solve(&mut one);
            },
            || {
                solve(&mut two);
            },
        );
        let (t_lex, _) = interleaved(
            rounds.div_ceil(3),
            reps,
            || {
                solve(&mut lex);
            },
            || {},
        );
        println!(
            "| {cells:?}, {n} | {:.3} ms | {:.3} ms | {:.3} ms | {:.2}x | {it_lex} / {it_mc} |",
            t_lex * 1e3,
            t_one * 1e3,
            t_two * 1e3,
            t_one / t_two
        );
        table_rows.push((n, t_two < 0.97 * t_one));
    }
    let from = (0..table_rows.len())
        .find(|&i| table_rows[i..].iter().all(|r| r.1))
        .map(|i| table_rows[i].0);
    match from {
        Some(rows) => println!("\nCG + AMG solve: two threads faster from {rows} rows"),
        None => println!("\nCG + AMG solve: two threads never faster at the largest size"),
    }
}

/// Steps per round of the `step` table: with 2.6–4 Newton iterations per step a round holds
/// about ten factorizations or AMG setups (one full AMG build every ten).
const STEPS_PER_ROUND: usize = 3;

/// The `step` table's cases: the default solver and `auto`, on three boxes.
const STEP_CASES: [(&str, &str); 2] = [
    ("cholesky (the default), full Newton", "cholesky"),
    ("auto", "auto"),
];

/// Converged backward-Euler steps of the clamped box (Stable Neo-Hookean, dt = 0.01 s, Newton
/// to 1e-8, required), as `softbench run` takes them on one thread (`RAYON_NUM_THREADS=1`: a
/// pool of one) and on two. Each case runs in a process of its own (a case run after a
/// larger one inherited its allocator's state: `auto` on the 49k box measured 1.07x after
/// the Cholesky cases and 1.45x alone). The last column splits each side's time by the
/// integrator's phases (its `StepReport` times), to show which phase holds the speed-up back;
/// the column before it says whether the second thread waits (CPU per wall time below 2) or
/// its work takes longer with both cores busy (more CPU time than on one thread).
fn step(rounds: usize) {
    println!(
        "\n## step (backward Euler, whole converged steps; the ratio is the median of per-round ratios)\n\n| solver, box | first step, 1 / 2 threads | step, 1 thread | step, 2 threads | speed-up | per-round range | CPU per wall time and CPU time, 1 → 2 threads (medians of rounds) | phases per step, 1 → 2 threads (all rounds) |\n|---|---|---|---|---|---|---|---|"
    );
    let exe = std::env::current_exe().expect("the bench's own path");
    let smoke = SMOKE.load(std::sync::atomic::Ordering::Relaxed);
    for (_, solver) in STEP_CASES {
        for cells in sizes(&[[8, 4, 4], [16, 8, 8], [32, 16, 16]]) {
            let mut command = std::process::Command::new(&exe);
            if !smoke {
                command.arg("--bench");
            }
            let cells = cells.map(|c| c.to_string());
            let out = command
                .args(["step-case", solver, &cells[0], &cells[1], &cells[2]])
                .arg(rounds.to_string())
                .output()
                .expect("the bench runs itself");
            assert!(
                out.status.success(),
                "step-case {solver} {cells:?} failed:\n{}",
                String::from_utf8_lossy(&out.stderr)
            );
            print!("{}", String::from_utf8_lossy(&out.stdout));
        }
    }
}

/// One row of the `step` table: two simulations of the same trajectory advance in lockstep,
/// [`STEPS_PER_ROUND`] steps each per round, one thread then two. After the first step (its
/// ordering, symbolic analysis or AMG build, timed apart) every round does the same steps on
/// both sides; the speed-up is the median of the per-round ratios, with their range. The two
/// states must agree bit for bit after every round (results do not depend on the threads).
fn step_case(solver: &str, cells: [usize; 3], rounds: usize) {
    let label = STEP_CASES
        .iter()
        .find(|c| c.1 == solver)
        .expect("a step case")
        .0;
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let mut settings = IntegratorSettings {
        linear_solver: LinearSolverKind::from_name(solver).unwrap(),
        ..Default::default()
    };
    settings.newton.tolerance = 1e-8;
    settings.newton.max_iterations = 50;
    settings.newton.require_convergence = true;
    let settings = settings.with_parallelism(Parallelism::Rayon);
    let sim = || {
        let model = clamped_box("stable-neo-hookean", cells);
        let state = State::at_rest(&model);
        (settings.build(), model, state)
    };
    let (mut i1, mut m1, mut s1) = sim();
    let (mut i2, mut m2, mut s2) = sim();
    let tets = m1.elastic_elements().unwrap().tets.len();
    // Seconds per step, and the steps' phase times added to `phases` (assembly, factorization
    // or preconditioner setup, solves, forces and energies, the rest).
    let advance =
        |i: &mut Box<dyn Integrator>, m: &mut _, s: &mut State, steps, phases: &mut [f64; 5]| {
            let t = Instant::now();
            let cpu = process_cpu_seconds();
            for _ in 0..steps {
                let r = i.step(m, s, 0.01).unwrap().times;
                let known = [r.assemble, r.factor, r.solve, r.forces];
                for (p, x) in phases.iter_mut().zip(known) {
                    *p += x;
                }
                phases[4] += r.total - known.iter().sum::<f64>();
            }
            (
                t.elapsed().as_secs_f64() / steps as f64,
                (process_cpu_seconds() - cpu) / steps as f64,
            )
        };
    let (mut p1, mut p2) = ([0.0; 5], [0.0; 5]);
    let first1 = one_thread
        .install(|| advance(&mut i1, &mut m1, &mut s1, 1, &mut [0.0; 5]))
        .0;
    let first2 = advance(&mut i2, &mut m2, &mut s2, 1, &mut [0.0; 5]).0;
    let (mut t1, mut t2, mut ratios) = (Vec::new(), Vec::new(), Vec::new());
    // Per round: each side's CPU time per wall time, and the CPU time of two threads
    // against one.
    let (mut per_wall1, mut per_wall2, mut work) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..rounds {
        let (a, cpu_a) =
            one_thread.install(|| advance(&mut i1, &mut m1, &mut s1, STEPS_PER_ROUND, &mut p1));
        let (b, cpu_b) = advance(&mut i2, &mut m2, &mut s2, STEPS_PER_ROUND, &mut p2);
        per_wall1.push(cpu_a / a);
        per_wall2.push(cpu_b / b);
        work.push(cpu_b / cpu_a);
        assert!(
            s1.q == s2.q && s1.v == s2.v,
            "the threads changed the trajectory: {label}, {tets} tets"
        );
        t1.push(a);
        t2.push(b);
        ratios.push(a / b);
    }
    let (lo, hi) = ratios
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(l, h), &r| (l.min(r), h.max(r)));
    let per_step = 1e3 / (rounds * STEPS_PER_ROUND) as f64;
    let phases: Vec<String> = ["assembly", "factor", "solve", "forces", "rest"]
        .iter()
        .zip(p1.iter().zip(&p2))
        .map(|(name, (a, b))| {
            format!(
                "{name} {:.1} → {:.1} ms ({:.2}x)",
                a * per_step,
                b * per_step,
                a / b
            )
        })
        .collect();
    println!(
        "| {label}, {tets} tets | {:.0} / {:.0} ms | {:.1} ms | {:.1} ms | {:.2}x | {lo:.2}–{hi:.2}x | {} | {} |",
        first1 * 1e3,
        first2 * 1e3,
        median(t1) * 1e3,
        median(t2) * 1e3,
        median(ratios),
        CpuUse {
            per_wall: (median(per_wall1), median(per_wall2)),
            work: median(work),
        }
        .describe(),
        phases.join(" · "),
    );
}

/// The Cholesky settings of the factorization and solve tables: METIS, the subtree schedule,
/// on the pool from any size (`parallelism` decides).
fn always_parallel(parallelism: Parallelism) -> DirectSettings {
    DirectSettings {
        ordering: Ordering::Metis,
        parallelism,
        parallel_min_flops: 0.0,
        ..DirectSettings::default()
    }
}

fn factor(rounds: usize) {
    let mut table = Table::new(
        "Cholesky factorization (METIS, subtree schedule)",
        "flops",
        &format!(
            "matrix, predicted flops (library rule: {PARALLEL_MIN_FLOPS:.0e}), CPU per wall time and CPU time 1 → 2 threads"
        ),
    );
    let mut systems = Vec::new();
    for cells in sizes(&[
        [6, 3, 3],
        [8, 4, 4],
        [10, 5, 5],
        [12, 6, 6],
        [16, 8, 8],
        [20, 10, 10],
        [24, 12, 12],
        [28, 14, 14],
        [32, 16, 16],
    ]) {
        systems.push((format!("box {cells:?}"), fem_box(cells).matrix));
    }
    for n in sizes(&[6, 8, 10]) {
        systems.push((format!("ball {n}"), fem_ball(n).matrix));
    }
    for (label, a) in &systems {
        let mut one = CholeskySolver::new(always_parallel(Parallelism::Sequential));
        one.analyze(a.pattern()).unwrap();
        let mut two = CholeskySolver::new(always_parallel(Parallelism::Rayon));
        two.analyze(a.pattern()).unwrap();
        let flops = one.stats().factor_flops;
        let (times, cpu) = interleaved_cpu(
            rounds,
            (1e8 / flops).clamp(1.0, 50.0) as usize,
            || {
                one.factor(a).unwrap();
            },
            || {
                two.factor(a).unwrap();
            },
        );
        table.row(
            &format!("{label}, {flops:.2e}, {}", cpu.describe()),
            flops,
            times,
        );
    }
    table.crossover();
}

/// Streaming reads of an array far larger than the caches (a sum over 32 MiB to 256 MiB, in
/// two halves on two threads): the memory bandwidth one thread and two get, the ceiling of
/// every memory-bound phase (triangular solves, mat-vecs, scatters).
fn bandwidth(rounds: usize) {
    let mut table = Table::new(
        "memory bandwidth (streaming sum)",
        "MiB",
        "array, GB/s on 1 / 2 threads",
    );
    for mib in sizes(&[32usize, 64, 128, 256]) {
        let n = mib << 17;
        let data: Vec<f64> = (0..n).map(|i| (i % 13) as f64).collect();
        // Eight independent partial sums: limited by memory, not by the adds' latency.
        let sum = |xs: &[f64]| {
            let mut acc = [0.0f64; 8];
            for c in xs.chunks_exact(8) {
                for (a, x) in acc.iter_mut().zip(c) {
                    *a += x;
                }
            }
            acc.iter().sum::<f64>()
        };
        let (mut s1, mut s2) = (0.0, 0.0);
        let times = interleaved(
            rounds,
            2,
            || s1 = sum(black_box(&data)),
            || {
                let (a, b) = data.split_at(n / 2);
                let (x, y) = rayon::join(|| sum(black_box(a)), || sum(black_box(b)));
                s2 = x + y;
            },
        );
        assert!(s1 > 0.0 && s2 > 0.0);
        let gbs = |t: f64| (n * 8) as f64 / t / 1e9;
        table.row(
            &format!("{mib} MiB, {:.1} / {:.1}", gbs(times.0), gbs(times.1)),
            mib as f64,
            times,
        );
    }
    table.crossover();
}

/// What a second core gives compute: work that touches no memory (independent FMA chains in
/// registers, one set per thread: the ceiling of any schedule) and faer's dense kernels at the
/// sizes of the 49k box's root supernode (`examples/tree_profile`): a square product, a
/// rank-64 update (a descendant's update of a front) and a dense LLᵀ, each on one thread
/// (`Par::Seq`) against two (`Par::rayon(2)`), as the factorization calls them.
fn dense(rounds: usize) {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::cholesky::llt::factor::{
        LltRegularization, cholesky_in_place, cholesky_in_place_scratch,
    };
    use faer::linalg::matmul::matmul;
    use faer::{Accum, Mat, Par};

    let mut table = Table::new(
        "dense compute (registers, faer kernels)",
        "flops",
        "work, flops, CPU per wall time and CPU time 1 → 2 threads",
    );
    // Registers only: eight independent multiply-add chains per thread.
    let chains = |iters: usize| {
        let mut acc = [1.0f64, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.7];
        for _ in 0..iters {
            for a in acc.iter_mut() {
                *a = a.mul_add(0.999_999_9, 1e-9);
            }
        }
        black_box(acc).iter().sum::<f64>()
    };
    let iters = if SMOKE.load(std::sync::atomic::Ordering::Relaxed) {
        1 << 16
    } else {
        1 << 24
    };
    let (times, cpu) = interleaved_cpu(
        rounds,
        1,
        || {
            black_box(chains(black_box(iters)) + chains(black_box(iters)));
        },
        || {
            black_box(rayon::join(
                || chains(black_box(iters)),
                || chains(black_box(iters)),
            ));
        },
    );
    let flops = (2 * 2 * 8 * iters) as f64;
    table.row(
        &format!("FMA chains in registers, {flops:.2e}, {}", cpu.describe()),
        flops,
        times,
    );

    let filled =
        |m: usize, n: usize| Mat::from_fn(m, n, |i, j| ((i * 7 + j * 13) % 17) as f64 / 17.0 - 0.5);
    for (m, n, k) in sizes(&[(512, 512, 512), (2048, 2048, 64), (2048, 2048, 2048)]) {
        let (a, b) = (filled(m, k), filled(k, n));
        let (mut c1, mut c2) = (Mat::<f64>::zeros(m, n), Mat::<f64>::zeros(m, n));
        let (times, cpu) = interleaved_cpu(
            rounds,
            1,
            || {
                matmul(
                    c1.as_mut(),
                    Accum::Replace,
                    a.as_ref(),
                    b.as_ref(),
                    1.0,
                    Par::Seq,
                )
            },
            || {
                matmul(
                    c2.as_mut(),
                    Accum::Replace,
                    a.as_ref(),
                    b.as_ref(),
                    1.0,
                    Par::rayon(2),
                )
            },
        );
        let flops = 2.0 * (m * n * k) as f64;
        table.row(
            &format!("product {m}×{k} · {k}×{n}, {flops:.2e}, {}", cpu.describe()),
            flops,
            times,
        );
    }
    for n in sizes(&[512usize, 1024, 2048]) {
        // Diagonally dominant, so SPD.
        let spd = Mat::from_fn(n, n, |i, j| {
            if i == j {
                n as f64
            } else {
                ((i + j) % 5) as f64 / 10.0
            }
        });
        let scratch =
            |par| MemBuffer::new(cholesky_in_place_scratch::<f64>(n, par, Default::default()));
        let (mut mem1, mut mem2) = (scratch(Par::Seq), scratch(Par::rayon(2)));
        let (mut l1, mut l2) = (spd.clone(), spd.clone());
        let factor = |l: &mut Mat<f64>, mem: &mut MemBuffer, par| {
            l.copy_from(&spd);
            cholesky_in_place(
                l.as_mut(),
                LltRegularization::default(),
                par,
                MemStack::new(mem),
                Default::default(),
            )
            .expect("SPD");
        };
        let (times, cpu) = interleaved_cpu(
            rounds,
            1,
            || factor(&mut l1, &mut mem1, Par::Seq),
            || factor(&mut l2, &mut mem2, Par::rayon(2)),
        );
        let flops = (n * n * n) as f64 / 3.0;
        table.row(
            &format!("dense LLᵀ {n}×{n}, {flops:.2e}, {}", cpu.describe()),
            flops,
            times,
        );
    }
    table.crossover();
}

/// The triangular solves with a factor of the subtree schedule (forward and backward, the
/// permutation and the residual check of a `solve` call), one thread against two, on the
/// factorization table's largest boxes and ball, with the rate at which one thread reads L's
/// storage (twice per solve) to set against the `bandwidth` table. The one-thread side runs
/// on a pool of one, as `RAYON_NUM_THREADS=1` does; the two-thread side inside the global
/// pool (`rayon::scope`), as a step large enough for threads calls it.
fn solve(rounds: usize) {
    let mut table = Table::new(
        "Cholesky solve (METIS, subtree schedule, one right-hand side)",
        "factor entries",
        "matrix, factor entries, L's storage read per time, CPU per wall time and CPU time 1 → 2 threads",
    );
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let mut systems = Vec::new();
    for cells in sizes(&[[8, 4, 4], [16, 8, 8], [24, 12, 12], [32, 16, 16]]) {
        systems.push((format!("box {cells:?}"), fem_box(cells).matrix));
    }
    for n in sizes(&[8, 10]) {
        systems.push((
            format!("ball {n}, {} tets", 48 * n * n * n),
            fem_ball(n).matrix,
        ));
    }
    for (label, a) in &systems {
        let mut one = CholeskySolver::new(always_parallel(Parallelism::Sequential));
        let mut two = CholeskySolver::new(always_parallel(Parallelism::Rayon));
        for s in [&mut one, &mut two] {
            s.analyze(a.pattern()).unwrap();
            s.factor(a).unwrap();
        }
        let nnz = one.stats().factor_nnz as f64;
        // Bytes of L's storage (explicit zeros of relaxed supernodes included) that a forward
        // and a backward solve read.
        let bytes = 2.0 * 8.0 * one.stats().factor_storage as f64;
        let rhs: Vec<f64> = (0..a.dim())
            .map(|i| ((i % 7) as f64 - 3.0) * 1e-3)
            .collect();
        let (mut x1, mut x2) = (rhs.clone(), rhs.clone());
        // The repetitions inside one `install`: entering the pool costs tens of microseconds,
        // the time of a whole solve on the smallest boxes.
        let reps = (2e7 / nnz).clamp(1.0, 200.0) as usize;
        let solves = |s: &mut CholeskySolver, x: &mut Vec<f64>| {
            for _ in 0..reps {
                x.copy_from_slice(&rhs);
                s.solve(x).unwrap();
            }
        };
        let ((t1, t2), cpu) = interleaved_cpu(
            rounds,
            1,
            || one_thread.install(|| solves(&mut one, &mut x1)),
            // From a pool thread, as a step large enough for threads calls it.
            || rayon::scope(|_| solves(&mut two, &mut x2)),
        );
        let times = (t1 / reps as f64, t2 / reps as f64);
        assert!(x1 == x2, "{label}: the threads changed the solution");
        table.row(
            &format!(
                "{label}, {nnz:.2e}, L read at {:.1} GB/s on one thread, {}",
                bytes / times.0 / 1e9,
                cpu.describe()
            ),
            nnz,
            times,
        );
    }
    table.crossover();
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    // `cargo test --all-targets` runs this main without `--bench`: then a smoke run (every
    // table on its smallest sizes, one round), so the tests prove the bench still runs.
    let smoke = !std::env::args().any(|a| a == "--bench");
    SMOKE.store(smoke, std::sync::atomic::Ordering::Relaxed);
    let quick = smoke || args.iter().any(|a| a == "--quick");
    let only: Vec<&String> = args.iter().filter(|a| !a.starts_with("--")).collect();
    // A case of the `step` table, in a process of its own: `step-case <solver> <nx> <ny> <nz>
    // <rounds>`.
    if only.first().is_some_and(|a| *a == "step-case") {
        let number = |k: usize| only[k].parse::<usize>().expect("step-case numbers");
        rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build_global()
            .unwrap();
        step_case(only[1], [number(2), number(3), number(4)], number(5));
        return;
    }
    let wanted = |name: &str| only.is_empty() || only.iter().any(|o| *o == name);
    let rounds = if smoke {
        1
    } else if quick {
        5
    } else {
        15
    };
    // As the command line runs: the global pool of two threads, called from outside it.
    rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build_global()
        .unwrap();
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "# thread crossover: 1 thread against a 2-thread pool, medians of {rounds} interleaved rounds\n\nload average at start: {}",
        load.trim()
    );
    if wanted("xpbd") {
        xpbd(rounds);
    }
    if wanted("elements") {
        elements(rounds);
    }
    if wanted("matvec") {
        matvec(rounds);
    }
    if wanted("amg") {
        amg(rounds);
    }
    if wanted("factor") {
        factor(rounds);
    }
    if wanted("dense") {
        dense(rounds);
    }
    if wanted("bandwidth") {
        bandwidth(rounds);
    }
    if wanted("solve") {
        solve(rounds);
    }
    if wanted("step") {
        step(rounds);
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!("\nload average at end: {}", load.trim());
}
