//! The run loop: step a scene, sample its state, and stop at the first sign of blow-up.
//!
//! A run fails at the first step that cannot be taken (non-finite state, inverted element,
//! Newton or solver failure: see [`crate::integrate::StepError`]) or, at a sampled step, when
//! the internal energy (kinetic + elastic + springs) exceeds `energy_limit` times its initial
//! value plus the work done on the body since the start: by gravity, and by time-dependent
//! potentials such as drag springs (`sum over steps of V(x_n, t_n+1) - V(x_n, t_n)`, the work of
//! moving their targets). The rows written before are valid
//! states; the [`Outcome`] says where and why the run ended.

use super::metrics::{Energies, Metrics};
use crate::integrate::{Integrator, State, StepReport};
use crate::model::Model;
use crate::scene::RunConfig;

/// One sampled row: the state after `step` steps and the work done since the previous row.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Sample {
    pub step: usize,
    /// Simulated time (s).
    pub t: f64,
    /// Time step (s).
    pub dt: f64,
    pub kinetic: f64,
    pub elastic: f64,
    pub gravity: f64,
    /// Kinetic + elastic + springs + gravity (J).
    pub total: f64,
    /// Linear momentum (kg m/s).
    pub momentum_x: f64,
    pub momentum_y: f64,
    pub momentum_z: f64,
    /// Newton iterations since the previous row.
    pub newton_iterations: u64,
    /// Linear-solver iterations since the previous row.
    pub linear_iterations: u64,
    /// Wall time of the steps since the previous row (s).
    pub wall_seconds: f64,
    pub springs: f64,
    /// Per-vertex potentials: contact penalties and drag springs (J).
    pub external: f64,
    /// Angular momentum about the origin (kg m^2/s).
    pub angular_momentum_x: f64,
    pub angular_momentum_y: f64,
    pub angular_momentum_z: f64,
    /// Steps since the previous row.
    pub steps: u64,
    pub substeps: u64,
    pub rejected_substeps: u64,
    pub newton_unconverged: u64,
    pub line_search_backtracks: u64,
    pub linear_solves: u64,
    pub factorizations: u64,
    pub max_relative_residual: f64,
    pub indefinite_fallbacks: u64,
    pub dt_halvings: u64,
    pub potential_evaluations: u64,
    pub gradient_evaluations: u64,
    pub hessian_evaluations: u64,
    pub assemble_seconds: f64,
    pub factor_seconds: f64,
    pub solve_seconds: f64,
    /// Wall time since the start of the run (s).
    pub elapsed_seconds: f64,
    /// Most (vertex, obstacle) pairs in contact after any step since the previous row.
    pub contacts: u64,
    /// Deepest penetration into an obstacle after any step since the previous row (m).
    pub max_penetration: f64,
    /// Quadratic programs solved since the previous row (constrained contact).
    pub qp_solves: u64,
    /// Their wall time (s).
    pub qp_seconds: f64,
    /// Entries of the largest sparse factor built since the previous row (nnz(L)).
    pub factor_nnz: u64,
}

/// What watches a run: every sampled row, and (optionally) the state after every step —
/// for writing frames. A closure `FnMut(&Sample) -> io::Result<()>` is an observer of rows.
pub trait Observer {
    /// A sampled row.
    fn sample(&mut self, sample: &Sample) -> std::io::Result<()>;

    /// The state after `step` steps (step 0 is the initial state). Default: nothing.
    fn after_step(&mut self, _step: usize, _model: &Model, _state: &State) -> std::io::Result<()> {
        Ok(())
    }
}

impl<F: FnMut(&Sample) -> std::io::Result<()>> Observer for F {
    fn sample(&mut self, sample: &Sample) -> std::io::Result<()> {
        self(sample)
    }
}

/// How a run ended.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
#[serde(tag = "status", rename_all = "lowercase")]
pub enum Outcome {
    /// Every step was taken.
    Completed,
    /// The run stopped at `step` (trying to reach time `t`).
    Failed {
        step: usize,
        t: f64,
        cause: String,
        message: String,
    },
    /// A stop was requested (SIGINT or SIGTERM) after `step` steps; the rows so far are valid.
    Interrupted { step: usize, signal: String },
}

