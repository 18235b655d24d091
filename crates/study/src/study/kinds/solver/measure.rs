//! The solver study kind, measuring: its columns, the work its runs share and one run's
//! measurement.

use super::{LADDER_COLUMNS, Solver, SolverStudySettings, TOLERANCES, settings, steps_text};
use crate::study::kind::{Measure, RunInputs};
use crate::study::vocabulary::format::cell;
use crate::study::vocabulary::measured::{Measured, build, peak_rss_mib, reset_peak_rss};
use crate::study::vocabulary::spec::{RunSpec, Study};
use crate::study::vocabulary::table::Table;
use softbench_core::integrate::newton::log::CSV_HEADER;
use softbench_core::integrate::newton::{Criterion, IterationRecord, Newton, Stop};
use softbench_core::integrate::{
    FrozenStep, IntegratorSettings, NewtonSettings, StepError, StepReport, solve_frozen,
};
use softbench_core::parallel::Parallelism;
use softbench_core::solve::{LinearSolverKind, SolverSettings as LinearSolverSettings};
use softbench_run::run::OutcomeKind;
use std::time::Instant;

/// `runs.csv`'s columns before the ladder's.
const HEAD_COLUMNS: [&str; 5] = [
    "dt",
    "outcome",
    "criterion",
    "solved_steps",
    "problems_fingerprint",
];

/// `runs.csv`'s columns after the ladder's.
const TAIL_COLUMNS: [&str; 15] = [
    "final_residual",
    "iterations_total",
    "seconds_total",
    "stops",
    "projected_elements",
    "capped_subproblems",
    "repeats",
    "iterates_repeatable",
    "solve_max_iterations",
    "driver_tolerance",
    "driver_seconds",
    "tets",
    "free_dofs",
    "fixed_dofs",
    "peak_rss_mib",
];

/// [`HEAD_COLUMNS`], the ladder's columns in order, then [`TAIL_COLUMNS`].
const ALL_COLUMNS: [&str; 5 + 35 + 15] = {
    let mut out = [""; 5 + 35 + 15];
    let mut i = 0;
    while i < HEAD_COLUMNS.len() {
        out[i] = HEAD_COLUMNS[i];
        i += 1;
    }
    let mut level = 0;
    while level < LADDER_COLUMNS.len() {
        let mut k = 0;
        while k < LADDER_COLUMNS[level].len() {
            out[i] = LADDER_COLUMNS[level][k];
            i += 1;
            k += 1;
        }
        level += 1;
    }
    let mut k = 0;
    while k < TAIL_COLUMNS.len() {
        out[i] = TAIL_COLUMNS[k];
        i += 1;
        k += 1;
    }
    out
};

/// Columns of a solver study's `runs.csv` after the run's identity.
pub const COLUMNS: &[&str] = &ALL_COLUMNS;

impl Measure for Solver {
    fn columns(&self) -> &'static [&'static str] {
        COLUMNS
    }

    fn progress(&self, m: &Measured) -> Option<String> {
        let reached = m.get("iterations_1e-8").filter(|s| !s.is_empty());
        Some(match reached {
            Some(n) => format!(", {n} iterations to 1e-8"),
            None => format!(
                ", 1e-8 not reached ({})",
                m.get("stops").unwrap_or_default()
            ),
        })
    }

    fn measure(
        &self,
        study: &Study,
        spec: &RunSpec,
        _: &RunInputs,
        parallelism: Parallelism,
    ) -> Result<Measured, String> {
        let settings = settings(&study.file).ok_or("no [solver] table")?;
        measure(spec, &settings, parallelism)
    }
}

/// One solve of one frozen step: its log and how it ended.
struct Solve {
    step: usize,
    records: Vec<IterationRecord>,
    /// The error that ended it, if one did.
    error: Option<String>,
    report: StepReport,
}

impl Solve {
    /// How it ended: `roundoff`, `cap`, `criterion` or `failed`.
    fn stop(&self) -> &'static str {
        if self.error.is_some() {
            return "failed";
        }
        self.records.last().map_or("failed", |r| match r.stop {
            Stop::Running => "failed",
            stop => stop.name(),
        })
    }
}

/// What reaching a tolerance cost one solve.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Reach {
    /// The first iterate that meets it.
    pub iteration: u32,
    /// Wall time from the start of the solve until that iterate was accepted (0 for the
    /// guess).
    pub seconds: f64,
    pub factorizations: u64,
    pub linear_iterations: u64,
    pub backtracks: u64,
    pub projected_elements: u64,
}

