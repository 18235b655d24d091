//! The run loop: step a scene, sample its state, and stop at the first sign of blow-up.
//!
//! A run ends early at the first step that cannot be taken (non-finite state, inverted
//! element, Newton or solver failure: see [`softbench_core::integrate::StepError`]) or, after any step,
//! when the energy balance sees a blow-up ([`super::balance`]): the energy gained beyond the
//! work done on the body passed `energy_limit` times the energy the body holds or exchanges
//! and is still growing. A run that took every step is judged once more at its end (energy
//! gained and kept, or sustained exponential growth). The rows written before are valid
//! states; the [`Outcome`] says where and why the run ended, in the vocabulary of
//! [`OutcomeKind`].

use super::balance::{EnergyBalance, EnergyScale, Violation};
use super::growth::GrowthFit;
use super::metrics::{Energies, Metrics};
use super::outcome::{Outcome, OutcomeKind};
use crate::scene::RunConfig;
use softbench_core::integrate::{Integrator, State, StepReport};
use softbench_core::model::Model;

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
    /// The contact barrier's energy (incremental potential contact; J).
    pub contact_energy: f64,
    /// Angular momentum about the origin (kg m^2/s).
    pub angular_momentum_x: f64,
    pub angular_momentum_y: f64,
    pub angular_momentum_z: f64,
    /// Steps since the previous row.
    pub steps: u64,
    pub substeps: u64,
    pub rejected_substeps: u64,
    /// Rejected internal steps whose attempt failed (Newton, linear solve, inversion) rather
    /// than missed the error tolerance.
    pub failed_substeps: u64,
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
    /// Incremental potential contact since the previous row: the smallest distance between
    /// contact primitives after any step (m; empty without it), the largest barrier
    /// stiffness (J), the collision-detection queries and the Newton steps they shortened.
    pub min_distance: Option<f64>,
    pub barrier_stiffness: f64,
    pub ccd_queries: u64,
    pub ccd_limited_steps: u64,
    /// 1 if the sampled frame is free of intersections by an exact test independent of the
    /// contact response (surface self-intersection, surface against obstacle meshes and
    /// boxes, vertices inside analytic obstacles), 0 if not; empty for scenes without contact.
    pub intersection_free: Option<u8>,
    /// Entries of the largest sparse factor built since the previous row (nnz(L)).
    pub factor_nnz: u64,
    /// Predicted flops of that factorization.
    pub factor_flops: f64,
    /// Steps since the previous row whose Newton solve stopped unconverged.
    pub newton_unconverged_steps: u64,
    /// Net work done on the body by time-dependent potentials since the start (J).
    pub driven_work: f64,
    /// Energy removed by damping since the start (J).
    pub dissipated: f64,
    /// The energy balance's excess `total - total(0) - driven_work + dissipated` (J): zero for
    /// an exact method, growing without bound for an unstable one.
    pub energy_excess: f64,
    /// What the excess is judged against: the energy the body holds or exchanges so far (J;
    /// see [`EnergyScale`]).
    pub energy_scale: f64,
    /// Local-solver iterations since the previous row (VBD sweeps, projective-dynamics
    /// local/global iterations, XPBD constraint sweeps).
    pub local_iterations: u64,
    /// The largest Chebyshev spectral radius ρ used by a step since the previous row (0
    /// without Chebyshev acceleration).
    pub chebyshev_rho: f64,
    /// Rejected Anderson iterates (history restarts) since the previous row.
    pub anderson_fallbacks: u64,
    /// Symbolic analyses since the previous row.
    pub symbolic_analyses: u64,
    /// AMG hierarchy (CG's preconditioner) since the previous row: the largest operator and
    /// grid complexities, full builds and value-only reuses (0 without AMG).
    pub amg_operator_complexity: f64,
    pub amg_grid_complexity: f64,
    pub amg_builds: u64,
    pub amg_reuses: u64,
    /// Of the reuses, those that kept the coarse operators.
    pub amg_lagged: u64,
    /// Wall time of force and energy evaluations outside assembly since the previous row (s).
    pub force_seconds: f64,
    /// Consistent-mass solves `M^{-1} f` since the previous row, and their wall time (s).
    pub mass_solves: u64,
    pub mass_solve_seconds: f64,
    /// The adaptive controller's accepted internal steps since the previous row (s): smallest,
    /// median and largest; empty for fixed-step methods and rows without steps.
    pub internal_dt_min: Option<f64>,
    pub internal_dt_median: Option<f64>,
    pub internal_dt_max: Option<f64>,
    /// Element matrices the Hessian filter changed since the previous row (summed over
    /// every assembly; see `integrator.newton.filter`).
    pub projected_elements: u64,
}

