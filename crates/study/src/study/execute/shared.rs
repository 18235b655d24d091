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
use crate::study::kind::{Measure, RunInputs};
use crate::study::vocabulary::error::RunError;
use crate::study::vocabulary::reference::{
    self, Reference, ScoringSettings, StoredReference, reference_key,
};
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
        let preparing = Preparing {
            study,
            kind: crate::study::kinds::measure(study.kind),
            source,
            workers,
            progress,
        };
        // (A reference without a set method also picks it from omega_max.)
        let omega = if preparing.kind.needs_omega(&study.file) {
            preparing.highest_modes(runs)?
        } else {
            HashMap::new()
        };
        // Each run's reference settings (a kind may give every scene its own) and key.
        let keys: HashMap<String, u64> = study
            .runs
            .iter()
            .filter_map(|s| Some((s.id.clone(), reference_key(&preparing.settings_of(s)?, s))))
            .collect();
        let (references, failed_references) = preparing.references(runs, &omega, &keys)?;
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

/// The shared work of one invocation being prepared.
struct Preparing<'a> {
    study: &'a Study,
    kind: &'static dyn Measure,
    source: Source<'a>,
    workers: &'a Workers<'a>,
    progress: &'a Progress,
}

/// References by key, and the failed ones (scene and message) by key.
type References = (
    BTreeMap<u64, (String, Reference)>,
    BTreeMap<u64, (String, String)>,
);

