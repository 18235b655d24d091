//! Work-precision runs: the error of a run against a reference solution at fixed sample
//! times, next to its wall time and hardware-independent cost.
//!
//! The position error at a sample time is `|x - x_ref|` over the free DOFs, relative to the
//! reference's largest displacement `max_k |x_ref(t_k) - X|` from the rest positions X (so the
//! error is relative to how far the body moves, not to where it happens to sit), and a run's
//! error is the largest over the sample times. The energy error is
//! `|E - E_ref|` over the largest kinetic + stored energy of the reference. The reference is
//! computed twice, at its step and at half of it; their difference is the reference's own
//! accuracy, and errors below `floor_factor` times it are not scored.

use super::config::{StudyFile, WorkPrecisionSettings};
use super::context::Context;
use super::error::StudyError;
use super::format::{cell, short};
use super::grid::Axis;
use super::identity::float;
use super::kind::{KindSpec, References, no_quick_check, number, run_steps};
use super::measured::{
    Measured, build, cap_cells, outcome_of, picture_surface, run_observed, summary_cells,
};
use super::plots::{self, Emit, SceneRows};
use super::spec::RunSpec;
use super::spec::Study;
use super::table::Table;
use crate::integrate::{Method, State};
use crate::model::Model;
use crate::parallel::Parallelism;
use crate::plot::{Chart, PlotError};
use crate::run::{Energies, Observer, RunSummary, Sample};
use crate::scene::SceneConfig;
use crate::scene::{RunConfig, Scene};
use std::fmt::Write;

/// Columns of a work-precision study's `runs.csv` after the run's identity.
pub const COLUMNS: &[&str] = &[
    "dt",
    "outcome",
    "error",
    "error_l2",
    "energy_error",
    "wall_seconds",
    "force_evaluations",
    "hessian_evaluations",
    "factorizations",
    "symbolic_analyses",
    "linear_iterations",
    "newton_iterations",
    "local_iterations_per_step",
    "substeps",
    "scored",
    "error_unscored",
    "reference_method",
    "reference_dt",
    "reference_difference",
    "step_seconds_median",
    "step_seconds_p95",
    "steps",
    "energy_drift_max",
    "newton_unconverged_steps",
    "newton_max_iterations",
    "newton_required",
    "assemble_seconds",
    "factor_seconds",
    "solve_seconds",
    "qp_seconds",
    "force_seconds",
    "mass_solves",
    "mass_solve_seconds",
    "internal_dt_min",
    "internal_dt_median",
    "internal_dt_max",
];

/// What the rest of the study code asks of a work-precision study.
pub(super) const SPEC: KindSpec = KindSpec {
    columns: COLUMNS,
    summary_columns: &[
        "dt",
        "outcome",
        "error",
        "energy_error",
        "wall_seconds",
        "force_evaluations",
        "hessian_evaluations",
        "factorizations",
        "linear_iterations",
        "newton_unconverged_steps",
    ],
    sweep_metrics: &["error", "wall_seconds"],
    progress: |m| number(m, "error").map(|e| format!(", error {e}")),
    settings_json: |file| serde_json::to_value(&file.work_precision).unwrap_or_default(),
    quick_notice: "the horizon and the dt ladders are shortened",
    report_settings,
    report_findings: orders,
    check,
    check_quick: no_quick_check,
    quick_axes,
    configure,
    estimated_steps: run_steps,
    needs_omega: |file| {
        file.work_precision
            .as_ref()
            .is_some_and(|w| w.reference.method.is_none() && !w.reference.same_dt)
    },
    references: Some(References {
        settings: |file| file.work_precision.clone(),
        dt: reference_dt,
        optional: false,
    }),
    measure: |study, spec, shared, parallelism| {
        let settings = study.file.work_precision.as_ref().expect("checked at load");
        let reference = shared.reference.ok_or("no reference solution")?;
        measure(spec, settings, reference, parallelism)
    },
    scene_charts,
    // No time histories: its runs differ only in accuracy.
    energy_caption: None,
    by_time_step: false,
    picture_rows: super::pictures::PictureRows::LeastAccuratePerLine,
    phases_at_smallest_dt: true,
    phase_dt_columns: &["dt"],
};

