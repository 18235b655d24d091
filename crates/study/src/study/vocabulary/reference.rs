//! Reference solutions: a converged run of a scene's physics, stored at fixed sample times,
//! that work-precision and stability runs are scored against, and the errors of a run
//! against it.
//!
//! A reference is computed twice, at its step and at half of it (or, with `same_dt`, twice at
//! the runs' own step, the second at a 100× tighter Newton tolerance); their difference is
//! the reference's own accuracy (its error bar), and errors below `floor_factor` times it are
//! not scored. The same holds within each of a study's phases (time windows), so a scene whose
//! late phase is chaotic is still scored where its reference converges; next to the pointwise
//! error, statistics that survive chaos (the centroid, the bounding box) are compared.

use crate::study::vocabulary::format::{cell, short};
use crate::study::vocabulary::measured::{Measured, build, outcome_of, run_observed};
use crate::study::vocabulary::meter::StepMeter;
use crate::study::vocabulary::modal::{ModalBasis, StoredModes};
use crate::study::vocabulary::shared_store::{bits, from_bits};
use crate::study::vocabulary::spec::RunSpec;
use softbench_core::integrate::{Method, State};
use softbench_core::model::Model;
use softbench_core::parallel::Parallelism;
use softbench_run::run::{Energies, Observer, RunSummary, Sample};
pub use softbench_run::scene::IndependentSolution;
use softbench_run::scene::{RunConfig, Scene};

/// Where runs are scored against a reference and how it is computed: a work-precision study's
/// settings table, and what a stability study's errors at its largest stable steps use.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScoringSettings {
    /// Simulated time of every run (s); must be a whole number of steps of every dt.
    pub horizon: f64,
    /// Newton must converge within its iteration cap, or the step fails as `solver-failed`.
    /// Default true.
    #[serde(default = "yes")]
    pub require_newton_convergence: bool,
    /// Errors are measured at `horizon k / samples`, k = 1..samples. Default 4.
    #[serde(default = "default_samples")]
    pub samples: usize,
    /// Time windows `[start, end]` (s) in which the error is also reported on its own
    /// (`error_phase1`...), each against the reference's own difference in it: a scene whose
    /// late phase is chaotic is scored where its reference converges. At most
    /// [`MAX_PHASES`]; each must hold a sample time. Default none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub phases: Vec<[f64; 2]>,
    #[serde(default)]
    pub reference: ReferenceSettings,
    /// Times each work-precision run is run: its error is the first run's (they are the
    /// same: runs are deterministic, and `repeatable` says so), its `wall_seconds` the median
    /// over the repeats, with the lowest and highest. Default 1.
    #[serde(default = "one")]
    pub repeats: usize,
}

fn default_samples() -> usize {
    4
}

fn one() -> usize {
    1
}

/// Phases a study may score apart.
pub const MAX_PHASES: usize = 4;

/// The runs.csv columns of the phases: the error in each (empty when not scored), the
/// reference's own difference in it.
pub const PHASE_COLUMNS: [[&str; 2]; MAX_PHASES] = [
    ["error_phase1", "reference_difference_phase1"],
    ["error_phase2", "reference_difference_phase2"],
    ["error_phase3", "reference_difference_phase3"],
    ["error_phase4", "reference_difference_phase4"],
];

/// Whether sample time `t` lies in `phase` (start excluded, end included, to round-off).
fn in_phase(t: f64, phase: [f64; 2]) -> bool {
    let eps = 1e-9 * phase[1].abs().max(1.0);
    t > phase[0] + eps && t <= phase[1] + eps
}

/// `sqrt(sum |a_k - b_k|^2) / sqrt(sum |b_k - rest|^2)` over the sample indices `k` that
/// `keep` selects; `None` when none is selected or `a` lacks one.
fn relative_l2(
    a: &[Vec<f64>],
    b: &[Vec<f64>],
    rest: &[f64],
    keep: &dyn Fn(usize) -> bool,
) -> Option<f64> {
    let squared =
        |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(p, q)| (p - q) * (p - q)).sum::<f64>();
    let (mut error, mut motion, mut count) = (0.0, 0.0, 0);
    for (k, r) in b.iter().enumerate().filter(|(k, _)| keep(*k)) {
        error += squared(a.get(k)?, r);
        motion += squared(r, rest);
        count += 1;
    }
    (count > 0).then(|| error.sqrt() / motion.sqrt().max(f64::MIN_POSITIVE))
}