/// Where the logged solve `records` first meets `criterion` at `tolerance`, with the work that
/// took: the directions computed from the earlier iterates (and, for a criterion that needs the
/// direction, from this one) and the backtracks that reached it. `None` if it never does.
pub fn reach(records: &[IterationRecord], criterion: Criterion, tolerance: f64) -> Option<Reach> {
    let mut work = Reach::default();
    for (i, r) in records.iter().enumerate() {
        work.backtracks += u64::from(r.backtracks);
        let own_direction = criterion.needs_direction();
        if own_direction {
            work.factorizations += u64::from(r.factorizations);
            work.linear_iterations += r.linear_iterations;
            work.projected_elements += r.projected_elements;
        }
        if criterion.met(tolerance, r) {
            work.iteration = r.iteration;
            work.seconds = if own_direction {
                r.seconds
            } else if i == 0 {
                0.0
            } else {
                records[i - 1].seconds
            };
            return Some(work);
        }
        if !own_direction {
            work.factorizations += u64::from(r.factorizations);
            work.linear_iterations += r.linear_iterations;
            work.projected_elements += r.projected_elements;
        }
    }
    None
}

/// Measure one run: drive the trajectory to the last step, freezing the listed ones, then solve
/// them `repeats` times with the run's Newton components.
pub fn measure(
    spec: &RunSpec,
    s: &SolverStudySettings,
    parallelism: Parallelism,
) -> Result<Measured, String> {
    reset_peak_rss();
    let criterion = s.criterion;
    let mut scene = build(spec, parallelism).map_err(|e| e.to_string())?;
    let dt = scene.config.run.dt;
    let settings = scene
        .config
        .integrator
        .with_parallelism(scene.model.parallelism());
    let mut m = Measured::default();
    m.set("dt", cell(Some(dt)));
    m.set("criterion", criterion.name().to_owned());
    m.set("solved_steps", steps_text(&s.steps));
    m.set("solve_max_iterations", s.max_iterations.to_string());
    m.set("driver_tolerance", cell(Some(s.driver_tolerance)));
    m.set("repeats", s.repeats.to_string());
    m.set("tets", scene.model.tets().len().to_string());
    let dofs = scene.model.dofs().counts();
    m.set("free_dofs", dofs.free_dofs.to_string());
    m.set("fixed_dofs", dofs.fixed_dofs.to_string());
    let failed = |mut m: Measured, kind: OutcomeKind, message: String| {
        m.outcome = kind.name().to_owned();
        m.message = message;
        Ok(m)
    };

    let mut driver = driver_settings(&settings, s).build();
    let mut state = scene.initial.clone();
    let last = s.steps.last().copied().unwrap_or(1);
    let mut frozen: Vec<(usize, FrozenStep)> = Vec::new();
    let start = Instant::now();
    for k in 1..=last {
        if s.steps.contains(&k) {
            match driver.freeze_step(&mut scene.model, &state, dt) {
                Some(Ok(f)) => frozen.push((k, f)),
                Some(Err(e)) => {
                    return failed(m, outcome_kind(&e), format!("freezing step {k}: {e}"));
                }
                None => {
                    return failed(
                        m,
                        OutcomeKind::SolverFailed,
                        format!(
                            "`{}` does not minimize one incremental potential at step {k} (an \
                             extrapolated BDF start-up step is three solves)",
                            settings.method.name()
                        ),
                    );
                }
            }
        }
        if k < last
            && let Err(e) = driver.step(&mut scene.model, &mut state, dt)
        {
            return failed(
                m,
                outcome_kind(&e),
                format!("the trajectory that sets the steps failed at step {k}: {e}"),
            );
        }
    }
    m.set("driver_seconds", cell(Some(start.elapsed().as_secs_f64())));
    m.set("problems_fingerprint", fingerprint(&frozen));

    // Each repeat: a fresh Newton with the run's components, solving the steps in order.
    let mut solve_settings = settings.newton;
    solve_settings.criterion = Criterion::Gradient;
    solve_settings.tolerance = 0.0;
    solve_settings.max_iterations = s.max_iterations;
    solve_settings.require_convergence = false;
    solve_settings.retry_halvings = 0;
    solve_settings.log_iterations = true;
    solve_settings.roundoff_stop = false;
    let mut repeats: Vec<Vec<Solve>> = Vec::with_capacity(s.repeats);
    for _ in 0..s.repeats {
        let solver = settings.linear_solver.build(&settings.solver);
        let mut newton = Newton::new(solver, solve_settings);
        let mut solves = Vec::with_capacity(frozen.len());
        for (k, f) in &frozen {
            let mut x = Vec::new();
            let mut report = StepReport::default();
            let result = solve_frozen(&mut newton, &mut scene.model, f, &mut x, &mut report);
            if let Err(StepError::Interrupted(signal)) = &result {
                return failed(
                    m,
                    OutcomeKind::Interrupted,
                    format!("stopped by {} while solving step {k}", signal.name()),
                );
            }
            let mut records = Vec::new();
            newton.drain_log(&mut records);
            solves.push(Solve {
                step: *k,
                records,
                error: result.err().map(|e| e.to_string()),
                report,
            });
        }
        repeats.push(solves);
    }
    let first = &repeats[0];
    summarize(&mut m, &repeats, criterion);
    m.tables = vec![
        ("iterations", iterations_table(first, criterion)),
        ("solves", solves_table(first)),
    ];
    m.set("peak_rss_mib", cell(peak_rss_mib()));
    let failures: Vec<String> = first
        .iter()
        .filter_map(|x| x.error.as_ref().map(|e| format!("step {}: {e}", x.step)))
        .collect();
    if failures.is_empty() {
        m.outcome = OutcomeKind::Completed.name().to_owned();
        Ok(m)
    } else {
        failed(m, OutcomeKind::SolverFailed, failures.join("; "))
    }
}

