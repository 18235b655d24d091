//! The time a study has left, estimated from what its runs have cost so far.
//!
//! Runs differ by orders of magnitude, so a rate of finished runs per second says little
//! (and indicatif's, which decays while no run finishes, balloons while a long run is in
//! flight). Here every run has a size known before it starts, planned steps × a per-step
//! weight; the finished runs, and the running ones past a tenth of their steps, give seconds
//! per unit of size per group (scene, method, linear solver, settings), else per scene, else
//! over all runs; and the runs left (the running ones from their step counts) are laid out
//! on the jobs as the runner hands them out. Setup and teardown are timed apart from the
//! steps, so a run that blows up after a few steps does not make every step look as dear.
//!
//! [`Eta`] is pure: the runner feeds it events with times in seconds from any fixed origin,
//! and it never reads a clock, so tests replay synthetic schedules.

use crate::study::vocabulary::identity::value_text;
use crate::study::vocabulary::spec::{RunSpec, Study};
use std::collections::HashMap;

/// A run as planned, before it starts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(in crate::study) struct Planned {
    /// Runs of one scene are expected to cost about the same per unit of size; a small
    /// integer, an index into a table.
    pub scene: usize,
    /// Runs of one group, within a scene, are expected to cost the same per unit of size
    /// (see [`plan`]); an index too.
    pub group: usize,
    /// The steps the run is expected to take (0 for a run with nothing to do).
    pub steps: f64,
    /// The cost of one of its steps relative to other runs' (free DOFs × the method's
    /// weight, as the shard balance estimates it).
    pub step_weight: f64,
}

impl Planned {
    fn size(&self) -> f64 {
        self.steps.max(0.0) * self.step_weight.max(0.0)
    }
}

/// The plan of `runs` of `study`, in order: each run's scene and group, the steps its kind
/// expects it to take, and the shard balance's cost of one of its steps. A group is a scene,
/// method and linear solver with the same values of the other swept parameters (a contact
/// response or a stiffness changes what a step costs) except those that only change how
/// many steps a run takes, which its size counts.
pub(in crate::study) fn plan(study: &Study, runs: &[&RunSpec]) -> Vec<Planned> {
    let counted = |name: &str| matches!(name, "run.dt" | "run.steps");
    let mut scenes: HashMap<&str, usize> = HashMap::new();
    let mut groups: HashMap<String, usize> = HashMap::new();
    runs.iter()
        .map(|r| {
            let mut key = format!(
                "{}\u{1f}{}\u{1f}{}",
                r.scene,
                r.method.name(),
                r.linear_solver.as_ref().map_or("", |s| s.name())
            );
            for (name, value) in study.parameters.iter().zip(&r.parameters) {
                if !counted(name) {
                    key.push('\u{1f}');
                    key.push_str(&value.as_ref().map_or(String::new(), value_text));
                }
            }
            let (next_scene, next_group) = (scenes.len(), groups.len());
            Planned {
                scene: *scenes.entry(&r.scene).or_insert(next_scene),
                group: *groups.entry(key).or_insert(next_group),
                steps: r.estimated_steps,
                step_weight: crate::study::vocabulary::shard::step_weight(r),
            }
        })
        .collect()
}

/// The fraction of its planned steps a running run must have done before its rate so far
/// counts (its first steps may carry a factorization's analysis).
const ENOUGH_OF_A_RUN: f64 = 0.1;

/// Where a run is.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    Queued,
    /// Already complete before this invocation: neither work done now nor work left.
    Skipped,
    /// Running since `started`, stepping since `stepping` (its setup done); `steps` done,
    /// the last at `moved` (`stepping` before the first).
    Running {
        started: f64,
        stepping: Option<f64>,
        steps: f64,
        moved: f64,
    },
    Finished,
}

/// Seconds spent stepping and size done: a cost per unit of size once `size` is positive.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Evidence {
    seconds: f64,
    size: f64,
}

impl Evidence {
    fn add(&mut self, seconds: f64, size: f64) {
        self.seconds += seconds.max(0.0);
        self.size += size;
    }

    /// Seconds per unit of size (ratio of sums: big runs weigh most).
    fn rate(&self) -> Option<f64> {
        (self.size > 0.0).then(|| self.seconds / self.size)
    }
}

/// Stepping evidence per group, per scene and over every run.
#[derive(Clone, Debug, Default, PartialEq)]
struct Rates {
    groups: Vec<Evidence>,
    scenes: Vec<Evidence>,
    pooled: Evidence,
}