/// How the reference solution is computed.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReferenceSettings {
    /// The method. Default: RK4 when it is stable at the reference step (below 2.5/omega_max),
    /// else implicit midpoint (second order, stable at any step); with `same_dt`, backward
    /// Euler.
    pub method: Option<Method>,
    /// Work-precision only: the reference runs at each run's own dt, so a run's error is its
    /// distance from the converged step it approximates (the iteration error of VBD,
    /// projective dynamics, XPBD or a truncated Newton solve), not from the exact motion.
    /// Its own accuracy is then its difference from a second reference at a Newton
    /// tolerance 100× tighter. Default false.
    pub same_dt: bool,
    /// The reference step (s). Default: the smallest dt of the grid divided by `dt_factor`.
    pub dt: Option<f64>,
    /// Default 8.
    pub dt_factor: f64,
    /// Newton tolerance of an implicit reference. Default 1e-10.
    pub newton_tolerance: f64,
    /// Errors below this factor times the difference between the reference and a second one
    /// at half its step are not scored. Default 2.
    pub floor_factor: f64,
    /// A second, independent solution (another method at its own step): the reference's
    /// error bar is then its difference from this one, instead of the reference's difference
    /// from itself at half its step. Default none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub independent: Option<IndependentSolution>,
    /// The reference runs with softbench's default integrator settings (its method and
    /// Newton tolerance as set here), not with those of the study's first run of the physics,
    /// whose options (chosen for that run's method) would otherwise carry over. Default false.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub default_integrator: bool,
    /// The lowest vibration modes of the body at rest that the modal error (`modal_error`)
    /// projects on; 0 measures no modal error. Default [`DEFAULT_MODES`].
    pub modes: usize,
}

/// The modes the modal error counts by default: enough to hold the large-scale motion of a
/// body (bending, twisting, stretching in each direction and their first overtones), few
/// enough to leave out the ringing of its small-scale modes.
pub const DEFAULT_MODES: usize = 10;
/// The most modes a study may ask for (each costs a block vector in the subspace iteration).
pub const MAX_MODES: usize = 200;

impl Default for ReferenceSettings {
    fn default() -> Self {
        Self {
            method: None,
            same_dt: false,
            dt: None,
            dt_factor: 8.0,
            newton_tolerance: 1e-10,
            floor_factor: 2.0,
            independent: None,
            default_integrator: false,
            modes: DEFAULT_MODES,
        }
    }
}

fn yes() -> bool {
    true
}

#[derive(Clone, Debug)]
pub(in crate::study) struct Snapshots {
    pub q: Vec<Vec<f64>>,
    pub energies: Vec<Energies>,
}

/// A reference solution at the sample times, and how well it is resolved.
#[derive(Clone, Debug)]
pub struct Reference {
    pub method: Method,
    pub dt: f64,
    /// Whether it runs at the runs' own dt (and `difference` is the one from a second
    /// reference at a tighter Newton tolerance, not at half the step).
    pub same_dt: bool,
    /// The independent solution `difference` is measured against, when there is one (else it
    /// is the reference at half its step, or with `same_dt` at a tighter tolerance).
    pub independent: Option<IndependentSolution>,
    pub(in crate::study) snapshots: Snapshots,
    pub(in crate::study) rest: Vec<f64>,
    /// Position error of the reference at `dt` against the one at `dt / 2` (or against the
    /// independent solution): its error bar.
    pub difference: f64,
    pub energy_difference: f64,
    /// Wall time of both reference runs (s).
    pub wall_seconds: f64,
    /// The sample times (s).
    times: Vec<f64>,
    /// The study's phases (s), and the reference's own difference in each.
    pub phases: Vec<[f64; 2]>,
    pub phase_differences: Vec<f64>,
    /// Errors below `floor_factor * difference` are not scored.
    floor_factor: f64,
    /// The lowest modes of the body at rest, and the reference's own difference in them.
    modal: Option<ModalBasis>,
    pub modal_difference: Option<f64>,
}