/// Error against wall time, time per step, cost and dt (and local-solver iterations where
/// there are any), one line per method.
fn scene_charts(s: &SceneRows, emit: &mut Emit) -> Result<(), PlotError> {
    let iterative = s.rows.iter().any(|r| {
        s.runs
            .number(r, "local_iterations_per_step")
            .is_some_and(|n| n > 0.0)
    });
    // One step for every run: error against dt would be a vertical line of points.
    let mut dts = s.rows.iter().filter_map(|r| s.runs.number(r, "dt"));
    let first = dts.next();
    let one_dt = dts.all(|dt| Some(dt) == first);
    for (x, x_label, what) in [
        ("wall_seconds", "wall time (s)", "time"),
        (
            "step_seconds_median",
            "median wall time per step (s)",
            "step-time",
        ),
        ("cost", "force + Hessian evaluations", "cost"),
        ("dt", "time step dt (s)", "dt"),
        (
            "local_iterations_per_step",
            "local-solver iterations per step",
            "iterations",
        ),
    ] {
        if what == "iterations" && !iterative {
            continue;
        }
        if what == "dt" && one_dt {
            continue;
        }
        emit(
            format!("work-precision-{what}-{}", s.slug),
            &format!(
                "Position error against the reference versus {x_label} (log-log), one line per \
                 method; unscored and failed runs are left out."
            ),
            Chart::Line(plots::work_precision_chart(
                s.scene, s.runs, s.params, s.rows, x, x_label,
            )),
        )?;
    }
    Ok(())
}

/// The `[work-precision]` table is present and sane, and the study sweeps dt.
fn check(
    file: &StudyFile,
    ctx: &Context,
    bad: &dyn Fn(&str, String) -> StudyError,
) -> Result<(), StudyError> {
    let Some(w) = &file.work_precision else {
        return Err(ctx.invalid(
            0,
            "work-precision",
            "a work-precision study needs a [work-precision] table with `horizon`",
        ));
    };
    if !(w.horizon.is_finite() && w.horizon > 0.0) {
        return Err(bad(
            "work-precision.horizon",
            format!("must be > 0 s (got {})", w.horizon),
        ));
    }
    if w.samples == 0 {
        return Err(bad("work-precision.samples", "must be at least 1".into()));
    }
    super::settings::check_reference(&w.reference, "work-precision", &bad)?;
    if !file.grid.contains_key("run.dt")
        && !file
            .methods
            .iter()
            .any(|m| m.get_ref().contains_key("run.dt"))
    {
        return Err(ctx.invalid(
            0,
            "grid",
            "a work-precision study sweeps the time step: add \"run.dt\" = [..] to [grid]",
        ));
    }
    Ok(())
}

/// `[quick]` shortens the `[work-precision]` table's horizon (whatever the kind, as the table
/// is written to meta.json as resolved).
pub(super) fn quick_table(file: &mut StudyFile) {
    if let Some(w) = file.work_precision.as_mut() {
        w.horizon = file.quick.horizon.unwrap_or(w.horizon);
    }
}

/// Quick mode keeps the largest steps of each ladder (the global one and each method's own).
fn quick_axes(file: &StudyFile, method_axes: &mut [Vec<Axis>]) {
    let keep = file.quick.dts.unwrap_or(2).max(1);
    for axis in method_axes
        .iter_mut()
        .flatten()
        .filter(|a| a.key == "run.dt")
    {
        axis.values.sort_by(|a, b| float(b).total_cmp(&float(a)));
        axis.values.truncate(keep);
    }
}

/// A run covers the horizon in whole sample intervals, with rows at every sample time.
fn configure(
    ctx: &Context,
    file: &StudyFile,
    config: &mut SceneConfig,
    axes: &[Axis],
    _quick: bool,
) -> Result<(), StudyError> {
    // It judges methods, so by default an unconverged Newton solve fails the step instead of
    // being accepted.
    if file
        .work_precision
        .as_ref()
        .is_some_and(|w| w.require_newton_convergence)
    {
        config.integrator.newton.require_convergence = true;
    }
    check_step_fits(ctx, file, config, axes)?;
    let w = file.work_precision.as_ref().expect("checked");
    let stride = (w.horizon / w.samples as f64 / config.run.dt).round() as usize;
    config.run.steps = stride * w.samples;
    // Rows at every sample time, and in between as densely as 500 rows allow.
    config.run.sample_every = (1..=stride)
        .find(|d| stride.is_multiple_of(*d) && config.run.steps / d <= 500)
        .unwrap_or(stride);
    Ok(())
}

