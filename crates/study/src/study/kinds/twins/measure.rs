//! The twins study kind, measuring: the conventions check, then the method and its partner
//! stepped side by side from the same state.

use super::Twins;
use super::plan::partner;
use crate::study::kind::{Measure, RunInputs, number};
use crate::study::vocabulary::columns;
use crate::study::vocabulary::format::cell;
use crate::study::vocabulary::measured::Measured;
use crate::study::vocabulary::spec::{RunSpec, Study};
use crate::study::vocabulary::table::Table;
use nalgebra::Vector3;
use softbench_core::integrate::peer::PeerConventions;
use softbench_core::integrate::{Integrator, State, StepError};
use softbench_core::model::Model;
use softbench_core::parallel::Parallelism;
use softbench_run::run::OutcomeKind;
use softbench_run::scene::{self, LoadedScene, Scene};
use std::sync::LazyLock;
use std::time::Instant;

/// A twins study's own columns of `runs.csv` (it runs no standard trajectory, so it fills no
/// summary or caps group).
pub const OWN_COLUMNS: &[&str] = &[
    "partner",
    "partner_settings",
    "unmatched_settings",
    "peer_package",
    "peer_version",
    "dt",
    "steps",
    "outcome",
    "tets",
    "free_dofs",
    "check_mass_difference",
    "check_fixed_equal",
    "check_energy_ratio",
    "check_force_difference",
    "check_note",
    "difference_first_step",
    "difference_max",
    "difference_final",
    "energy_final",
    "partner_energy_final",
    "energy_difference_max",
    "iterations_per_step",
    "partner_iterations_per_step",
    "first_step_seconds",
    "partner_first_step_seconds",
    "step_seconds_median",
    "partner_step_seconds_median",
    "cost_ratio",
];

/// Every measured column of a twins study's `runs.csv`.
pub static COLUMNS: LazyLock<Vec<&'static str>> =
    LazyLock::new(|| columns::declare(OWN_COLUMNS, false, false));

/// The per-step table's columns (`series/<run-id>-steps.csv`).
const STEP_COLUMNS: [&str; 9] = [
    "step",
    "t",
    "difference",
    "energy",
    "partner_energy",
    "iterations",
    "partner_iterations",
    "seconds",
    "partner_seconds",
];

impl Measure for Twins {
    fn columns(&self) -> &'static [&'static str] {
        &COLUMNS
    }

    fn progress(&self, m: &Measured) -> Option<String> {
        number(m, "difference_max").map(|d| format!(", apart by {d} of the displacement"))
    }

    fn measure(
        &self,
        study: &Study,
        spec: &RunSpec,
        _: &RunInputs,
        parallelism: Parallelism,
    ) -> Result<Measured, String> {
        let partner_name = partner(&study.file, spec.method)
            .ok_or_else(|| format!("`{}` has no partner", spec.method))?;
        let (partner_loaded, settings) = partner_scene(spec, &partner_name)?;
        let mut ours =
            scene::build(&spec.loaded, &spec.data, parallelism).map_err(|e| e.to_string())?;
        let mut theirs =
            scene::build(&partner_loaded, &spec.data, parallelism).map_err(|e| e.to_string())?;
        let mut m = Measured::default();
        m.set("partner", partner_name);
        m.set("partner_settings", settings.overrides.join("; "));
        m.set("unmatched_settings", settings.unmatched.join("; "));
        let peer = spec.method.entry().peer;
        m.set(
            "peer_package",
            peer.map(|p| p.package.clone()).unwrap_or_default(),
        );
        m.set(
            "peer_version",
            peer.and_then(|p| p.version.clone()).unwrap_or_default(),
        );
        let run = ours.config.run;
        m.set("dt", cell(Some(run.dt)));
        m.set("tets", ours.model.tets().len().to_string());
        m.set(
            "free_dofs",
            ours.model.dofs().counts().free_dofs.to_string(),
        );
        let mut method = ours.take_integrator();
        let mut partner = theirs.take_integrator();
        check_conventions(&mut m, &mut *method, &mut ours.model, run.dt)?;
        let steps = side_by_side(&mut ours, &mut theirs, &mut *method, &mut *partner);
        steps.summarize(&mut m);
        Ok(m)
    }
}