impl Reference {
    /// The sample times (s): `horizon k / samples`, k = 1..samples.
    pub fn times(&self) -> &[f64] {
        &self.times
    }

    /// What `difference` was measured against, for reports.
    pub fn checked_against(&self) -> String {
        match (self.independent, self.same_dt) {
            (Some(i), _) => format!(
                "an independent solution ({} at dt = {} s)",
                i.method.name(),
                short(i.dt)
            ),
            (None, true) => "a second solve at a 100× tighter Newton tolerance".into(),
            (None, false) => "the solution at twice its step".into(),
        }
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
        if positions.len() != self.snapshots.q.len() {
            return None;
        }
        relative_l2(positions, &self.snapshots.q, &self.rest, &|_| true)
    }

    /// The relative L2 position error in the lowest modes of the body at rest (see
    /// [`crate::study::vocabulary::modal`]); `None` without modes or unless `positions` hold
    /// every sample time.
    pub fn modal_error(&self, positions: &[Vec<f64>]) -> Option<f64> {
        self.modal
            .as_ref()?
            .relative_error(positions, &self.snapshots.q, &self.rest)
    }

    /// The modal cells of a run at `positions` (see [`crate::study::vocabulary::modal`]).
    pub(in crate::study) fn set_modal_cells(&self, m: &mut Measured, positions: &[Vec<f64>]) {
        crate::study::vocabulary::modal::set_modal_cells(
            m,
            self.modal.as_ref(),
            self.modal_error(positions),
            self.modal_difference,
            self.floor_factor,
        );
    }

    /// The relative L2 position error within each phase, `None` where it is within
    /// `floor_factor` times the reference's own difference there (not scored) or `positions`
    /// do not cover it.
    pub fn phase_errors(&self, positions: &[Vec<f64>]) -> Vec<Option<f64>> {
        self.phases
            .iter()
            .zip(&self.phase_differences)
            .map(|(&phase, &difference)| {
                let keep = |k: usize| self.times.get(k).is_some_and(|&t| in_phase(t, phase));
                relative_l2(positions, &self.snapshots.q, &self.rest, &keep)
                    .filter(|e| *e > self.floor_factor * difference)
            })
            .collect()
    }

    /// Errors of statistics that survive chaos, largest over the sample times and relative to
    /// the diagonal of the rest shape's bounding box: of the vertex centroid, and of the
    /// bounding box (its largest corner coordinate difference). `None` unless `positions`
    /// hold every sample time.
    pub fn statistic_errors(&self, positions: &[Vec<f64>]) -> Option<(f64, f64)> {
        if positions.len() != self.snapshots.q.len() || positions.is_empty() {
            return None;
        }
        let (rest_lo, rest_hi) = bounds(&self.rest);
        let diagonal = (0..3)
            .map(|i| (rest_hi[i] - rest_lo[i]).powi(2))
            .sum::<f64>()
            .sqrt()
            .max(f64::MIN_POSITIVE);
        let (mut centroid, mut bbox) = (0.0f64, 0.0f64);
        for (q, r) in positions.iter().zip(&self.snapshots.q) {
            let (c, cr) = (centre(q), centre(r));
            let d = (0..3).map(|i| (c[i] - cr[i]).powi(2)).sum::<f64>().sqrt();
            centroid = centroid.max(d / diagonal);
            let ((lo, hi), (lo_r, hi_r)) = (bounds(q), bounds(r));
            for i in 0..3 {
                bbox = bbox.max((lo[i] - lo_r[i]).abs().max((hi[i] - hi_r[i]).abs()) / diagonal);
            }
        }
        Some((centroid, bbox))
    }
}