impl Rates {
    fn add(&mut self, p: &Planned, seconds: f64, size: f64) {
        self.groups[p.group].add(seconds, size);
        self.scenes[p.scene].add(seconds, size);
        self.pooled.add(seconds, size);
    }

    /// Seconds per unit of size for a run: its group's, else its scene's (scenes differ in
    /// what a DOF costs), else every run's.
    fn rate(&self, p: &Planned) -> Option<f64> {
        self.groups[p.group]
            .rate()
            .or_else(|| self.scenes[p.scene].rate())
            .or_else(|| self.pooled.rate())
    }

    /// Becomes a copy of `other`, in its own storage.
    fn copy_from(&mut self, other: &Rates) {
        self.groups.clone_from(&other.groups);
        self.scenes.clone_from(&other.scenes);
        self.pooled = other.pooled;
    }
}

/// A mean of seconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Mean {
    sum: f64,
    count: f64,
}

impl Mean {
    fn add(&mut self, seconds: f64) {
        self.sum += seconds.max(0.0);
        self.count += 1.0;
    }

    fn get(&self) -> Option<f64> {
        (self.count > 0.0).then(|| self.sum / self.count)
    }
}

/// What runs spend besides their steps: the setup before the first (building the scene and
/// the pictures' surface) and the teardown after the last (the outcome, the pictures' last
/// frames, the cells). A run that blows up after a few steps is mostly these, and its few
/// steps must not carry them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Overhead {
    setup: Mean,
    teardown: Mean,
}

/// The estimator: the plan, the runs' events, and what the runs so far cost.
#[derive(Clone, Debug)]
pub(in crate::study) struct Eta {
    plan: Vec<Planned>,
    phase: Vec<Phase>,
    jobs: usize,
    /// Finished runs' stepping (indexed by [`Planned::group`] and [`Planned::scene`]).
    finished: Rates,
    /// Scratch: the finished runs' and the running runs' so far (allocated once).
    so_far: Rates,
    /// Overheads per scene, and over every run.
    scene_overheads: Vec<Overhead>,
    pooled_overhead: Overhead,
    /// Scratch for the schedule: when each job is free (allocated once).
    free_at: Vec<f64>,
}

impl Eta {
    /// An estimator for `plan`, in the order the runs are handed out, run `jobs` at a time.
    pub(in crate::study) fn new(plan: Vec<Planned>, jobs: usize) -> Self {
        let jobs = jobs.max(1);
        let groups = plan.iter().map(|p| p.group + 1).max().unwrap_or(0);
        let scenes = plan.iter().map(|p| p.scene + 1).max().unwrap_or(0);
        Self {
            phase: vec![Phase::Queued; plan.len()],
            plan,
            jobs,
            finished: Rates {
                groups: vec![Evidence::default(); groups],
                scenes: vec![Evidence::default(); scenes],
                pooled: Evidence::default(),
            },
            so_far: Rates {
                groups: vec![Evidence::default(); groups],
                scenes: vec![Evidence::default(); scenes],
                pooled: Evidence::default(),
            },
            scene_overheads: vec![Overhead::default(); scenes],
            pooled_overhead: Overhead::default(),
            free_at: Vec::with_capacity(jobs),
        }
    }

    /// Run `run` was complete already and is not run now.
    pub(in crate::study) fn skip(&mut self, run: usize) {
        self.phase[run] = Phase::Skipped;
    }

    /// Run `run` started at `now`.
    pub(in crate::study) fn start(&mut self, run: usize, now: f64) {
        self.phase[run] = Phase::Running {
            started: now,
            stepping: None,
            steps: 0.0,
            moved: now,
        };
    }

    /// Run `run` finished its setup and began stepping at `at` (later calls change nothing).
    pub(in crate::study) fn stepping(&mut self, run: usize, at: f64) {
        if let Phase::Running {
            started,
            stepping: stepping @ None,
            moved,
            ..
        } = &mut self.phase[run]
        {
            *stepping = Some(at);
            *moved = at;
            let setup = at - *started;
            self.scene_overheads[self.plan[run].scene].setup.add(setup);
            self.pooled_overhead.setup.add(setup);
        }
    }