/// The reference step for the physics of `spec`: as set, or the smallest dt of the grid over
/// `dt_factor`.
fn reference_dt(study: &Study, w: &WorkPrecisionSettings, spec: &RunSpec) -> f64 {
    if w.reference.same_dt {
        return spec.loaded.config.run.dt;
    }
    w.reference.dt.unwrap_or_else(|| {
        let smallest = study
            .runs
            .iter()
            .filter(|r| r.physics == spec.physics)
            .map(|r| r.loaded.config.run.dt)
            .fold(f64::INFINITY, f64::min);
        smallest / w.reference.dt_factor
    })
}

/// Which reference a run is scored against: one per physics, or with `same_dt` one per
/// physics and time step.
pub(super) fn reference_key(w: &WorkPrecisionSettings, spec: &RunSpec) -> u64 {
    if !w.reference.same_dt {
        return spec.physics;
    }
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    (spec.physics, spec.loaded.config.run.dt.to_bits()).hash(&mut h);
    h.finish()
}

/// A work-precision run's horizon and sample times must be whole numbers of its steps.
fn check_step_fits(
    ctx: &Context,
    file: &StudyFile,
    config: &SceneConfig,
    axes: &[Axis],
) -> Result<(), StudyError> {
    let w = file.work_precision.as_ref().expect("checked");
    let dt = config.run.dt;
    let interval = w.horizon / w.samples as f64;
    let per_sample = interval / dt;
    if (per_sample - per_sample.round()).abs() > 1e-6 * per_sample.max(1.0) || per_sample < 0.5 {
        let line = axes
            .iter()
            .find(|a| a.key == "run.dt")
            .map_or(1, |a| a.line);
        return Err(StudyError::Invalid {
            path: ctx.path.to_owned(),
            line,
            key: "grid.\"run.dt\"".into(),
            message: format!(
                "dt = {dt} s does not divide the sample interval horizon / samples = {interval} s; \
                 errors are measured at whole steps, so choose dt values that divide it"
            ),
        });
    }
    Ok(())
}

/// The state at each sample time.
#[derive(Clone, Debug)]
struct Snapshots {
    q: Vec<Vec<f64>>,
    energies: Vec<Energies>,
}

/// A reference solution at the sample times, and how well it is resolved.
#[derive(Clone, Debug)]
pub struct Reference {
    pub method: Method,
    pub dt: f64,
    /// Whether it runs at the runs' own dt (and `difference` is the one from a second
    /// reference at a tighter Newton tolerance, not at half the step).
    pub same_dt: bool,
    snapshots: Snapshots,
    rest: Vec<f64>,
    /// Position error of the reference at `dt` against the one at `dt / 2`.
    pub difference: f64,
    pub energy_difference: f64,
    /// Wall time of both reference runs (s).
    pub wall_seconds: f64,
    /// The sample times (s).
    times: Vec<f64>,
    /// Errors below `floor_factor * difference` are not scored.
    floor_factor: f64,
}

impl Reference {
    /// The sample times (s): `horizon k / samples`, k = 1..samples.
    pub fn times(&self) -> &[f64] {
        &self.times
    }

    /// Errors below this factor times `difference` are not scored.
    pub fn floor_factor(&self) -> f64 {
        self.floor_factor
    }

    /// Errors at or below this are within the reference's own accuracy.
    pub fn floor(&self) -> f64 {
        self.floor_factor * self.difference
    }