/// The smallest and largest coordinate per axis of the vertices `q` (x, y, z interleaved).
fn bounds(q: &[f64]) -> ([f64; 3], [f64; 3]) {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for x in q.chunks_exact(3) {
        for i in 0..3 {
            lo[i] = lo[i].min(x[i]);
            hi[i] = hi[i].max(x[i]);
        }
    }
    (lo, hi)
}

/// The centroid of the vertices `q` (not mass-weighted: a statistic of the shape's motion).
fn centre(q: &[f64]) -> [f64; 3] {
    let n = (q.len() / 3).max(1) as f64;
    let mut c = [0.0; 3];
    for x in q.chunks_exact(3) {
        for i in 0..3 {
            c[i] += x[i] / n;
        }
    }
    c
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
/// `surface`, the snapshots its pictures are drawn from), counting its steps on `meter`.
pub(in crate::study) fn sampled_run(
    scene: &mut Scene,
    run: &RunConfig,
    stride: usize,
    surface: Option<softbench_run::render::Surface>,
    meter: Option<&StepMeter>,
) -> (
    RunSummary,
    Vec<Sample>,
    Snapshots,
    Option<softbench_run::render::Snapshots>,
) {
    let mut observer = SampleObserver {
        stride,
        rows: Vec::new(),
        snapshots: Snapshots {
            q: Vec::new(),
            energies: Vec::new(),
        },
    };
    let (summary, _, pictures) = run_observed(scene, run, surface, &mut observer, meter);
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
            contact: r.contact_energy,
        })
        .collect();
    (summary, observer.rows, observer.snapshots, pictures)
}

/// Largest relative position error and energy error of `run` against `reference` over the
/// sample times both reached; `None` if `run` reached none.
/// The position error at the last sample time alone (the final-time error of ODE
/// benchmarks), relative to the reference's largest displacement as in [`errors`].
pub(in crate::study) fn final_error(
    run: &Snapshots,
    reference: &Snapshots,
    rest: &[f64],
) -> Option<f64> {
    let n = reference.q.len();
    if n == 0 || run.q.len() < n {
        return None;
    }
    let distance = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y) * (x - y))
            .sum::<f64>()
            .sqrt()
    };
    let displacement = reference
        .q
        .iter()
        .map(|r| distance(r, rest))
        .fold(0.0f64, f64::max)
        .max(f64::MIN_POSITIVE);
    Some(distance(&run.q[n - 1], &reference.q[n - 1]) / displacement)
}