/// Smallest, median and largest of a set of step sizes (s).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct StepSizes {
    pub min: f64,
    pub median: f64,
    pub max: f64,
}

impl StepSizes {
    /// The range of `steps` (sorted in place), or `None` when empty. The median of an even
    /// count is the mean of the two middle values.
    pub fn of(steps: &mut [f64]) -> Option<Self> {
        if steps.is_empty() {
            return None;
        }
        steps.sort_by(f64::total_cmp);
        let n = steps.len();
        let median = if n % 2 == 1 {
            steps[n / 2]
        } else {
            0.5 * (steps[n / 2 - 1] + steps[n / 2])
        };
        Some(Self {
            min: steps[0],
            median,
            max: steps[n - 1],
        })
    }
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

    /// The Newton iteration records of step `step` (only with
    /// `integrator.newton.log_iterations`; a failed step's too). Default: nothing.
    fn newton_iterations(
        &mut self,
        _step: usize,
        _records: &[softbench_core::integrate::newton::IterationRecord],
    ) -> std::io::Result<()> {
        Ok(())
    }
}

impl<F: FnMut(&Sample) -> std::io::Result<()>> Observer for F {
    fn sample(&mut self, sample: &Sample) -> std::io::Result<()> {
        self(sample)
    }
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
    /// Energy drift: the largest `|excess| / scale` after any step, with the energy balance's
    /// excess `H - H(0) - W_driven + W_damping` and scale (the energy the body holds or
    /// exchanges so far, [`EnergyScale`]). The energy a method gained or lost beyond the work
    /// done on the body and the energy damping removed, relative to the energy at stake: 0 for
    /// an exact method whatever its damping, drags or fall, so it measures the method alone.
    /// Equal to `|energy_excess_peak|`; the peak's sign says gained or lost.
    pub energy_drift_max: f64,
    /// The same after the last step taken.
    pub energy_drift_final: f64,
    /// The energy the body held or exchanged by the end, which the excess is judged against
    /// (J; see [`EnergyScale`]).
    pub energy_scale: EnergyScale,
    /// The blow-up limit: an excess above this many scales that is still growing is a blow-up
    /// (0: the check is off).
    pub energy_limit: f64,
    /// The excess over the scale of largest magnitude of any step, signed: positive when
    /// energy was gained, negative when it was lost.
    pub energy_excess_peak: f64,
    /// The exponential fitted to the excess over the last half of the run (see
    /// [`super::growth`]): its rate, fit and growth; `None` for runs of fewer than two steps.
    pub energy_growth: Option<GrowthFit>,
    /// Net work of time-dependent potentials and energy removed by damping (J).
    pub driven_work: f64,
    pub dissipated: f64,
    /// Steps whose Newton solve stopped unconverged at the iteration cap.
    pub newton_unconverged_steps: u64,
    /// The most elastic tets with `det F <= 0` in any state of the run (the initial one and
    /// after every step taken): a run can complete with inverted elements, which this says.
    pub inverted_elements_max: usize,
    /// The adaptive controller's accepted internal steps over the whole run (`None` for
    /// fixed-step methods).
    pub internal_dt: Option<StepSizes>,
    /// Wall time of the first step (s): it includes the one-time setup (ordering, symbolic
    /// analysis, AMG hierarchy, colouring), so it is reported apart from the rest.
    pub first_step_seconds: f64,
    /// Median, quartiles and 95th percentile of the wall time per step after the first (of
    /// the first, for a run of one step) (s): the steady cost and its spread.
    pub step_seconds_median: f64,
    pub step_seconds_q1: f64,
    pub step_seconds_q3: f64,
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
    unconverged_steps: u64,
    dt: f64,
    elapsed: f64,
    internal_dt: Option<StepSizes>,
}