/// The partner's scene: the run's with the partner's method and the peer's settings matched
/// (`integrator.peer` dropped).
fn partner_scene(
    spec: &RunSpec,
    partner: &str,
) -> Result<(LoadedScene, softbench_core::integrate::peer::TwinSettings), String> {
    let config = &spec.loaded.config;
    let settings = config
        .integrator
        .method
        .entry()
        .peer
        .map(|p| p.twin_settings(config.integrator.peer.values()))
        .unwrap_or_default();
    let mut table = toml::Table::try_from(config).map_err(|e| e.to_string())?;
    if let Some(toml::Value::Table(integrator)) = table.get_mut("integrator") {
        integrator.remove("peer");
        integrator.insert("method".into(), toml::Value::String(partner.to_owned()));
    }
    for o in &settings.overrides {
        scene::apply_override(&mut table, o).map_err(|e| e.to_string())?;
    }
    let path = &spec.loaded.path;
    let config = scene::from_table(table, None, path)
        .map_err(|e| format!("the partner `{partner}` cannot run this scene: {e}"))?;
    Ok((
        LoadedScene {
            path: path.clone(),
            config,
        },
        settings,
    ))
}

/// A deterministic deformation of the rest shape (1 % of the body's size, every free vertex
/// moved differently), where the conventions are compared.
fn probe_positions(model: &Model) -> Vec<Vector3<f64>> {
    let rest = model.rest_positions();
    let (lo, hi) = rest.iter().fold(
        (
            Vector3::repeat(f64::INFINITY),
            Vector3::repeat(f64::NEG_INFINITY),
        ),
        |(lo, hi), p| (lo.inf(p), hi.sup(p)),
    );
    let size = (hi - lo).max();
    rest.iter()
        .enumerate()
        .map(|(i, p)| {
            if model.dofs().is_fixed(i) {
                return *p;
            }
            let k = i as f64;
            p + 0.01
                * size
                * Vector3::new(
                    (1.3 * k).sin(),
                    (2.1 * k + 0.5).sin(),
                    (0.7 * k + 1.1).cos(),
                )
        })
        .collect()
}

/// Compare the peer's own masses, fixed set and elastic energy or forces with the model's.
fn check_conventions(
    m: &mut Measured,
    method: &mut dyn Integrator,
    model: &mut Model,
    dt: f64,
) -> Result<(), String> {
    for column in [
        "check_mass_difference",
        "check_fixed_equal",
        "check_energy_ratio",
        "check_force_difference",
    ] {
        m.set(column, String::new());
    }
    let positions = probe_positions(model);
    let Some(found) = method.peer_conventions(model, &positions, dt) else {
        m.set(
            "check_note",
            "not a peer: both methods run softbench's model".into(),
        );
        return Ok(());
    };
    let found: PeerConventions = found.map_err(|e| format!("conventions check: {e}"))?;
    let free: Vec<usize> = model.dofs().free_vertices().to_vec();
    if let Some(masses) = &found.masses {
        let ours = model.vertex_masses();
        let worst = free
            .iter()
            .map(|&v| (masses.get(v).copied().unwrap_or(f64::NAN) - ours[v]).abs() / ours[v])
            .fold(0.0f64, f64::max);
        m.set("check_mass_difference", cell(Some(worst)));
    }
    if let Some(fixed) = &found.fixed {
        let mut theirs = fixed.clone();
        theirs.sort_unstable();
        let ours: Vec<usize> = (0..model.rest_positions().len())
            .filter(|&v| model.dofs().is_fixed(v))
            .collect();
        m.set("check_fixed_equal", (theirs == ours).to_string());
    }
    let mut q = vec![0.0; model.num_dofs()];
    model.dofs().gather(&positions, &mut q);
    if let Some(energy) = found.elastic_energy {
        let ours = model
            .potential_parts(&q)
            .map_err(|e| e.to_string())?
            .elastic;
        m.set("check_energy_ratio", cell(Some(energy / ours)));
    }
    if let Some(forces) = &found.elastic_forces {
        m.set(
            "check_force_difference",
            cell(Some(force_difference(model, &q, forces, &free)?)),
        );
    }
    m.set("check_note", found.note.unwrap_or_default());
    Ok(())
}