pub(in crate::study) fn errors(
    run: &Snapshots,
    reference: &Snapshots,
    rest: &[f64],
) -> Option<(f64, f64)> {
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
pub(in crate::study) fn stride(settings: &ScoringSettings, dt: f64) -> usize {
    ((settings.horizon / settings.samples as f64 / dt).round() as usize).max(1)
}

/// Compute the reference for the physics of `template` (any run of it): `method` at `dt` and
/// at `dt / 2`, or with `same_dt` twice at `dt`, the second at a 100× tighter Newton
/// tolerance (and always with the Cholesky solver, so the linear solves are exact), or
/// `method` at `dt` and the settings' independent solution.
pub fn reference(
    template: &RunSpec,
    settings: &ScoringSettings,
    method: Method,
    dt: f64,
    parallelism: Parallelism,
) -> Result<Reference, String> {
    let same_dt = settings.reference.same_dt;
    let solve =
        |method: Method, dt: f64, tolerance: f64| -> Result<(Snapshots, f64, Vec<f64>), String> {
            let mut spec = template.clone();
            if settings.reference.default_integrator {
                spec.loaded.config.integrator = Default::default();
            }
            let integrator = &mut spec.loaded.config.integrator;
            integrator.method = method;
            integrator.newton.tolerance = tolerance;
            integrator.newton.max_iterations = integrator.newton.max_iterations.max(50);
            if same_dt {
                integrator.newton.require_convergence = true;
                integrator.linear_solver = softbench_core::solve::LinearSolverKind::cholesky();
            }
            let mut scene = build(&spec, parallelism).map_err(|e| e.to_string())?;
            let stride = stride(settings, dt);
            let run = RunConfig {
                dt,
                steps: stride * settings.samples,
                sample_every: stride,
                energy_limit: 0.0,
                budget: None,
            };
            let (summary, _, snapshots, _) = sampled_run(&mut scene, &run, stride, None, None);
            if !summary.outcome.is_completed() {
                return Err(reference_failure(method, dt, &summary.outcome));
            }
            Ok((
                snapshots,
                summary.totals.times.total,
                scene.initial.q.clone(),
            ))
        };
    let tolerance = settings.reference.newton_tolerance;
    let independent = settings.reference.independent.filter(|_| !same_dt);
    let (coarse, t1, rest) = solve(method, dt, tolerance)?;
    let (fine, t2, _) = match independent {
        Some(other) => solve(other.method, other.dt, tolerance)?,
        None if same_dt => solve(method, dt, tolerance / 100.0)?,
        None => solve(method, dt / 2.0, tolerance)?,
    };
    // Relative to the reference's own motion: the independent solution is scored against the
    // reference as a run is; without one, the coarser solve against the finer.
    let (difference, energy_difference) = match independent {
        Some(_) => errors(&fine, &coarse, &rest),
        None => errors(&coarse, &fine, &rest),
    }
    .ok_or("the reference reached no sample time")?;
    let times: Vec<f64> = (1..=settings.samples)
        .map(|k| settings.horizon * k as f64 / settings.samples as f64)
        .collect();
    let phase_differences = settings
        .phases
        .iter()
        .map(|&phase| {
            let keep = |k: usize| times.get(k).is_some_and(|&t| in_phase(t, phase));
            match independent {
                Some(_) => relative_l2(&fine.q, &coarse.q, &rest, &keep),
                None => relative_l2(&coarse.q, &fine.q, &rest, &keep),
            }
            .unwrap_or(f64::NAN)
        })
        .collect();
    let modal = match settings.reference.modes {
        0 => None,
        count => {
            let mut scene = build(template, parallelism).map_err(|e| e.to_string())?;
            Some(ModalBasis::of(&mut scene.model, count)?)
        }
    };
    let modal_difference = modal.as_ref().and_then(|b| match independent {
        Some(_) => b.relative_error(&fine.q, &coarse.q, &rest),
        None => b.relative_error(&coarse.q, &fine.q, &rest),
    });
    // With an independent solution the reference is the declared one, and the other is only
    // its check; else the finer (or tighter) of the two.
    let (reference, reference_dt) = match independent {
        Some(_) => (coarse, dt),
        None if same_dt => (fine, dt),
        None => (fine, dt / 2.0),
    };
    Ok(Reference {
        method,
        dt: reference_dt,
        same_dt,
        independent,
        snapshots: reference,
        rest,
        difference,
        energy_difference,
        wall_seconds: t1 + t2,
        times,
        phases: settings.phases.clone(),
        phase_differences,
        floor_factor: settings.reference.floor_factor,
        modal,
        modal_difference,
    })
}

/// Which reference a run is scored against: one per physics, or with `same_dt` one per
/// physics and time step.
pub(in crate::study) fn reference_key(w: &ScoringSettings, spec: &RunSpec) -> u64 {
    if !w.reference.same_dt {
        return spec.physics;
    }
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    (spec.physics, spec.loaded.config.run.dt.to_bits()).hash(&mut h);
    h.finish()
}

/// A [`Reference`] as the shards of a study store it (`shared/`): every number as its f64
/// bits, so a shard that reads it scores its runs exactly as the shard that computed it.
#[derive(serde::Serialize, serde::Deserialize)]
pub(in crate::study) struct StoredReference {
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
    #[serde(default)]
    phases: Vec<[u64; 2]>,
    #[serde(default)]
    phase_differences: Vec<u64>,
    /// The independent solution's method and step (bits), if any.
    #[serde(default)]
    independent: Option<(String, u64)>,
    /// The lowest modes and the reference's own difference in them (bits), if measured.
    #[serde(default)]
    modal: Option<(StoredModes, Option<u64>)>,
}

impl Reference {
    /// The reference as stored.
    pub(in crate::study) fn stored(&self) -> StoredReference {
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
            phases: self.phases.iter().map(|p| p.map(bits)).collect(),
            phase_differences: all(&self.phase_differences),
            independent: self
                .independent
                .map(|i| (i.method.name().to_owned(), bits(i.dt))),
            modal: self
                .modal
                .as_ref()
                .map(|b| (b.stored(), self.modal_difference.map(bits))),
        }
    }

    /// The reference a shard stored (an error names a method this build does not know).
    pub(in crate::study) fn from_stored(s: &StoredReference) -> Result<Self, String> {
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
                            // Stored references predate the barrier (no reference scene has one).
                            contact: 0.0,
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
            phases: s.phases.iter().map(|p| p.map(from_bits)).collect(),
            phase_differences: all(&s.phase_differences),
            independent: match &s.independent {
                Some((method, dt)) => Some(IndependentSolution {
                    method: Method::from_name(method).map_err(|e| e.to_string())?,
                    dt: from_bits(*dt),
                }),
                None => None,
            },
            modal: s.modal.as_ref().map(|(b, _)| ModalBasis::from_stored(b)),
            modal_difference: s.modal.as_ref().and_then(|(_, d)| d.map(from_bits)),
        })
    }
}