fn sample(
    step: usize,
    state: &State,
    energies: &Energies,
    (p, l): ([f64; 3], [f64; 3]),
    w: RowWork,
    balance: &EnergyBalance,
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
        contact_energy: energies.contact,
        angular_momentum_x: l[0],
        angular_momentum_y: l[1],
        angular_momentum_z: l[2],
        steps: w.steps,
        substeps: work.substeps.into(),
        rejected_substeps: work.rejected_substeps.into(),
        failed_substeps: work.failed_substeps.into(),
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
        min_distance: work.min_distance,
        barrier_stiffness: work.barrier_stiffness,
        ccd_queries: work.ccd_queries,
        ccd_limited_steps: work.filtered_steps.into(),
        intersection_free: None,
        factor_nnz: work.factor_nnz as u64,
        factor_flops: work.factor_flops,
        newton_unconverged_steps: w.unconverged_steps,
        driven_work: balance.driven_work(),
        dissipated: balance.dissipated(),
        energy_excess: balance.excess(energies.total()),
        energy_scale: balance.scale().total(),
        local_iterations: work.local_iterations.into(),
        chebyshev_rho: work.chebyshev_rho,
        anderson_fallbacks: work.anderson_fallbacks.into(),
        symbolic_analyses: work.symbolic_analyses.into(),
        amg_operator_complexity: work.amg_operator_complexity,
        amg_grid_complexity: work.amg_grid_complexity,
        amg_builds: work.amg_builds.into(),
        amg_reuses: work.amg_reuses.into(),
        amg_lagged: work.amg_lagged.into(),
        force_seconds: work.times.forces,
        mass_solves: work.mass_solves.into(),
        mass_solve_seconds: work.times.mass_solve,
        internal_dt_min: w.internal_dt.map(|s| s.min),
        internal_dt_median: w.internal_dt.map(|s| s.median),
        internal_dt_max: w.internal_dt.map(|s| s.max),
        projected_elements: work.projected_elements,
    }
}

/// The outcome of a run the energy balance calls a blow-up after `step`.
fn unstable(step: usize, t: f64, v: &Violation, limit: f64) -> Outcome {
    Outcome::ended(OutcomeKind::Unstable, step, t, v.cause(), v.message(limit))
}

/// The outcome of a run whose cost after `step` (of `config.steps`) passed a limit of its
/// budget, if it did.
fn over_budget(config: &RunConfig, spent: &StepReport, step: usize, t: f64) -> Option<Outcome> {
    let (key, limit, used) = config.budget?.exceeded(|key| spent_on(spent, key))?;
    Some(Outcome::ended(
        OutcomeKind::HorizonNotReached,
        step,
        t,
        "budget",
        format!(
            "run.budget.{key} = {limit} was passed after step {step} of {} ({used} spent); a \
             larger budget lets the run go on",
            config.steps
        ),
    ))
}