/// Largest difference between the peer's elastic forces and the model's (−∇ of the elastic
/// energy: the gradient less gravity's) on the free vertices, over the largest model force.
fn force_difference(
    model: &mut Model,
    q: &[f64],
    forces: &[f64],
    free: &[usize],
) -> Result<f64, String> {
    let mut g = vec![0.0; q.len()];
    model.gradient(q, &mut g).map_err(|e| e.to_string())?;
    let gravity = model.gravity().unwrap_or_default();
    let masses = model.vertex_masses().to_vec();
    let (mut worst, mut scale) = (0.0f64, 0.0f64);
    for (k, &v) in free.iter().enumerate() {
        // ∇V = ∇E_elastic − m g on a free vertex, so the elastic force is −∇V − m g.
        let ours = -Vector3::new(g[3 * k], g[3 * k + 1], g[3 * k + 2]) - masses[v] * gravity;
        let theirs = Vector3::new(forces[3 * v], forces[3 * v + 1], forces[3 * v + 2]);
        worst = worst.max((theirs - ours).norm());
        scale = scale.max(ours.norm());
    }
    Ok(worst / scale)
}

/// Per-step records of the two trajectories.
#[derive(Default)]
struct Steps {
    rows: Vec<[f64; 9]>,
    /// How the pair ended: the first failure of either (who failed, and how).
    failure: Option<(OutcomeKind, String)>,
    final_difference: Option<f64>,
    /// The partner's energy at the start (J).
    initial_energy: f64,
}

/// Step the method and its partner from the same initial state for the run's steps.
fn side_by_side(
    ours: &mut Scene,
    theirs: &mut Scene,
    method: &mut dyn Integrator,
    partner: &mut dyn Integrator,
) -> Steps {
    let run = ours.config.run;
    let mut a = ours.initial.clone();
    let mut b = theirs.initial.clone();
    let start = ours.model.full_positions(&a.q);
    // The partner's largest displacement from the start so far (m).
    let mut displacement = 0.0f64;
    let mut steps = Steps {
        initial_energy: total_energy(&mut theirs.model, &b),
        ..Steps::default()
    };
    for k in 1..=run.steps {
        let t0 = Instant::now();
        let ra = method.step(&mut ours.model, &mut a, run.dt);
        let seconds = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let rb = partner.step(&mut theirs.model, &mut b, run.dt);
        let partner_seconds = t1.elapsed().as_secs_f64();
        let (ra, rb) = match (ra, rb) {
            (Ok(ra), Ok(rb)) => (ra, rb),
            (Err(e), _) => {
                steps.failure = Some(failure("the method", k, &e));
                break;
            }
            (_, Err(e)) => {
                steps.failure = Some(failure("the partner", k, &e));
                break;
            }
        };
        let xa = ours.model.full_positions(&a.q);
        let xb = theirs.model.full_positions(&b.q);
        displacement = displacement.max(distance(&xb, &start));
        let difference = distance(&xa, &xb) / displacement.max(f64::MIN_POSITIVE);
        let energy = total_energy(&mut theirs.model, &a);
        let partner_energy = total_energy(&mut theirs.model, &b);
        steps.final_difference = Some(difference);
        steps.rows.push([
            k as f64,
            b.t,
            difference,
            energy,
            partner_energy,
            f64::from(ra.local_iterations.max(ra.newton_iterations)),
            f64::from(rb.local_iterations.max(rb.newton_iterations)),
            seconds,
            partner_seconds,
        ]);
    }
    steps
}