/// What a run did, for `summary.json` and study tables.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RunSummary {
    pub method: String,
    pub dt: f64,
    pub steps_requested: usize,
    pub steps_completed: usize,
    pub final_time: f64,
    pub outcome: Outcome,
    pub initial_energy: Energies,
    pub final_energy: Option<Energies>,
    /// Largest |total(t) - total(0)| / scale over the sampled rows, with scale the initial
    /// internal energy plus |gravity work| (or 1 J if both are zero).
    pub energy_drift_max: f64,
    /// The same at the last sampled row.
    pub energy_drift_final: f64,
    /// Median and 95th percentile of the wall time per step (s).
    pub step_seconds_median: f64,
    pub step_seconds_p95: f64,
    /// Work summed over all steps.
    pub totals: StepReport,
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let i = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[i]
}

/// The work a row reports: since the previous row.
struct RowWork<'a> {
    report: &'a StepReport,
    steps: u64,
    dt: f64,
    elapsed: f64,
}

fn sample(
    step: usize,
    state: &State,
    energies: &Energies,
    (p, l): ([f64; 3], [f64; 3]),
    w: RowWork,
) -> Sample {
    let work = w.report;
    Sample {
        step,
        t: state.t,
        dt: w.dt,
        kinetic: energies.kinetic,
        elastic: energies.elastic,
        gravity: energies.gravity,
        total: energies.total(),
        momentum_x: p[0],
        momentum_y: p[1],
        momentum_z: p[2],
        newton_iterations: work.newton_iterations.into(),
        linear_iterations: work.linear_iterations,
        wall_seconds: work.times.total,
        springs: energies.springs,
        external: energies.external,
        angular_momentum_x: l[0],
        angular_momentum_y: l[1],
        angular_momentum_z: l[2],
        steps: w.steps,
        substeps: work.substeps.into(),
        rejected_substeps: work.rejected_substeps.into(),
        newton_unconverged: work.newton_unconverged.into(),
        line_search_backtracks: work.line_search_backtracks.into(),
        linear_solves: work.linear_solves.into(),
        factorizations: work.factorizations.into(),
        max_relative_residual: work.max_relative_residual,
        indefinite_fallbacks: work.indefinite_fallbacks.into(),
        dt_halvings: work.dt_halvings.into(),
        potential_evaluations: work.evaluations.potential,
        gradient_evaluations: work.evaluations.gradient,
        hessian_evaluations: work.evaluations.hessian,
        assemble_seconds: work.times.assemble,
        factor_seconds: work.times.factor,
        solve_seconds: work.times.solve,
        elapsed_seconds: w.elapsed,
        contacts: work.contacts.into(),
        max_penetration: work.max_penetration,
        qp_solves: work.qp_solves.into(),
        qp_seconds: work.times.qp,
        factor_nnz: work.factor_nnz as u64,
    }
}

fn add_work(acc: &mut StepReport, r: &StepReport) {
    acc.absorb(r);
    acc.evaluations.potential += r.evaluations.potential;
    acc.evaluations.gradient += r.evaluations.gradient;
    acc.evaluations.hessian += r.evaluations.hessian;
    acc.times.total += r.times.total;
}