    /// Relative L2 position error over all sample times:
    /// `sqrt(sum_k |x_k - x_ref(t_k)|^2) / sqrt(sum_k |x_ref(t_k) - X|^2)` with X the rest
    /// positions, so it is relative to how far the body moves. `None` unless `positions`
    /// holds every sample time.
    pub fn relative_l2_error(&self, positions: &[Vec<f64>]) -> Option<f64> {
        let reference = &self.snapshots.q;
        if positions.len() != reference.len() || reference.is_empty() {
            return None;
        }
        let squared =
            |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>();
        let error: f64 = positions
            .iter()
            .zip(reference)
            .map(|(x, r)| squared(x, r))
            .sum();
        let motion: f64 = reference.iter().map(|r| squared(r, &self.rest)).sum();
        Some(error.sqrt() / motion.sqrt().max(f64::MIN_POSITIVE))
    }
}

/// Records rows, and the state and energies every `stride` steps.
struct SampleObserver {
    stride: usize,
    rows: Vec<Sample>,
    snapshots: Snapshots,
}

impl Observer for SampleObserver {
    fn sample(&mut self, sample: &Sample) -> std::io::Result<()> {
        self.rows.push(sample.clone());
        Ok(())
    }

    fn after_step(&mut self, step: usize, _: &Model, state: &State) -> std::io::Result<()> {
        if step > 0 && step.is_multiple_of(self.stride) {
            self.snapshots.q.push(state.q.clone());
        }
        Ok(())
    }
}

/// Run `scene` and keep the state at every multiple of `stride` steps (and, with a
/// `surface`, the snapshots its pictures are drawn from).
fn sampled_run(
    scene: &mut Scene,
    run: &RunConfig,
    stride: usize,
    surface: Option<crate::render::Surface>,
) -> (
    RunSummary,
    Vec<Sample>,
    Snapshots,
    Option<crate::render::Snapshots>,
) {
    let mut observer = SampleObserver {
        stride,
        rows: Vec::new(),
        snapshots: Snapshots {
            q: Vec::new(),
            energies: Vec::new(),
        },
    };
    let (summary, _, pictures) = run_observed(scene, run, surface, &mut observer);
    // Rows exist at every sample time (sample_every divides the stride): their energies are
    // the sample energies.
    observer.snapshots.energies = observer
        .rows
        .iter()
        .filter(|r| r.step > 0 && r.step % stride == 0)
        .map(|r| Energies {
            kinetic: r.kinetic,
            elastic: r.elastic,
            springs: r.springs,
            gravity: r.gravity,
            external: r.external,
        })
        .collect();
    (summary, observer.rows, observer.snapshots, pictures)
}

/// Largest relative position error and energy error of `run` against `reference` over the
/// sample times both reached; `None` if `run` reached none.
fn errors(run: &Snapshots, reference: &Snapshots, rest: &[f64]) -> Option<(f64, f64)> {
    let n = run.q.len().min(reference.q.len());
    if n == 0 || run.q.len() < reference.q.len() {
        return None;
    }
    let energy_scale = reference
        .energies
        .iter()
        .map(Energies::internal)
        .fold(0.0f64, f64::max)
        .max(f64::MIN_POSITIVE);
    let distance = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y) * (x - y))
            .sum::<f64>()
            .sqrt()
    };
    // Relative to the largest displacement of the reference, so an early sample time with
    // a tiny displacement does not dominate.
    let displacement = reference
        .q
        .iter()
        .map(|r| distance(r, rest))
        .fold(0.0f64, f64::max)
        .max(f64::MIN_POSITIVE);
    let mut position = 0.0f64;
    let mut energy = 0.0f64;
    for k in 0..n {
        position = position.max(distance(&run.q[k], &reference.q[k]) / displacement);
        if let (Some(e), Some(er)) = (run.energies.get(k), reference.energies.get(k)) {
            energy = energy.max((e.total() - er.total()).abs() / energy_scale);
        }
    }
    Some((position, energy))
}

/// Steps between sample times at `dt`.
fn stride(settings: &WorkPrecisionSettings, dt: f64) -> usize {
    ((settings.horizon / settings.samples as f64 / dt).round() as usize).max(1)
}

