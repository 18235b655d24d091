//! A run's cost budget as the integrator sees it inside one step.
//!
//! The run loop checks `run.budget` after every step, which bounds the cost of every method
//! whose step is bounded (a Newton solve has its iteration cap, a local solver its sweeps).
//! An adaptive method covers its step with as many internal steps as its error control asks
//! for, so one step can cost thousands of factorizations: its loop asks [`over_budget`] before
//! each attempt, and stops with [`StepError::OverBudget`](super::StepError::OverBudget) once
//! the run's spending passes a limit. The run loop arms the guard for the run on its thread
//! ([`arm`]) and disarms it when the run ends ([`Armed`] does on drop), so a run without a
//! budget, or code that steps an integrator outside a run, never sees one.

use std::cell::Cell;
use std::time::Instant;

/// The limits of a run and what it had spent before the current step.
#[derive(Clone, Copy, Debug)]
struct Guard {
    start: Instant,
    wall_seconds: Option<f64>,
    evaluations: Option<f64>,
    factorizations: Option<f64>,
    linear_iterations: Option<f64>,
    /// The model's force + Hessian evaluation count when the run started.
    evaluations_at_start: u64,
    /// Factorizations and linear iterations of the steps before this one.
    factorizations_before: u64,
    linear_iterations_before: u64,
}

thread_local! {
    static GUARD: Cell<Option<Guard>> = const { Cell::new(None) };
}

/// A limit passed inside a step: the budget key, its limit and what was spent.
pub type Exceeded = (&'static str, f64, f64);

/// The guard of one run, armed on this thread until dropped.
pub struct Armed(());

impl Drop for Armed {
    fn drop(&mut self) {
        GUARD.with(|g| g.set(None));
    }
}

/// Arm the guard for a run on this thread: its limits (`None`: no limit) and the model's
/// force + Hessian evaluation count now.
pub fn arm(
    wall_seconds: Option<f64>,
    evaluations: Option<f64>,
    factorizations: Option<f64>,
    linear_iterations: Option<f64>,
    evaluations_at_start: u64,
) -> Armed {
    GUARD.with(|g| {
        g.set(Some(Guard {
            start: Instant::now(),
            wall_seconds,
            evaluations,
            factorizations,
            linear_iterations,
            evaluations_at_start,
            factorizations_before: 0,
            linear_iterations_before: 0,
        }))
    });
    Armed(())
}

/// The guard armed on this thread (or none), to carry into a step that runs on another
/// thread ([`super::on_pool`]): the guard lives in a thread-local, and a step that moves onto
/// rayon's pool must still see its run's budget.
#[derive(Clone, Copy, Debug)]
pub struct Carried(Option<Guard>);

/// What [`Carried::run`] sets back when it ends, even by a panic.
struct Restore(Option<Guard>);

impl Drop for Restore {
    fn drop(&mut self) {
        GUARD.with(|g| g.set(self.0));
    }
}

/// This thread's guard, to carry to another thread.
pub fn carry() -> Carried {
    Carried(GUARD.with(Cell::get))
}

impl Carried {
    /// Runs `f` with the carried guard armed on the current thread, then restores the
    /// thread's own.
    pub fn run<R>(self, f: impl FnOnce() -> R) -> R {
        let _restore = Restore(GUARD.with(|g| g.replace(self.0)));
        f()
    }
}

/// Record what the run's steps so far have spent (the run loop's totals), before a step.
pub fn before_step(factorizations: u64, linear_iterations: u64) {
    GUARD.with(|g| {
        if let Some(mut guard) = g.get() {
            guard.factorizations_before = factorizations;
            guard.linear_iterations_before = linear_iterations;
            g.set(Some(guard));
        }
    });
}

/// The first limit the run has passed, counting the current step's work so far: the model's
/// evaluation count now (`evaluations`, force + Hessian) and the step's `factorizations` and
/// `linear_iterations` so far. `None` when no guard is armed or every limit holds.
pub fn over_budget(
    evaluations: u64,
    factorizations: u64,
    linear_iterations: u64,
) -> Option<Exceeded> {
    let guard = GUARD.with(Cell::get)?;
    let spent = [
        (
            "wall_seconds",
            guard.wall_seconds,
            guard.start.elapsed().as_secs_f64(),
        ),
        (
            "evaluations",
            guard.evaluations,
            evaluations.saturating_sub(guard.evaluations_at_start) as f64,
        ),
        (
            "factorizations",
            guard.factorizations,
            (guard.factorizations_before + factorizations) as f64,
        ),
        (
            "linear_iterations",
            guard.linear_iterations,
            (guard.linear_iterations_before + linear_iterations) as f64,
        ),
    ];
    spent
        .into_iter()
        .find_map(|(key, limit, used)| limit.filter(|l| used > *l).map(|l| (key, l, used)))
}