/// Run `config.steps` steps of `integrator` from `state`, giving the observer step 0 and
/// every `config.sample_every` steps (and the last), and every state with `after_step`.
/// Returns how the run ended; an error only when the observer fails (e.g. the output file
/// cannot be written).
pub fn run(
    model: &mut Model,
    integrator: &mut dyn Integrator,
    state: &mut State,
    config: &RunConfig,
    observer: &mut dyn Observer,
) -> std::io::Result<RunSummary> {
    let mut metrics = Metrics::default();
    let start = std::time::Instant::now();
    let dt = config.dt;
    let mut summary = RunSummary {
        method: integrator.name().to_owned(),
        dt,
        steps_requested: config.steps,
        steps_completed: 0,
        final_time: state.t,
        outcome: Outcome::Completed,
        initial_energy: Energies::default(),
        final_energy: None,
        energy_drift_max: 0.0,
        energy_drift_final: 0.0,
        step_seconds_median: 0.0,
        step_seconds_p95: 0.0,
        totals: StepReport::default(),
    };
    let initial = match metrics.energies(model, state) {
        Ok(e) => e,
        Err(e) => {
            summary.outcome = Outcome::Failed {
                step: 0,
                t: state.t,
                cause: "model error".into(),
                message: e.to_string(),
            };
            return Ok(summary);
        }
    };
    summary.initial_energy = initial;
    let mut since_row = StepReport::default();
    let mut steps_since_row = 0u64;
    let mut step_seconds = Vec::with_capacity(config.steps.min(1 << 20));
    let momenta = metrics.momenta(model, state);
    let no_work = RowWork {
        report: &StepReport::default(),
        steps: 0,
        dt,
        elapsed: 0.0,
    };
    observer.sample(&sample(0, state, &initial, momenta, no_work))?;
    observer.after_step(0, model, state)?;

    let drift_scale = |e: &Energies| {
        let work = (initial.gravity - e.gravity).abs();
        let s = initial.internal() + work;
        if s > 0.0 { s } else { 1.0 }
    };
    let time_dependent = !model.vertex_potentials().is_empty();
    let mut driven_work = 0.0;
    for step in 1..=config.steps {
        if let Some(signal) = crate::interrupt::requested() {
            summary.outcome = Outcome::Interrupted {
                step: step - 1,
                signal: signal.name().into(),
            };
            break;
        }
        if time_dependent {
            let before = model.vertex_energy_at(&state.q, state.t);
            let after = model.vertex_energy_at(&state.q, state.t + dt);
            if let (Ok(b), Ok(a)) = (before, after) {
                driven_work += a - b;
            }
        }
        match integrator.step(model, state, dt) {
            Ok(report) => {
                step_seconds.push(report.times.total);
                add_work(&mut since_row, &report);
                add_work(&mut summary.totals, &report);
                steps_since_row += 1;
                summary.steps_completed = step;
                summary.final_time = state.t;
                observer.after_step(step, model, state)?;
            }
            Err(e) => {
                summary.outcome = Outcome::Failed {
                    step,
                    t: state.t + dt,
                    cause: e.cause().into(),
                    message: e.to_string(),
                };
                break;
            }
        }
        if step % config.sample_every != 0 && step != config.steps {
            continue;
        }
        let energies = match metrics.energies(model, state) {
            Ok(e) => e,
            Err(e) => {
                let cause = crate::integrate::StepError::from(e);
                summary.outcome = Outcome::Failed {
                    step,
                    t: state.t,
                    cause: cause.cause().into(),
                    message: cause.to_string(),
                };
                break;
            }
        };
        let momenta = metrics.momenta(model, state);
        let work = RowWork {
            report: &since_row,
            steps: steps_since_row,
            dt,
            elapsed: start.elapsed().as_secs_f64(),
        };
        observer.sample(&sample(step, state, &energies, momenta, work))?;
        since_row = StepReport::default();
        steps_since_row = 0;
        let drift = (energies.total() - initial.total()).abs() / drift_scale(&energies);
        summary.energy_drift_max = summary.energy_drift_max.max(drift);
        summary.energy_drift_final = drift;
        summary.final_energy = Some(energies);
        // Blow-up: internal energy beyond the limit times what it could legitimately be.
        let gravity_work = (initial.gravity - energies.gravity).max(0.0);
        let work = gravity_work + driven_work.max(0.0);
        let allowed = config.energy_limit * (initial.internal() + work);
        let floor = 1e-12 * (1.0 + initial.internal().abs() + initial.gravity.abs());
        if config.energy_limit > 0.0
            && (!energies.total().is_finite() || energies.internal() > allowed + floor)
        {
            summary.outcome = Outcome::Failed {
                step,
                t: state.t,
                cause: "energy growth".into(),
                message: format!(
                    "kinetic + elastic energy {:.4e} J exceeds {} x (initial {:.4e} J + work done on the body {:.4e} J)",
                    energies.internal(),
                    config.energy_limit,
                    initial.internal(),
                    work
                ),
            };
            break;
        }
    }
    step_seconds.sort_by(f64::total_cmp);
    summary.step_seconds_median = percentile(&step_seconds, 0.5);
    summary.step_seconds_p95 = percentile(&step_seconds, 0.95);
    Ok(summary)
}