    /// Run `run` has done `steps` steps, the last at `at` (calls that do not change the count
    /// change nothing).
    pub(in crate::study) fn progress(&mut self, run: usize, steps: f64, at: f64) {
        if let Phase::Running {
            steps: done, moved, ..
        } = &mut self.phase[run]
            && steps != *done
        {
            *done = steps;
            *moved = at;
        }
    }

    /// Run `run` finished at `now` having done `steps` steps (`None`: its kind counts none, so
    /// it did what was planned, and all its time counts as stepping). A run that stopped
    /// early (a blow-up) is evidence for the steps it did; one that took more steps than
    /// planned counts as planned, the rate per planned step carrying the difference to the
    /// runs like it. Feed its last [`Eta::progress`] first.
    pub(in crate::study) fn finish(&mut self, run: usize, steps: Option<f64>, now: f64) {
        let Phase::Running {
            started,
            stepping,
            moved,
            ..
        } = self.phase[run]
        else {
            return;
        };
        self.phase[run] = Phase::Finished;
        let planned = self.plan[run];
        let seconds = match (stepping, steps) {
            (Some(stepping), Some(_)) => {
                let teardown = now - moved;
                self.scene_overheads[planned.scene].teardown.add(teardown);
                self.pooled_overhead.teardown.add(teardown);
                moved - stepping
            }
            _ => now - started,
        };
        let done = steps.map_or(planned.steps, |s| s.clamp(0.0, planned.steps.max(0.0)));
        let size = done * planned.step_weight.max(0.0);
        if size > 0.0 {
            self.finished.add(&planned, seconds, size);
        }
    }

    /// The finished runs' evidence, and that of the running runs past [`ENOUGH_OF_A_RUN`] of
    /// their steps for the steps they have done, into `so_far`: a long run in flight tells
    /// what its like cost before it ends.
    fn gather(&mut self) {
        self.so_far.copy_from(&self.finished);
        for (planned, phase) in self.plan.iter().zip(&self.phase) {
            if let Phase::Running {
                stepping: Some(stepping),
                steps,
                moved,
                ..
            } = *phase
                && steps > 0.0
                && steps >= ENOUGH_OF_A_RUN * planned.steps
            {
                let size = steps.min(planned.steps) * planned.step_weight.max(0.0);
                self.so_far.add(planned, moved - stepping, size);
            }
        }
    }