/// The trajectory that sets the steps: the run's scheme with default Newton settings (converged
/// to `driver_tolerance`, required) and the default Cholesky, so every run of a scene and scheme
/// freezes the same states whatever its own components and linear solver.
pub fn driver_settings(run: &IntegratorSettings, s: &SolverStudySettings) -> IntegratorSettings {
    let mut driver = *run;
    driver.newton = NewtonSettings {
        tolerance: s.driver_tolerance,
        max_iterations: s.driver_max_iterations,
        require_convergence: true,
        ..NewtonSettings::default()
    };
    driver.linear_solver = LinearSolverKind::cholesky();
    let parallelism = run.solver.direct.parallelism;
    driver.solver = LinearSolverSettings::default();
    driver.with_parallelism(parallelism)
}

/// The outcome a step error means.
fn outcome_kind(e: &StepError) -> OutcomeKind {
    match e {
        StepError::InvertedElement { .. } => OutcomeKind::LeftMaterialDomain,
        StepError::NonFinite { .. } => OutcomeKind::Unstable,
        StepError::Interrupted(_) => OutcomeKind::Interrupted,
        _ => OutcomeKind::SolverFailed,
    }
}

/// A hash of the frozen problems' numbers, bit for bit: equal in every run of a scene.
fn fingerprint(frozen: &[(usize, FrozenStep)]) -> String {
    let mut bytes = Vec::new();
    for (k, f) in frozen {
        let p = &f.problem;
        bytes.extend((*k as u64).to_le_bytes());
        for v in [
            &p.x_hat,
            &p.damping_anchor,
            &p.damping_at,
            &p.linear,
            &p.guess,
            &f.start,
        ] {
            bytes.extend(v.iter().flat_map(|x| x.to_bits().to_le_bytes()));
        }
        for x in [p.beta, p.force_time, p.damping_weight, p.force_scale] {
            bytes.extend(x.to_bits().to_le_bytes());
        }
        bytes.push(u8::from(p.quasi_static));
    }
    format!("{:016x}", crate::study::vocabulary::identity::fnv1a(&bytes))
}