fn failure(who: &str, step: usize, e: &StepError) -> (OutcomeKind, String) {
    (
        OutcomeKind::of_step_error(e),
        format!("{who} failed at step {step}: {e}"),
    )
}

/// Largest distance between corresponding vertices.
fn distance(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max)
}

/// Kinetic plus potential energy of `state` on `model` (NaN where the model cannot evaluate
/// it, e.g. an inverted element of a material undefined there).
fn total_energy(model: &mut Model, state: &State) -> f64 {
    let mut mv = vec![0.0; state.v.len()];
    model.mass().mul_vec(&state.v, &mut mv);
    let kinetic = 0.5 * state.v.iter().zip(&mv).map(|(v, p)| v * p).sum::<f64>();
    model.set_time(state.t);
    model
        .potential_parts(&state.q)
        .map_or(f64::NAN, |p| kinetic + p.total())
}

impl Steps {
    /// The run's cells and its per-step table.
    fn summarize(&self, m: &mut Measured) {
        let column = |i: usize| self.rows.iter().map(move |r| r[i]);
        let median = |v: Vec<f64>| {
            let mut v = v;
            v.sort_by(f64::total_cmp);
            (!v.is_empty()).then(|| v[v.len() / 2])
        };
        let later = |i: usize| median(column(i).skip(1).collect());
        let per_step = |i: usize| {
            (!self.rows.is_empty()).then(|| column(i).sum::<f64>() / self.rows.len() as f64)
        };
        m.outcome = self
            .failure
            .as_ref()
            .map_or(OutcomeKind::Completed, |f| f.0)
            .name()
            .to_owned();
        m.message = self
            .failure
            .as_ref()
            .map(|f| f.1.clone())
            .unwrap_or_default();
        m.set("steps", self.rows.len().to_string());
        m.set(
            "difference_first_step",
            cell(self.rows.first().map(|r| r[2])),
        );
        m.set("difference_max", cell(column(2).reduce(f64::max)));
        m.set("difference_final", cell(self.final_difference));
        m.set("energy_final", cell(self.rows.last().map(|r| r[3])));
        m.set("partner_energy_final", cell(self.rows.last().map(|r| r[4])));
        // Relative to the energy the partner exchanged (potential to kinetic) over the run.
        let e0 = self.initial_energy;
        let exchanged = column(4).map(|e| (e - e0).abs()).fold(0.0, f64::max);
        let apart = self
            .rows
            .iter()
            .map(|r| (r[3] - r[4]).abs())
            .fold(0.0, f64::max);
        m.set(
            "energy_difference_max",
            cell((exchanged > 0.0).then(|| apart / exchanged)),
        );
        m.set("iterations_per_step", cell(per_step(5)));
        m.set("partner_iterations_per_step", cell(per_step(6)));
        m.set("first_step_seconds", cell(self.rows.first().map(|r| r[7])));
        m.set(
            "partner_first_step_seconds",
            cell(self.rows.first().map(|r| r[8])),
        );
        let (ours, theirs) = (later(7), later(8));
        m.set("step_seconds_median", cell(ours));
        m.set("partner_step_seconds_median", cell(theirs));
        m.set(
            "cost_ratio",
            cell(ours.zip(theirs).map(|(a, b)| a / b.max(f64::MIN_POSITIVE))),
        );
        let mut table = Table::new(STEP_COLUMNS.iter().map(|c| c.to_string()).collect());
        for r in &self.rows {
            table.rows.push(
                r.iter()
                    .enumerate()
                    .map(|(i, x)| {
                        if i == 0 {
                            format!("{x}")
                        } else {
                            cell(Some(*x))
                        }
                    })
                    .collect(),
            );
        }
        m.tables = vec![("steps", table)];
    }
}