    /// The estimated seconds until every run has finished, as of `now`; `None` until some
    /// run has finished, or enough of one has run, to estimate from.
    pub(in crate::study) fn remaining(&mut self, now: f64) -> Option<f64> {
        self.gather();
        let so_far = &self.so_far;
        let rate = |p: &Planned| so_far.rate(p);
        let (overheads, pooled_overhead) = (&self.scene_overheads, &self.pooled_overhead);
        // A run's setup and teardown: its scene's means, else every scene's, else none.
        let overhead = |p: &Planned, part: fn(&Overhead) -> Mean| {
            part(&overheads[p.scene])
                .get()
                .or_else(|| part(pooled_overhead).get())
                .unwrap_or(0.0)
        };
        let setup = |p: &Planned| overhead(p, |o| o.setup);
        let teardown = |p: &Planned| overhead(p, |o| o.teardown);
        self.free_at.clear();
        let mut any_left = false;
        for run in 0..self.plan.len() {
            let planned = self.plan[run];
            let Phase::Running {
                started,
                stepping,
                steps,
                moved,
            } = self.phase[run]
            else {
                continue;
            };
            any_left = true;
            let rate = rate(&planned)?;
            let step = planned.step_weight.max(0.0) * rate;
            let since = now - moved;
            let steps_left = (planned.steps - steps).max(0.0);
            let left = match stepping {
                // Still setting up: the rest of a setup like its scene's, then the rest.
                None => {
                    (setup(&planned) - (now - started)).max(0.0)
                        + planned.size() * rate
                        + teardown(&planned)
                }
                // Between step counts, count down within the current step only: a run slower
                // than its rate then holds its estimate instead of reaching zero.
                Some(_) if steps_left > 0.0 => {
                    steps_left * step - since.clamp(0.0, step) + teardown(&planned)
                }
                // Past its planned steps: the rest of a teardown like its scene's.
                Some(_) => (teardown(&planned) - since).max(0.0),
            };
            self.free_at.push(left.max(0.0));
        }
        while self.free_at.len() < self.jobs {
            self.free_at.push(0.0);
        }
        // The queued runs, in order, each to the job free first: as the runner hands them out.
        for run in 0..self.plan.len() {
            if self.phase[run] != Phase::Queued {
                continue;
            }
            any_left = true;
            let planned = self.plan[run];
            let seconds = setup(&planned) + planned.size() * rate(&planned)? + teardown(&planned);
            let first = self
                .free_at
                .iter_mut()
                .min_by(|a, b| a.total_cmp(b))
                .expect("at least one job");
            *first += seconds;
        }
        if !any_left {
            return Some(0.0);
        }
        Some(self.free_at.iter().copied().fold(0.0, f64::max))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A consistent cost model: a run of scene s sets up in `setup[s]` seconds, then takes
    /// `cost[g]` seconds per unit of size for group g, then `teardown[s]` seconds.
    struct Model {
        setup: Vec<f64>,
        cost: Vec<f64>,
        teardown: Vec<f64>,
    }

    /// A run of `group`, each group its own scene.
    fn run(group: usize, steps: f64, step_weight: f64) -> Planned {
        Planned {
            scene: group,
            group,
            steps,
            step_weight,
        }
    }

    /// Replays `plan` on `jobs` jobs as the runner does (each run to the job free first, in
    /// order), runs taking the model's time (or `stops[i]` steps of it, for a run that stops
    /// early), feeding `eta` each run's start, setup's end, steps and end. Calls `look(eta,
    /// now, next, true_remaining, finished)` after every event, `next` the next one's time.
    fn replay(
        eta: &mut Eta,
        plan: &[Planned],
        order: &[usize],
        jobs: usize,
        model: &Model,
        stops: &[Option<f64>],
        mut look: impl FnMut(&mut Eta, f64, f64, f64, bool),
    ) -> f64 {
        // Schedule: start and end of every run (the truth).
        let mut free = vec![0.0f64; jobs];
        let mut span = vec![(0.0, 0.0); plan.len()];
        for &i in order {
            let (job, _) = free
                .iter()
                .enumerate()
                .min_by(|a, b| a.1.total_cmp(b.1))
                .unwrap();
            let steps = stops[i].unwrap_or(plan[i].steps);
            let per_step = plan[i].step_weight * model.cost[plan[i].group];
            let scene = plan[i].scene;
            let end = free[job] + model.setup[scene] + steps * per_step + model.teardown[scene];
            span[i] = (free[job], end);
            free[job] = end;
        }
        let finish = free.iter().copied().fold(0.0, f64::max);
        // Events in time order: starts, setups' ends, step counts, finishes.
        let mut events: Vec<(f64, usize, u8, f64)> = Vec::new();
        for &i in order {
            let (start, end) = span[i];
            let stepping = start + model.setup[plan[i].scene];
            let stepped = end - model.teardown[plan[i].scene];
            let steps = stops[i].unwrap_or(plan[i].steps);
            events.push((start, i, 0, 0.0));
            events.push((stepping, i, 3, 0.0));
            let n = steps as usize;
            for k in 1..=n {
                let t = stepping + (stepped - stepping) * k as f64 / steps;
                events.push((t, i, 1, k as f64));
            }
            events.push((end, i, 2, steps));
        }
        // Stable: at equal times, in the order pushed (a run's start before its finish, and
        // a run's finish before the start of the run that waited for its job).
        events.sort_by(|a, b| a.0.total_cmp(&b.0));
        for (k, &(t, i, what, steps)) in events.iter().enumerate() {
            match what {
                0 => eta.start(i, t),
                1 => eta.progress(i, steps, t),
                2 => eta.finish(i, Some(steps), t),
                _ => eta.stepping(i, t),
            }
            let next = events.get(k + 1).map_or(t, |e| e.0);
            look(eta, t, next, finish - t, what == 2);
        }
        finish
    }

    fn mixed_plan() -> Vec<Planned> {
        vec![
            run(0, 20.0, 1.0),
            run(1, 100.0, 30.0),
            run(0, 400.0, 1.0),
            run(1, 10.0, 30.0),
            run(2, 0.0, 5.0),
            run(0, 50.0, 8.0),
            run(1, 200.0, 30.0),
            run(0, 5.0, 1.0),
        ]
    }

    fn model() -> Model {
        // Per unit of size, group 1 costs twice group 0; group 2 runs have no size. Setups
        // differ by at most 2x too.
        Model {
            setup: vec![0.5, 1.0, 0.75],
            cost: vec![0.01, 0.02, 0.03],
            teardown: vec![0.2, 0.1, 0.15],
        }
    }

    #[test]
    fn a_plan_groups_runs_by_scene_method_and_settings_but_not_by_time_step() {
        let shipped = |name: &str| {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../..")
                .join(name);
            crate::study::plan::load::load(&path, true, &softbench_run::data::DataPaths::new(None))
                .unwrap()
        };
        // Methods × dt on two scenes; methods × Young's modulus on one.
        for study in [
            shipped("experiments/energy_drift.toml"),
            shipped("experiments/stiffness_sweep.toml"),
        ] {
            let runs: Vec<&RunSpec> = study.runs.iter().collect();
            let plan = plan(&study, &runs);
            let stiffness =
                |r: &RunSpec| r.loaded.config.material.as_ref().map(|m| m.youngs_modulus);
            for (a, pa) in runs.iter().zip(&plan) {
                assert_eq!(pa.steps, a.estimated_steps);
                assert!(pa.step_weight >= a.dofs as f64 && a.dofs > 0);
                for (b, pb) in runs.iter().zip(&plan) {
                    assert_eq!(pa.scene == pb.scene, a.scene == b.scene);
                    let alike = a.scene == b.scene
                        && a.method.name() == b.method.name()
                        && stiffness(a) == stiffness(b);
                    assert_eq!(pa.group == pb.group, alike, "{} and {}", a.id, b.id);
                }
            }
        }
    }

    #[test]
    fn no_estimate_before_a_run_finishes_or_enough_of_one_has_run() {
        let mut eta = Eta::new(vec![run(0, 100.0, 1.0), run(0, 100.0, 1.0)], 1);
        assert_eq!(eta.remaining(0.0), None);
        eta.start(0, 0.0);
        eta.stepping(0, 0.0);
        eta.progress(0, 5.0, 5.0);
        assert_eq!(eta.remaining(5.0), None, "5% of a run is not enough");
        eta.progress(0, 10.0, 10.0);
        // 1 s a step: 90 s left of this run, 100 s of the next.
        assert_eq!(eta.remaining(10.0), Some(190.0));
    }

    #[test]
    fn after_every_finished_run_the_estimate_is_within_a_factor_of_the_truth() {
        let plan = mixed_plan();
        let order: Vec<usize> = (0..plan.len()).collect();
        let stops = vec![None; plan.len()];
        let model = model();
        for jobs in [1, 2, 3] {
            let mut eta = Eta::new(plan.clone(), jobs);
            replay(
                &mut eta,
                &plan,
                &order,
                jobs,
                &model,
                &stops,
                |eta, now, _, truth, finished| {
                    if !finished {
                        return;
                    }
                    // Whether the runs left are all of groups whose rate and overheads
                    // finished runs have told (each group its own scene here).
                    let told = (0..plan.len()).all(|i| {
                        let p = &plan[i];
                        matches!(eta.phase[i], Phase::Finished)
                            || (eta.scene_overheads[p.scene].teardown.count > 0.0
                                && (p.size() == 0.0 || eta.finished.groups[p.group].size > 0.0))
                    });
                    let estimate = eta.remaining(now).expect("a run has finished");
                    // The groups' costs and setups differ by 2x, so before a group's first
                    // run has finished the pooled rate is off by at most that, give or take
                    // the countdown within a running step (at most one step, 0.6 s here);
                    // once the groups of every run left are told it is exact.
                    let (factor, slack) = if told { (1.0, 1e-9) } else { (2.0, 0.6) };
                    assert!(
                        estimate <= factor * (truth + slack)
                            && truth <= factor * (estimate + slack),
                        "{jobs} jobs at {now}: estimate {estimate}, truth {truth}"
                    );
                },
            );
        }
    }

    #[test]
    fn the_estimate_never_grows_when_runs_cost_what_the_finished_ones_did() {
        // One small run first sets each group's rate; then nothing surprises.
        let plan = vec![
            run(0, 10.0, 1.0),
            run(1, 10.0, 3.0),
            run(0, 300.0, 1.0),
            run(1, 80.0, 3.0),
            run(0, 1000.0, 1.0),
            run(1, 5.0, 3.0),
        ];
        let order: Vec<usize> = (0..plan.len()).collect();
        let model = Model {
            setup: vec![0.3, 0.1],
            cost: vec![0.01, 0.05],
            teardown: vec![0.05, 0.2],
        };
        for jobs in [1, 2] {
            let mut eta = Eta::new(plan.clone(), jobs);
            let mut last: Option<f64> = None;
            let mut both_known = false;
            let stops = vec![None; plan.len()];
            replay(
                &mut eta,
                &plan,
                &order,
                jobs,
                &model,
                &stops,
                |eta, now, next, truth, _| {
                    both_known |=
                        eta.finished.groups[0].size > 0.0 && eta.finished.groups[1].size > 0.0;
                    if !both_known {
                        return;
                    }
                    // Halfway to the next event too: the countdown within a step.
                    for at in [now, 0.5 * (now + next)] {
                        let estimate = eta.remaining(at).unwrap();
                        if let Some(last) = last {
                            assert!(
                                estimate <= last + 1e-9,
                                "{jobs} jobs at {now}: {estimate} after {last}"
                            );
                        }
                        last = Some(estimate);
                    }
                    let estimate = eta.remaining(now).unwrap();
                    assert!((estimate - truth).abs() <= 1e-6 * truth.max(1.0));
                },
            );
        }
    }

    #[test]
    fn a_group_with_no_finished_run_takes_its_scenes_rate_before_the_pooled_one() {
        // Scene 0 costs 1 s per unit, scene 1 costs 10; method groups 0 and 1 on scene 0,
        // 2 and 3 on scene 1.
        let on = |scene, group| Planned {
            scene,
            group,
            steps: 10.0,
            step_weight: 1.0,
        };
        let plan = vec![on(0, 0), on(1, 2), on(0, 1), on(1, 3)];
        let mut eta = Eta::new(plan, 1);
        eta.start(0, 0.0);
        eta.finish(0, None, 10.0);
        eta.start(1, 10.0);
        eta.finish(1, None, 110.0);
        // Group 1 (10 s at scene 0's rate) and group 3 (100 s at scene 1's); the pooled rate
        // (5.5 s a unit) would say 55 s each.
        assert_eq!(eta.remaining(110.0), Some(110.0));
    }

    #[test]
    fn parallel_jobs_share_the_work_left() {
        // Four equal runs, one finished: three left, of 10 s each.
        let plan = vec![run(0, 10.0, 1.0); 4];
        for (jobs, expected) in [(1, 30.0), (2, 20.0), (3, 10.0), (8, 10.0)] {
            let mut eta = Eta::new(plan.clone(), jobs);
            eta.start(0, 0.0);
            eta.finish(0, Some(10.0), 10.0);
            assert_eq!(eta.remaining(10.0), Some(expected), "{jobs} jobs");
        }
        // One long run in flight keeps one job busy while the other takes the short ones.
        let plan = vec![
            run(0, 10.0, 1.0),
            run(0, 100.0, 1.0),
            run(0, 10.0, 1.0),
            run(0, 10.0, 1.0),
        ];
        let mut eta = Eta::new(plan, 2);
        eta.start(0, 0.0);
        eta.start(1, 0.0);
        eta.stepping(1, 0.0);
        eta.finish(0, Some(10.0), 10.0);
        eta.start(2, 10.0);
        eta.progress(1, 10.0, 10.0);
        // Run 1 has 90 s left; runs 2 and 3 take 20 s on the other job.
        assert_eq!(eta.remaining(10.0), Some(90.0));
    }

    #[test]
    fn runs_already_complete_do_not_count_as_work_done_now() {
        let plan = mixed_plan();
        let model = model();
        let skipped = [1, 2, 5];
        let order: Vec<usize> = (0..plan.len()).filter(|i| !skipped.contains(i)).collect();
        let stops = vec![None; plan.len()];
        // The same study resumed with three runs complete, and a fresh study of the other
        // runs only: the same estimates at every event.
        let mut resumed = Eta::new(plan.clone(), 2);
        for &i in &skipped {
            resumed.skip(i);
        }
        let left: Vec<Planned> = order.iter().map(|&i| plan[i]).collect();
        let mut fresh = Eta::new(left.clone(), 2);
        let mut resumed_estimates = Vec::new();
        replay(
            &mut resumed,
            &plan,
            &order,
            2,
            &model,
            &stops,
            |eta, now, _, truth, _| resumed_estimates.push((eta.remaining(now), truth)),
        );
        let mut fresh_estimates = Vec::new();
        let fresh_order: Vec<usize> = (0..left.len()).collect();
        replay(
            &mut fresh,
            &left,
            &fresh_order,
            2,
            &model,
            &vec![None; left.len()],
            |eta, now, _, truth, _| fresh_estimates.push((eta.remaining(now), truth)),
        );
        assert_eq!(resumed_estimates, fresh_estimates);
        // Skipped runs are neither evidence nor work left.
        assert_eq!(resumed.finished.pooled, fresh.finished.pooled);
        assert_eq!(resumed.remaining(1e9), Some(0.0));
    }

    #[test]
    fn zero_size_runs_take_no_time_and_are_no_evidence() {
        let plan = vec![run(0, 0.0, 5.0), run(0, 10.0, 0.0), run(0, 10.0, 1.0)];
        let mut eta = Eta::new(plan, 1);
        eta.start(0, 0.0);
        // It spent 2 s on nothing: no rate from it.
        eta.finish(0, Some(0.0), 2.0);
        assert_eq!(eta.remaining(2.0), None);
        eta.start(1, 2.0);
        eta.finish(1, Some(10.0), 3.0);
        assert_eq!(eta.remaining(3.0), None);
        eta.start(2, 3.0);
        eta.stepping(2, 3.0);
        eta.progress(2, 5.0, 8.0);
        assert_eq!(eta.remaining(8.0), Some(5.0));
        eta.progress(2, 10.0, 13.0);
        eta.finish(2, Some(10.0), 13.0);
        assert_eq!(eta.remaining(13.0), Some(0.0));
        // Nothing but zero-size runs left: they take no time once a rate is known.
        let mut eta = Eta::new(vec![run(0, 10.0, 1.0), run(0, 0.0, 1.0)], 1);
        eta.start(0, 0.0);
        eta.finish(0, None, 10.0);
        assert_eq!(eta.remaining(10.0), Some(0.0));
    }

    #[test]
    fn a_first_run_that_stops_early_counts_the_steps_it_did() {
        // Run 0 sets up in 50 s, blows up after 4 of its 1000 steps, in 4 s (1 s a step), and
        // ends in 5 s. Counting its planned steps would say 59 ms a step, and the rest would
        // look 17x shorter than they are; counting its setup and teardown as steps, 14.75 s a
        // step and 9x longer.
        let plan = vec![run(0, 1000.0, 1.0), run(0, 100.0, 1.0), run(0, 100.0, 1.0)];
        let model = Model {
            setup: vec![50.0],
            cost: vec![1.0],
            teardown: vec![5.0],
        };
        let mut stops = vec![None; plan.len()];
        stops[0] = Some(4.0);
        let mut eta = Eta::new(plan.clone(), 1);
        let mut checked = false;
        replay(
            &mut eta,
            &plan,
            &[0, 1, 2],
            1,
            &model,
            &stops,
            |eta, now, _, truth, finished| {
                if finished && !checked {
                    checked = true;
                    assert_eq!(now, 59.0);
                    assert_eq!(eta.remaining(now), Some(truth));
                    assert_eq!(truth, 310.0);
                }
            },
        );
        assert!(checked);
        // A kind that counts no steps finishes as planned.
        let mut eta = Eta::new(plan, 1);
        eta.start(0, 0.0);
        eta.finish(0, None, 1000.0);
        assert_eq!(eta.remaining(1000.0), Some(200.0));
    }

    #[test]
    fn a_run_slower_than_its_rate_holds_its_estimate_and_then_tells_its_pace() {
        let plan = vec![run(0, 10.0, 1.0), run(0, 10.0, 1.0)];
        let mut eta = Eta::new(plan, 1);
        eta.start(0, 0.0);
        eta.finish(0, Some(10.0), 10.0);
        eta.start(1, 10.0);
        eta.stepping(1, 10.0);
        // Its first step is late: the estimate counts down one step (1 s) and waits.
        assert_eq!(eta.remaining(10.5), Some(9.5));
        assert_eq!(eta.remaining(11.0), Some(9.0));
        assert_eq!(eta.remaining(60.0), Some(9.0));
        // Half done after 50 s, past ENOUGH_OF_A_RUN: its own pace counts with the finished
        // run's, 60 s for 15 steps, so its 5 steps left take 20 s.
        eta.progress(1, 5.0, 60.0);
        assert_eq!(eta.remaining(60.0), Some(20.0));
    }
}