/// Compute the reference for the physics of `template` (any run of it): `method` at `dt` and
/// at `dt / 2`, or with `same_dt` twice at `dt`, the second at a 100× tighter Newton
/// tolerance (and always with the Cholesky solver, so the linear solves are exact).
pub fn reference(
    template: &RunSpec,
    settings: &WorkPrecisionSettings,
    method: Method,
    dt: f64,
    parallelism: Parallelism,
) -> Result<Reference, String> {
    let same_dt = settings.reference.same_dt;
    let solve = |dt: f64, tolerance: f64| -> Result<(Snapshots, f64, Vec<f64>), String> {
        let mut spec = template.clone();
        let integrator = &mut spec.loaded.config.integrator;
        integrator.method = method;
        integrator.newton.tolerance = tolerance;
        integrator.newton.max_iterations = integrator.newton.max_iterations.max(50);
        if same_dt {
            integrator.newton.require_convergence = true;
            integrator.linear_solver = crate::solve::LinearSolverKind::cholesky();
        }
        let mut scene = build(&spec, parallelism).map_err(|e| e.to_string())?;
        let stride = stride(settings, dt);
        let run = RunConfig {
            dt,
            steps: stride * settings.samples,
            sample_every: stride,
            energy_limit: 0.0,
        };
        let (summary, _, snapshots, _) = sampled_run(&mut scene, &run, stride, None);
        if !summary.outcome.is_completed() {
            let (status, message) = outcome_of(&summary.outcome);
            return Err(format!(
                "the reference ({} at dt = {dt:e} s) {status}: {message}; choose another \
                 [work-precision.reference] method or dt",
                method.name()
            ));
        }
        Ok((
            snapshots,
            summary.totals.times.total,
            scene.initial.q.clone(),
        ))
    };
    let tolerance = settings.reference.newton_tolerance;
    let (coarse, t1, rest) = solve(dt, tolerance)?;
    let (fine, t2, _) = if same_dt {
        solve(dt, tolerance / 100.0)?
    } else {
        solve(dt / 2.0, tolerance)?
    };
    let (difference, energy_difference) =
        errors(&coarse, &fine, &rest).ok_or("the reference reached no sample time")?;
    Ok(Reference {
        method,
        dt: if same_dt { dt } else { dt / 2.0 },
        same_dt,
        snapshots: fine,
        rest,
        difference,
        energy_difference,
        wall_seconds: t1 + t2,
        times: (1..=settings.samples)
            .map(|k| settings.horizon * k as f64 / settings.samples as f64)
            .collect(),
        floor_factor: settings.reference.floor_factor,
    })
}

/// Run one work-precision run and score it against `reference`.
pub fn measure(
    spec: &RunSpec,
    settings: &WorkPrecisionSettings,
    reference: &Reference,
    parallelism: Parallelism,
) -> Result<Measured, String> {
    let mut scene = build(spec, parallelism).map_err(|e| e.to_string())?;
    let run = scene.config.run;
    let surface = picture_surface(&scene, spec)?;
    let (summary, rows, snapshots, pictures) =
        sampled_run(&mut scene, &run, stride(settings, run.dt), surface);
    let (outcome, message) = outcome_of(&summary.outcome);
    let mut m = Measured {
        outcome,
        message,
        cells: summary_cells(&summary),
        series: rows,
        snapshots: pictures,
        ..Measured::default()
    };
    m.cells.extend(cap_cells(spec));
    m.set("dt", cell(Some(run.dt)));
    m.set("reference_method", reference.method.name().to_owned());
    m.set("reference_dt", cell(Some(reference.dt)));
    m.set("reference_difference", cell(Some(reference.difference)));
    let floor = settings.reference.floor_factor * reference.difference;
    match errors(&snapshots, &reference.snapshots, &reference.rest) {
        Some((error, energy)) if summary.outcome.is_completed() => {
            let scored = error > floor;
            m.set("scored", if scored { "yes" } else { "no" }.into());
            m.set("error", cell(scored.then_some(error)));
            m.set(
                "error_l2",
                cell(reference.relative_l2_error(&snapshots.q).filter(|_| scored)),
            );
            m.set("error_unscored", cell((!scored).then_some(error)));
            m.set("energy_error", cell(Some(energy)));
            if !scored {
                m.message = format!(
                    "error {error:.3e} is below {} x the reference's own difference {:.3e}: \
                     not scored",
                    settings.reference.floor_factor, reference.difference
                );
            }
        }
        _ => m.set("scored", "no".into()),
    }
    Ok(m)
}