/// What a run has spent of the budget's `key` (see [`crate::scene::CostBudget::limits`]).
pub fn spent_on(spent: &StepReport, key: &str) -> f64 {
    match key {
        "wall_seconds" => spent.times.total,
        "evaluations" => (spent.evaluations.gradient + spent.evaluations.hessian) as f64,
        "factorizations" => f64::from(spent.factorizations),
        "linear_iterations" => spent.linear_iterations as f64,
        _ => 0.0,
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
/// every `config.sample_every` steps (and the last), and every state with `after_step`. The
/// energy balance is checked after every step, sampled or not. Returns how the run ended; an
/// error only when the observer fails (e.g. the output file cannot be written).
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
        outcome: Outcome::completed(),
        initial_energy: Energies::default(),
        final_energy: None,
        energy_drift_max: 0.0,
        energy_drift_final: 0.0,
        energy_scale: EnergyScale::default(),
        energy_limit: config.energy_limit,
        energy_excess_peak: 0.0,
        energy_growth: None,
        driven_work: 0.0,
        dissipated: 0.0,
        newton_unconverged_steps: 0,
        inverted_elements_max: 0,
        internal_dt: None,
        first_step_seconds: 0.0,
        step_seconds_median: 0.0,
        step_seconds_q1: 0.0,
        step_seconds_q3: 0.0,
        step_seconds_p95: 0.0,
        totals: StepReport::default(),
    };
    let model_error = |step: usize, t: f64, e: softbench_core::model::ModelError| {
        Outcome::of_step_error(step, t, &softbench_core::integrate::StepError::from(e))
    };
    let initial = match metrics.energies(model, state) {
        Ok(e) => e,
        Err(e) => {
            summary.outcome = model_error(0, state.t, e);
            return Ok(summary);
        }
    };
    summary.initial_energy = initial;
    summary.inverted_elements_max = model.inverted_elements(&state.q).unwrap_or(0);
    let scale = match EnergyScale::of(model, &initial) {
        Ok(s) => s,
        Err(e) => {
            summary.outcome = model_error(0, state.t, e);
            return Ok(summary);
        }
    };
    summary.energy_scale = scale;
    // A start whose energy is already not finite (an input that overflows) is never run.
    if let Some((what, value)) = [
        ("the initial energy", initial.total()),
        ("the initial kinetic energy", initial.kinetic),
        ("the energy the body holds at the start", scale.total()),
    ]
    .into_iter()
    .find(|(_, x)| !x.is_finite())
    {
        let v = Violation::NonFinite { what, value };
        summary.outcome = unstable(0, state.t, &v, config.energy_limit);
        return Ok(summary);
    }
    let mut balance = EnergyBalance::new(model, &initial, scale, config.energy_limit);
    let mut since_row = StepReport::default();
    let mut steps_since_row = 0u64;
    let mut unconverged_since_row = 0u64;
    let mut step_seconds = Vec::with_capacity(config.steps.min(1 << 20));
    // Adaptive methods' accepted internal steps: since the last row, and over the run.
    let mut row_dts: Vec<f64> = Vec::new();
    let mut run_dts: Vec<f64> = Vec::new();
    let mut iteration_records = Vec::new();
    let momenta = metrics.momenta(model, state);
    let no_work = RowWork {
        report: &StepReport::default(),
        steps: 0,
        unconverged_steps: 0,
        dt,
        elapsed: 0.0,
        internal_dt: None,
    };
    let mut row = sample(0, state, &initial, momenta, no_work, &balance);
    row.intersection_free = integrator.intersection_free(model, state).map(u8::from);
    observer.sample(&row)?;
    observer.after_step(0, model, state)?;

    // A budget passed before the horizon: the run stops after the step's row is written. Inside
    // a step, an adaptive method's internal steps ask the guard (see `cost_guard`).
    let mut stopped: Option<Outcome> = None;
    let _guard = config.budget.map(|b| {
        let c = model.counters();
        softbench_core::integrate::cost_guard::arm(
            b.wall_seconds,
            b.evaluations,
            b.factorizations,
            b.linear_iterations,
            c.gradient + c.hessian,
        )
    });
    for step in 1..=config.steps {
        if let Some(signal) = softbench_core::interrupt::requested() {
            summary.outcome = Outcome::ended(
                OutcomeKind::Interrupted,
                step - 1,
                state.t,
                "interrupted",
                format!("stopped by {} after step {}", signal.name(), step - 1),
            );
            break;
        }
        balance.before_step(model, state, dt);
        softbench_core::integrate::cost_guard::before_step(
            summary.totals.factorizations.into(),
            summary.totals.linear_iterations,
        );
        let stepped = integrator.step(model, state, dt);
        integrator.drain_iteration_log(&mut iteration_records);
        if !iteration_records.is_empty() {
            observer.newton_iterations(step, &iteration_records)?;
            iteration_records.clear();
        }
        match stepped {
            Ok(report) => {
                step_seconds.push(report.times.total);
                row_dts.extend_from_slice(integrator.internal_steps());
                run_dts.extend_from_slice(integrator.internal_steps());
                add_work(&mut since_row, &report);
                add_work(&mut summary.totals, &report);
                steps_since_row += 1;
                if report.newton_unconverged > 0 {
                    unconverged_since_row += 1;
                    summary.newton_unconverged_steps += 1;
                }
                summary.steps_completed = step;
                summary.final_time = state.t;
                if let Ok(n) = model.inverted_elements(&state.q) {
                    summary.inverted_elements_max = summary.inverted_elements_max.max(n);
                }
                observer.after_step(step, model, state)?;
                if step < config.steps
                    && let Some(over) = over_budget(config, &summary.totals, step, state.t)
                {
                    stopped = Some(over);
                }
            }
            Err(softbench_core::integrate::StepError::Interrupted(signal)) => {
                summary.outcome = Outcome::ended(
                    OutcomeKind::Interrupted,
                    step - 1,
                    state.t,
                    "interrupted",
                    format!(
                        "stopped by {} during step {step}, after step {}",
                        signal.name(),
                        step - 1
                    ),
                );
                break;
            }
            Err(e) => {
                summary.outcome = Outcome::of_step_error(step, state.t + dt, &e);
                break;
            }
        }
        let energies = match metrics.energies(model, state) {
            Ok(e) => e,
            Err(e) => {
                summary.outcome = model_error(step, state.t, e);
                break;
            }
        };
        let verdict = balance.after_step(model, state, dt, &energies);
        let sampled = step % config.sample_every == 0 || step == config.steps;
        if sampled || verdict.is_err() || stopped.is_some() {
            let momenta = metrics.momenta(model, state);
            let work = RowWork {
                report: &since_row,
                steps: steps_since_row,
                unconverged_steps: unconverged_since_row,
                dt,
                elapsed: start.elapsed().as_secs_f64(),
                internal_dt: StepSizes::of(&mut row_dts),
            };
            let mut row = sample(step, state, &energies, momenta, work, &balance);
            row.intersection_free = integrator.intersection_free(model, state).map(u8::from);
            observer.sample(&row)?;
            since_row = StepReport::default();
            row_dts.clear();
            steps_since_row = 0;
            unconverged_since_row = 0;
            summary.final_energy = Some(energies);
        }
        if let Err(v) = verdict {
            summary.outcome = unstable(step, state.t, &v, config.energy_limit);
            break;
        }
        if let Some(over) = stopped.take() {
            summary.outcome = over;
            break;
        }
    }
    if summary.outcome.is_completed()
        && let Err(v) = balance.finish()
    {
        summary.outcome = unstable(summary.steps_completed, state.t, &v, config.energy_limit);
    }
    summary.energy_excess_peak = balance.peak();
    // The drift is the balance's own ratio, unsigned (see the field docs).
    summary.energy_drift_max = balance.peak().abs();
    summary.energy_drift_final = balance.latest().abs();
    summary.energy_scale = balance.scale();
    summary.energy_growth = balance.growth();
    summary.driven_work = balance.driven_work();
    summary.dissipated = balance.dissipated();
    summary.internal_dt = StepSizes::of(&mut run_dts);
    summary.first_step_seconds = step_seconds.first().copied().unwrap_or(0.0);
    // The steady steps: all but the first, unless there is only one.
    let steady = if step_seconds.len() > 1 {
        &mut step_seconds[1..]
    } else {
        &mut step_seconds[..]
    };
    steady.sort_by(f64::total_cmp);
    summary.step_seconds_median = percentile(steady, 0.5);
    summary.step_seconds_q1 = percentile(steady, 0.25);
    summary.step_seconds_q3 = percentile(steady, 0.75);
    summary.step_seconds_p95 = percentile(steady, 0.95);
    Ok(summary)
}