/// The ladder's cells (summed over the steps; seconds as the median over the repeats with
/// their range) and the totals.
fn summarize(m: &mut Measured, repeats: &[Vec<Solve>], criterion: Criterion) {
    let first = &repeats[0];
    for (level, tolerance) in TOLERANCES.iter().enumerate() {
        let [
            iterations,
            seconds,
            low,
            high,
            factorizations,
            linear,
            backtracks,
        ] = LADDER_COLUMNS[level];
        let per_repeat: Vec<Option<Vec<Reach>>> = repeats
            .iter()
            .map(|solves| {
                solves
                    .iter()
                    .map(|x| {
                        x.error
                            .is_none()
                            .then(|| reach(&x.records, criterion, *tolerance))
                            .flatten()
                    })
                    .collect()
            })
            .collect();
        let Some(Some(reached)) = per_repeat.first() else {
            for column in LADDER_COLUMNS[level] {
                m.set(column, String::new());
            }
            continue;
        };
        let sum = |f: &dyn Fn(&Reach) -> u64| reached.iter().map(f).sum::<u64>().to_string();
        m.set(iterations, sum(&|r| u64::from(r.iteration)));
        m.set(factorizations, sum(&|r| r.factorizations));
        m.set(linear, sum(&|r| r.linear_iterations));
        m.set(backtracks, sum(&|r| r.backtracks));
        let mut times: Vec<f64> = per_repeat
            .iter()
            .flatten()
            .map(|r| r.iter().map(|x| x.seconds).sum())
            .collect();
        times.sort_by(f64::total_cmp);
        m.set(seconds, cell(Some(median(&times))));
        m.set(low, cell(times.first().copied()));
        m.set(high, cell(times.last().copied()));
    }
    let last_residuals: Vec<f64> = first
        .iter()
        .filter_map(|x| x.records.last().map(|r| criterion.residual(r)))
        .collect();
    m.set(
        "final_residual",
        cell(last_residuals.iter().copied().reduce(f64::max)),
    );
    m.set(
        "iterations_total",
        first
            .iter()
            .map(|x| x.records.last().map_or(0, |r| u64::from(r.iteration)))
            .sum::<u64>()
            .to_string(),
    );
    let mut totals: Vec<f64> = repeats
        .iter()
        .map(|solves| {
            solves
                .iter()
                .map(|x| x.records.last().map_or(0.0, |r| r.seconds))
                .sum()
        })
        .collect();
    totals.sort_by(f64::total_cmp);
    m.set("seconds_total", cell(Some(median(&totals))));
    m.set("stops", stops_text(first));
    m.set(
        "projected_elements",
        first
            .iter()
            .map(|x| x.report.projected_elements)
            .sum::<u64>()
            .to_string(),
    );
    m.set(
        "capped_subproblems",
        first
            .iter()
            .map(|x| u64::from(x.report.capped_subproblems))
            .sum::<u64>()
            .to_string(),
    );
    // The iterates must not depend on the repeat (a fresh Newton each time).
    let trace = |solves: &Vec<Solve>| -> Vec<(u32, u64)> {
        solves
            .iter()
            .flat_map(|x| x.records.iter())
            .map(|r| (r.iteration, r.gradient_norm.to_bits()))
            .collect()
    };
    let same = repeats.iter().all(|r| trace(r) == trace(first));
    m.set("iterates_repeatable", same.to_string());
}

/// The median of sorted `v` (NaN when empty).
fn median(v: &[f64]) -> f64 {
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// How the solves ended, counted: `roundoff 2, cap 1`.
fn stops_text(solves: &[Solve]) -> String {
    let mut counts: Vec<(&str, usize)> = Vec::new();
    for x in solves {
        let stop = x.stop();
        match counts.iter_mut().find(|(s, _)| *s == stop) {
            Some(c) => c.1 += 1,
            None => counts.push((stop, 1)),
        }
    }
    counts
        .iter()
        .map(|(s, n)| format!("{s} {n}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Every logged iteration of the first repeat, with the step it solved and the residual of
/// the study's criterion.
fn iterations_table(solves: &[Solve], criterion: Criterion) -> Table {
    let mut header: Vec<String> = CSV_HEADER.iter().map(|s| (*s).to_owned()).collect();
    header.push("residual".into());
    let mut table = Table::new(header);
    for x in solves {
        for r in &x.records {
            let mut row = r.csv_cells(x.step);
            row.push(cell(Some(criterion.residual(r))));
            table.rows.push(row);
        }
    }
    table
}

/// The columns of `series/<run>-solves.csv`.
const SOLVES_HEADER: [&str; 11] = [
    "step",
    "criterion",
    "tolerance",
    "iteration",
    "seconds",
    "factorizations",
    "linear_iterations",
    "backtracks",
    "projected_elements",
    "stop",
    "error",
];

/// Every step under every criterion at every tolerance of the ladder (the first repeat): where
/// it was reached and what that took; empty cells where it was not.
fn solves_table(solves: &[Solve]) -> Table {
    let mut table = Table::new(SOLVES_HEADER.iter().map(|s| (*s).to_owned()).collect());
    for x in solves {
        for criterion in Criterion::ALL {
            for tolerance in TOLERANCES {
                let reached = reach(&x.records, *criterion, tolerance);
                let n = |f: &dyn Fn(&Reach) -> String| reached.as_ref().map_or(String::new(), f);
                table.rows.push(vec![
                    x.step.to_string(),
                    criterion.name().to_owned(),
                    format!("{tolerance:e}"),
                    n(&|r| r.iteration.to_string()),
                    n(&|r| format!("{:e}", r.seconds)),
                    n(&|r| r.factorizations.to_string()),
                    n(&|r| r.linear_iterations.to_string()),
                    n(&|r| r.backtracks.to_string()),
                    n(&|r| r.projected_elements.to_string()),
                    x.stop().to_owned(),
                    x.error.clone().unwrap_or_default(),
                ]);
            }
        }
    }
    table
}