impl Preparing<'_> {
    /// The settings of the reference `spec` is scored against, if any.
    fn settings_of(&self, spec: &RunSpec) -> Option<ScoringSettings> {
        self.kind.reference_settings(&self.study.file, spec)
    }

    /// What a progress line says while waiting for another process computing `what`.
    fn on_wait(&self, what: &str) -> impl Fn(&softbench_run::lock::Waiting) + '_ {
        let what = what.to_owned();
        move |holder: &softbench_run::lock::Waiting| {
            self.progress
                .line(&format!("waiting for {holder} to compute the {what}"));
        }
    }

    /// The highest mode of each physics the `runs` need, from the first run of the study
    /// with it (`None` where it could not be computed; left out where a merge finds none
    /// stored).
    fn highest_modes(&self, runs: &[&RunSpec]) -> Result<HashMap<u64, Option<f64>>, RunError> {
        let Workers {
            parallelism,
            threads,
            ..
        } = *self.workers;
        // The first run of the study with each physics the runs need, in grid order.
        let mut templates: Vec<&RunSpec> = Vec::new();
        for spec in &self.study.runs {
            if runs.iter().any(|r| r.physics == spec.physics)
                && !templates.iter().any(|t| t.physics == spec.physics)
            {
                templates.push(spec);
            }
        }
        let mut omega = HashMap::new();
        for spec in &templates {
            let task = format!("highest mode of {}", spec.scene);
            let compute = || {
                self.progress.start(&task);
                let value = threads.install(|| {
                    crate::study::vocabulary::measured::build(spec, parallelism)
                        .map_err(|e| e.to_string())
                        .and_then(|mut scene| {
                            crate::study::vocabulary::measured::highest_mode_at_rest(&mut scene)
                        })
                        .map(|m| m.omega)
                        .ok()
                });
                self.progress.finish(&task);
                value
            };
            let key = format!("omega-{}", item_key(&serde_json::json!(spec.physics)));
            let value = match self.source {
                Source::Local(store) | Source::Stored(store) => Some(
                    store
                        .get_or_compute(
                            &key,
                            self.on_wait(&task),
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
        Ok(omega)
    }

    /// One reference per key (physics, and dt with `same_dt`) the `runs` need, from the first
    /// run of the study with each key, `jobs` of them at a time (each is independent); the
    /// progress says where each came from.
    fn references(
        &self,
        runs: &[&RunSpec],
        omega: &HashMap<u64, Option<f64>>,
        keys: &HashMap<String, u64>,
    ) -> Result<References, RunError> {
        let key = |s: &RunSpec| keys.get(&s.id).copied();
        let mut templates: Vec<&RunSpec> = Vec::new();
        for spec in &self.study.runs {
            if key(spec).is_some()
                && runs.iter().any(|r| key(r) == key(spec))
                && !templates.iter().any(|t| key(t) == key(spec))
            {
                templates.push(spec);
            }
        }
        let results = in_turn(self.workers.jobs, &templates, |spec| {
            self.reference(spec, omega)
        })?;
        let mut references = BTreeMap::new();
        let mut failed_references = BTreeMap::new();
        for (spec, (method, result, solved_here)) in results {
            let reference = match result {
                Ok(r) => r,
                // A kind that goes on without its reference leaves the errors that need it
                // empty, and the report says why.
                Err(m) if self.kind.reference_optional() => {
                    self.progress.line(&format!(
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
            let origin = match self.source {
                Source::Local(_) if !solved_here => ", stored by an earlier invocation",
                Source::Stored(_) if !solved_here => ", computed by another shard",
                Source::Stored(_) => ", computed here for every shard",
                _ => "",
            };
            self.progress.line(&format!(
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
        Ok((references, failed_references))
    }

    /// The reference of the runs like `spec`: computed here (and stored), or read from the
    /// study folder; `None` where a merge finds none stored.
    fn reference(
        &self,
        spec: &RunSpec,
        omega: &HashMap<u64, Option<f64>>,
    ) -> Result<Option<Solved>, RunError> {
        let Workers {
            parallelism,
            threads,
            ..
        } = *self.workers;
        let w = &self
            .settings_of(spec)
            .expect("a run with a reference key has settings");
        let dt = self.kind.reference_dt(self.study, w, spec);
        let method = w.reference.method.unwrap_or_else(|| {
            // Same dt: the converged backward Euler step. Otherwise RK4 where it is stable at
            // dt (its limit is 2.83 / omega_max), else the second-order implicit midpoint rule.
            let name = match omega.get(&spec.physics).copied().flatten() {
                _ if w.reference.same_dt => "backward-euler",
                Some(w) if dt < 2.5 / w => "rk4",
                _ => "implicit-midpoint",
            };
            Method::from_name(name).expect("a built-in method")
        });
        let task = reference_task(spec, w, method, dt);
        let solved_here = std::cell::Cell::new(false);
        let solve = || {
            solved_here.set(true);
            self.progress.start(&task);
            let result = threads.install(|| reference::reference(spec, w, method, dt, parallelism));
            self.progress.finish(&task);
            result
        };
        let key = format!(
            "reference-{}",
            item_key(&serde_json::json!({
                "physics": spec.physics,
                "method": method.name(),
                "dt": bits(dt),
                "settings": w,
                // The template run matters through its integrator settings, which a
                // reference with the default integrator does not take.
                "template": (!w.reference.default_integrator).then_some(&spec.hash),
            }))
        );
        let stored =
            |r: Result<StoredReference, String>| r.and_then(|s| Reference::from_stored(&s));
        let result = match self.source {
            Source::Local(store) | Source::Stored(store) => Some(stored(store.get_or_compute(
                &key,
                self.on_wait(&task),
                || solve().map(|r| r.stored()),
                |_| softbench_core::interrupt::requested().is_none(),
            )?)),
            Source::ReadOnly(store) => store
                .read::<Result<StoredReference, String>>(&key)?
                .map(stored),
        };
        Ok(result.map(|r| (method, r, solved_here.get())))
    }
}

/// What the progress says while a reference is computed.
fn reference_task(spec: &RunSpec, w: &ScoringSettings, method: Method, dt: f64) -> String {
    if w.reference.same_dt {
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
    }
}

/// `compute` of every item, `jobs` workers taking the next item as they finish one (items
/// differ in cost by orders of magnitude, so fixed groups would wait for their slowest); after
/// a failure no new one is started. The results are in item order, without the items nobody
/// had (`None`); the first failure in item order is returned.
fn in_turn<'s, T: Send>(
    jobs: usize,
    items: &[&'s RunSpec],
    compute: impl Fn(&RunSpec) -> Result<Option<T>, RunError> + Sync,
) -> Result<Vec<(&'s RunSpec, T)>, RunError> {
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
    let next = AtomicUsize::new(0);
    let failed = AtomicBool::new(false);
    // Where a worker leaves what it computed (or why it could not).
    type Slot<T> = std::sync::Mutex<Option<Result<Option<T>, RunError>>>;
    let slots: Vec<Slot<T>> = items.iter().map(|_| std::sync::Mutex::new(None)).collect();
    std::thread::scope(|scope| {
        for _ in 0..jobs.clamp(1, items.len().max(1)) {
            scope.spawn(|| {
                while !failed.load(Ordering::Relaxed) {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(spec) = items.get(i) else {
                        break;
                    };
                    let result = compute(spec);
                    if result.is_err() {
                        failed.store(true, Ordering::Relaxed);
                    }
                    *slots[i].lock().expect("a shared computation panicked") = Some(result);
                }
            });
        }
    });
    let mut results = Vec::new();
    for (spec, slot) in items.iter().copied().zip(slots) {
        let Some(result) = slot.into_inner().expect("a shared computation panicked") else {
            continue;
        };
        if let Some(r) = result? {
            results.push((spec, r));
        }
    }
    Ok(results)
}

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
