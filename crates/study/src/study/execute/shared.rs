//! What the runs of a study share, computed before they start: the highest mode of each
//! scene (for kinds that start from it, and the default reference method) and the reference
//! solutions. A local study computes them in memory; the shards of a study go through the
//! study folder's [`SharedStore`], so each item is computed once whichever shards need it;
//! a merge reads what the shards stored.
//!
//! Each item is computed from the *first run of the study* (in grid order) with its physics,
//! never from the first run that happens to be pending, so it is the same for a fresh
//! study, a resumed one and every shard.

use crate::study::execute::progress::Progress;
use crate::study::kind::RunInputs;
use crate::study::vocabulary::error::RunError;
use crate::study::vocabulary::reference::{self, Reference, StoredReference, reference_key};
use crate::study::vocabulary::shared_store::{SharedStore, bits, from_bits};
use crate::study::vocabulary::spec::{RunSpec, Study};
use softbench_core::integrate::Method;
use softbench_core::parallel::Parallelism;
use softbench_core::threads::Threads;
use std::collections::{BTreeMap, HashMap};

/// A reference solution attempted with a method: the solution or why it failed.
/// (And whether this process computed it: `false` when it read what another shard stored.)
type Solved = (Method, Result<Reference, String>, bool);

/// Where shared work comes from.
#[derive(Clone, Copy)]
pub(in crate::study) enum Source<'a> {
    /// A local study: read from the study folder, or computed here and stored there, so a
    /// study that stopped (failed, interrupted) does not compute its references again when it
    /// resumes.
    Local(&'a SharedStore),
    /// Read from the study folder, or computed here once under the item's lock and stored
    /// (a shard).
    Stored(&'a SharedStore),
    /// Read from the study folder only; items nobody stored are left out (a merge).
    ReadOnly(&'a SharedStore),
}

/// What runs share.
pub(in crate::study) struct SharedWork {
    /// Highest mode by physics (`None` where it could not be computed).
    pub omega: HashMap<u64, Option<f64>>,
    /// Reference solution by physics (and dt, with `same_dt`: see
    /// [`reference_key`]), with its label.
    pub references: BTreeMap<u64, (String, Reference)>,
    /// References that failed (kinds whose reference is optional go on without them): scene
    /// and message.
    pub failed_references: BTreeMap<u64, (String, String)>,
    /// Each run's reference key, for the runs that have a reference.
    keys: HashMap<String, u64>,
}

/// Who does a study's work: `jobs` runs (or shared computations) at a time, each with
/// `parallelism` inside, in the study's pool of `threads`.
#[derive(Clone, Copy, Debug)]
pub(in crate::study) struct Workers<'a> {
    pub parallelism: Parallelism,
    pub threads: &'a Threads,
    pub jobs: usize,
}

impl<'a> Workers<'a> {
    /// One job with sequential runs, in the caller's pool: reading what others computed.
    pub fn reading(threads: &'a Threads) -> Self {
        Self {
            parallelism: Parallelism::Sequential,
            threads,
            jobs: 1,
        }
    }
}

impl SharedWork {
    /// What the `runs` need, from `source`.
    pub(in crate::study) fn prepare(
        study: &Study,
        runs: &[&RunSpec],
        source: Source,
        workers: &Workers,
        progress: &Progress,
    ) -> Result<Self, RunError> {
        let Workers {
            parallelism,
            threads,
            jobs,
        } = *workers;
        let kind = crate::study::kinds::measure(study.kind);
        // The first run of the study with each physics the runs need, in grid order.
        let mut templates: Vec<&RunSpec> = Vec::new();
        for spec in &study.runs {
            if runs.iter().any(|r| r.physics == spec.physics)
                && !templates.iter().any(|t| t.physics == spec.physics)
            {
                templates.push(spec);
            }
        }
        let on_wait = |what: &str| {
            let what = what.to_owned();
            move |holder: &softbench_run::lock::Waiting| {
                progress.line(&format!("waiting for {holder} to compute the {what}"));
            }
        };
        let mut omega = HashMap::new();
        // (A reference without a set method also picks it from omega_max.)
        if kind.needs_omega(&study.file) {
            for spec in &templates {
                let task = format!("highest mode of {}", spec.scene);
                let compute = || {
                    progress.start(&task);
                    let value = threads.install(|| {
                        crate::study::vocabulary::measured::build(spec, parallelism)
                            .map_err(|e| e.to_string())
                            .and_then(|mut scene| {
                                crate::study::vocabulary::measured::highest_mode_at_rest(&mut scene)
                            })
                            .map(|m| m.omega)
                            .ok()
                    });
                    progress.finish(&task);
                    value
                };
                let key = format!("omega-{}", item_key(&serde_json::json!(spec.physics)));
                let value = match source {
                    Source::Local(store) | Source::Stored(store) => Some(
                        store
                            .get_or_compute(
                                &key,
                                on_wait(&task),
                                || compute().map(bits),
                                |_| softbench_core::interrupt::requested().is_none(),
                            )?
                            .map(from_bits),
                    ),
                    Source::ReadOnly(store) => {
                        store.read::<Option<u64>>(&key)?.map(|b| b.map(from_bits))
                    }
                };
                if let Some(value) = value {
                    omega.insert(spec.physics, value);
                }
            }
        }
        let mut references = BTreeMap::new();
        let mut failed_references = BTreeMap::new();
        // Each run's reference settings (a kind may give every scene its own) and key.
        let settings_of = |s: &RunSpec| kind.reference_settings(&study.file, s);
        let keys: HashMap<String, u64> = study
            .runs
            .iter()
            .filter_map(|s| Some((s.id.clone(), reference_key(&settings_of(s)?, s))))
            .collect();
        let key = |s: &RunSpec| keys.get(&s.id).copied();
        {
            // One reference per physics (and dt, with `same_dt`): the first run of the study
            // with each key the runs need, `jobs` of them at a time (each is independent).
            let mut templates: Vec<&RunSpec> = Vec::new();
            for spec in &study.runs {
                if key(spec).is_some()
                    && runs.iter().any(|r| key(r) == key(spec))
                    && !templates.iter().any(|t| key(t) == key(spec))
                {
                    templates.push(spec);
                }
            }
            let compute = |spec: &RunSpec| -> Result<Option<Solved>, RunError> {
                let w = &settings_of(spec).expect("a run with a reference key has settings");
                let dt = kind.reference_dt(study, w, spec);
                let method = w.reference.method.unwrap_or_else(|| {
                    // Same dt: the converged backward Euler step. Otherwise RK4 where it is
                    // stable at dt (its limit is 2.83 / omega_max), else the second-order
                    // implicit midpoint rule.
                    let name = match omega.get(&spec.physics).copied().flatten() {
                        _ if w.reference.same_dt => "backward-euler",
                        Some(w) if dt < 2.5 / w => "rk4",
                        _ => "implicit-midpoint",
                    };
                    Method::from_name(name).expect("a built-in method")
                });
                let task = if w.reference.same_dt {
                    format!(
                        "reference for {}: {} at dt = {dt:e} s, converged twice",
                        spec.scene,
                        method.name()
                    )
                } else if let Some(i) = w.reference.independent {
                    format!(
                        "reference for {}: {} at dt = {dt:e} s and {} at dt = {:e} s",
                        spec.scene,
                        method.name(),
                        i.method.name(),
                        i.dt
                    )
                } else {
                    format!(
                        "reference for {}: {} at dt = {dt:e} s and dt/2",
                        spec.scene,
                        method.name()
                    )
                };
                let solved_here = std::cell::Cell::new(false);
                let solve = || {
                    solved_here.set(true);
                    progress.start(&task);
                    let result =
                        threads.install(|| reference::reference(spec, w, method, dt, parallelism));
                    progress.finish(&task);
                    result
                };
                let key = format!(
                    "reference-{}",
                    item_key(&serde_json::json!({
                        "physics": spec.physics,
                        "method": method.name(),
                        "dt": bits(dt),
                        "settings": w,
                        // The template run matters through its integrator settings, which
                        // a reference with the default integrator does not take.
                        "template": (!w.reference.default_integrator).then_some(&spec.hash),
                    }))
                );
                let stored =
                    |r: Result<StoredReference, String>| r.and_then(|s| Reference::from_stored(&s));
                let result = match source {
                    Source::Local(store) | Source::Stored(store) => {
                        Some(stored(store.get_or_compute(
                            &key,
                            on_wait(&task),
                            || solve().map(|r| r.stored()),
                            |_| softbench_core::interrupt::requested().is_none(),
                        )?))
                    }
                    Source::ReadOnly(store) => store
                        .read::<Result<StoredReference, String>>(&key)?
                        .map(stored),
                };
                Ok(result.map(|r| (method, r, solved_here.get())))
            };
            // `jobs` workers take the next reference as they finish one (references differ in
            // cost by orders of magnitude, so fixed groups would wait for their slowest);
            // after a failure no new one is started. Results are kept in template order.
            let next = std::sync::atomic::AtomicUsize::new(0);
            let failed = std::sync::atomic::AtomicBool::new(false);
            let slots: Vec<Slot> = templates
                .iter()
                .map(|_| std::sync::Mutex::new(None))
                .collect();
            std::thread::scope(|scope| {
                for _ in 0..jobs.clamp(1, templates.len().max(1)) {
                    scope.spawn(|| {
                        use std::sync::atomic::Ordering;
                        while !failed.load(Ordering::Relaxed) {
                            let i = next.fetch_add(1, Ordering::Relaxed);
                            let Some(spec) = templates.get(i) else {
                                break;
                            };
                            let result = compute(spec);
                            if result.is_err() {
                                failed.store(true, Ordering::Relaxed);
                            }
                            *slots[i].lock().expect("a reference computation panicked") =
                                Some(result);
                        }
                    });
                }
            });
            let mut results = Vec::new();
            for (spec, slot) in templates.iter().copied().zip(slots) {
                let Some(result) = slot.into_inner().expect("a reference computation panicked")
                else {
                    continue;
                };
                if let Some(r) = result? {
                    results.push((spec, r));
                }
            }
            for (spec, (method, result, solved_here)) in results {
                let reference = match result {
                    Ok(r) => r,
                    // A kind that goes on without its reference leaves the errors that need it
                    // empty, and the report says why.
                    Err(m) if kind.reference_optional() => {
                        progress.line(&format!(
                            "reference for {} failed, so error_at_stable_dt is left empty: {m}",
                            spec.scene
                        ));
                        failed_references.insert(
                            key(spec).expect("a template has a key"),
                            (reference_label(spec, None), m),
                        );
                        continue;
                    }
                    Err(m) => return Err(RunError::Run(format!("scene {}: {m}", spec.scene))),
                };
                let origin = match source {
                    Source::Local(_) if !solved_here => ", stored by an earlier invocation",
                    Source::Stored(_) if !solved_here => ", computed by another shard",
                    Source::Stored(_) => ", computed here for every shard",
                    _ => "",
                };
                progress.line(&format!(
                    "reference for {}: {} at dt = {:e} s, {:.3e} from {} ({:.1} s{origin})",
                    spec.scene,
                    method.name(),
                    reference.dt,
                    reference.difference,
                    reference.checked_against(),
                    reference.wall_seconds
                ));
                let label = reference_label(spec, reference.same_dt.then_some(reference.dt));
                references.insert(key(spec).expect("a template has a key"), (label, reference));
            }
        }
        Ok(Self {
            omega,
            references,
            failed_references,
            keys,
        })
    }

    /// What one run gets.
    pub(in crate::study) fn of(&self, spec: &RunSpec) -> RunInputs<'_> {
        let key = self.keys.get(&spec.id).copied().unwrap_or(spec.physics);
        RunInputs {
            omega: self.omega.get(&spec.physics).copied().flatten(),
            reference: self.references.get(&key).map(|(_, r)| r),
            meter: None,
        }
    }
}

/// Where a worker leaves the reference it computed (or why it could not).
type Slot = std::sync::Mutex<Option<Result<Option<Solved>, RunError>>>;

/// The name of a stored item: a hash of what determines it and of the softbench version.
fn item_key(what: &serde_json::Value) -> String {
    let document = serde_json::json!({
        "version": env!("CARGO_PKG_VERSION"),
        "what": what,
    });
    format!(
        "{:016x}",
        crate::study::vocabulary::identity::fnv1a(document.to_string().as_bytes())
    )
}

/// How the report names a reference: its scene and material (references differ by material
/// within a scene), and the runs' dt for a same-dt reference.
fn reference_label(spec: &RunSpec, same_dt: Option<f64>) -> String {
    match (&spec.loaded.config.material, same_dt) {
        (Some(m), Some(dt)) => format!("{} ({}, dt = {} s)", spec.scene, m.model, dt),
        (Some(m), None) => format!("{} ({})", spec.scene, m.model),
        (None, _) => spec.scene.clone(),
    }
}