/// The report's paragraph on the work-precision settings.
fn report_settings(out: &mut String, file: &StudyFile) {
    if let Some(w) = &file.work_precision {
        let _ = writeln!(
            out,
            "Work-precision: horizon {} s, errors at {} sample times (the largest is reported). \
             Newton convergence {}.\n",
            short(w.horizon),
            w.samples,
            if w.require_newton_convergence {
                "is required"
            } else {
                "is **not** required: unconverged steps are accepted and counted"
            }
        );
    }
}

/// Observed order of each line of a work-precision study: the slope of log(error) against
/// log(dt) between its two smallest scored time steps.
fn orders(out: &mut String, runs: &Table) {
    let mut text = String::new();
    for (scene, method, order) in super::findings::observed_orders(runs) {
        let _ = writeln!(text, "| {scene} | {method} | {order:.2} |");
    }
    if !text.is_empty() {
        let _ = writeln!(
            out,
            "Observed order (slope of log error against log dt between the two smallest scored \
             steps; adaptive methods, whose dt is only an output interval, are left out):\n\n| scene | method | order |\n|---|---|---|\n{text}"
        );
    }
}

/// A [`Reference`] as the shards of a study store it (`shared/`): every number as its f64
/// bits, so a shard that reads it scores its runs exactly as the shard that computed it.
#[derive(serde::Serialize, serde::Deserialize)]
pub(super) struct StoredReference {
    method: String,
    dt: u64,
    q: Vec<Vec<u64>>,
    /// Kinetic, elastic, springs, gravity, external.
    energies: Vec<[u64; 5]>,
    rest: Vec<u64>,
    difference: u64,
    energy_difference: u64,
    wall_seconds: u64,
    times: Vec<u64>,
    floor_factor: u64,
    #[serde(default)]
    same_dt: bool,
}

impl Reference {
    /// The reference as stored.
    pub(super) fn stored(&self) -> StoredReference {
        use super::shared_store::bits;
        let all = |v: &[f64]| v.iter().map(|x| bits(*x)).collect::<Vec<u64>>();
        StoredReference {
            method: self.method.name().to_owned(),
            dt: bits(self.dt),
            q: self.snapshots.q.iter().map(|q| all(q)).collect(),
            energies: self
                .snapshots
                .energies
                .iter()
                .map(|e| [e.kinetic, e.elastic, e.springs, e.gravity, e.external].map(bits))
                .collect(),
            rest: all(&self.rest),
            difference: bits(self.difference),
            energy_difference: bits(self.energy_difference),
            wall_seconds: bits(self.wall_seconds),
            times: all(&self.times),
            floor_factor: bits(self.floor_factor),
            same_dt: self.same_dt,
        }
    }

    /// The reference a shard stored (an error names a method this build does not know).
    pub(super) fn from_stored(s: &StoredReference) -> Result<Self, String> {
        use super::shared_store::from_bits;
        let all = |v: &[u64]| v.iter().map(|b| from_bits(*b)).collect::<Vec<f64>>();
        Ok(Reference {
            method: Method::from_name(&s.method).map_err(|e| e.to_string())?,
            dt: from_bits(s.dt),
            snapshots: Snapshots {
                q: s.q.iter().map(|q| all(q)).collect(),
                energies: s
                    .energies
                    .iter()
                    .map(|e| {
                        let [kinetic, elastic, springs, gravity, external] = e.map(from_bits);
                        Energies {
                            kinetic,
                            elastic,
                            springs,
                            gravity,
                            external,
                        }
                    })
                    .collect(),
            },
            rest: all(&s.rest),
            difference: from_bits(s.difference),
            energy_difference: from_bits(s.energy_difference),
            wall_seconds: from_bits(s.wall_seconds),
            times: all(&s.times),
            floor_factor: from_bits(s.floor_factor),
            same_dt: s.same_dt,
        })
    }
}