/// The phase and statistic columns of a run whose positions at the sample times of
/// `reference` are `positions`: `phases`, `error_phase<i>` and `reference_difference_phase<i>`,
/// `centroid_error` and `bounding_box_error`.
pub(in crate::study) fn set_phase_cells(
    m: &mut Measured,
    reference: &Reference,
    positions: &[Vec<f64>],
) {
    m.set(
        "phases",
        reference
            .phases
            .iter()
            .map(|[a, b]| format!("[{}, {}]", short(*a), short(*b)))
            .collect::<Vec<_>>()
            .join(" "),
    );
    let errors = reference.phase_errors(positions);
    for (i, [error, difference]) in PHASE_COLUMNS.iter().enumerate() {
        m.set(error, cell(errors.get(i).copied().flatten()));
        m.set(
            difference,
            cell(reference.phase_differences.get(i).copied()),
        );
    }
    let stats = reference.statistic_errors(positions);
    m.set("centroid_error", cell(stats.map(|s| s.0)));
    m.set("bounding_box_error", cell(stats.map(|s| s.1)));
}

/// Why a reference solve did not give a reference, and what to do: a signal stopped it (run
/// the command again: the study resumes), or it failed (choose another method or step).
fn reference_failure(method: Method, dt: f64, outcome: &softbench_run::run::Outcome) -> String {
    let (status, message) = outcome_of(outcome);
    let what = format!(
        "the reference ({} at dt = {dt:e} s) {status}: {message}",
        method.name()
    );
    if outcome.status == softbench_run::run::OutcomeKind::Interrupted {
        return format!("{what}; run the same command again to resume");
    }
    format!(
        "{what}; choose another reference method or dt (a study's `[<kind>.reference]` table, \
         a suite problem's `[problem] reference`)"
    )
}

#[cfg(test)]
mod failure_tests {
    use super::*;
    use softbench_run::run::{Outcome, OutcomeKind};

    /// Stopping a study by a signal while it computes a reference is not the reference's
    /// fault: the message says to resume, not to choose another method (found stopping the
    /// suite).
    #[test]
    fn an_interrupted_reference_says_to_resume_and_a_failed_one_to_choose_another() {
        let method = Method::from_name("esdirk43").unwrap();
        let stopped = Outcome::ended(
            OutcomeKind::Interrupted,
            961,
            0.12,
            "interrupted",
            "stopped by SIGINT after step 961",
        );
        let text = reference_failure(method, 1.25e-4, &stopped);
        assert!(
            text.ends_with("run the same command again to resume"),
            "{text}"
        );
        assert!(!text.contains("choose another"), "{text}");
        let failed = Outcome::ended(OutcomeKind::Unstable, 3, 0.1, "energy", "energy grew");
        let text = reference_failure(method, 1.25e-4, &failed);
        assert!(
            text.contains("choose another reference method or dt"),
            "{text}"
        );
    }
}
