//! Where a step runs: a step whose element loops go parallel moves onto rayon's pool once, so
//! its many parallel calls (the factorization's kernels, the element loops) start from a pool
//! thread; a step too small for threads, a sequential model or an explicit step below the
//! gradient loop's rule stays on the caller and pays no entry. The caller's per-thread state
//! follows the step: the run's cost budget goes in, the obstacle queries come back.

use std::sync::Mutex;

use nalgebra::Vector3;
use softbench::contact::{HalfSpace, Obstacle, Shape, query_count};
use softbench::integrate::{Integrator, State, StepError, StepReport, cost_guard};
use softbench::material::{LameParameters, MaterialModel};
use softbench::mesh::generate::box_mesh;
use softbench::model::{Model, ModelSpec};
use softbench::parallel::Parallelism;

/// Records the rayon thread index `advance` ran on; takes no step.
struct WhereItRuns {
    explicit: bool,
    seen: Mutex<Vec<Option<usize>>>,
}

impl Integrator for WhereItRuns {
    fn name(&self) -> &'static str {
        "where-it-runs"
    }
    fn order(&self) -> u32 {
        1
    }
    fn is_explicit(&self) -> bool {
        self.explicit
    }
    fn advance(
        &mut self,
        _model: &mut Model,
        _state: &mut State,
        _dt: f64,
        _report: &mut StepReport,
    ) -> Result<(), StepError> {
        self.seen
            .get_mut()
            .unwrap()
            .push(rayon::current_thread_index());
        Ok(())
    }
}

fn block(cells: [usize; 3], par: Parallelism) -> Model {
    let lame = LameParameters::from_youngs_poisson(1e5, 0.3).unwrap();
    let material = MaterialModel::from_name("stable-neo-hookean", lame).unwrap();
    let mut model = Model::new(ModelSpec::elastic(
        box_mesh(cells, [1.0, 1.0, 1.0]),
        material,
        1000.0,
    ))
    .unwrap();
    model.set_parallelism(par);
    model
}

/// The thread index `advance` saw in one step called from this (non-pool) thread.
fn stepped_on(model: &mut Model, explicit: bool) -> Option<usize> {
    let mut integ = WhereItRuns {
        explicit,
        seen: Mutex::new(Vec::new()),
    };
    let mut state = State::at_rest(model);
    integ.step(model, &mut state, 0.01).unwrap();
    assert_eq!(state.t, 0.01, "the step's bookkeeping still runs");
    let seen = integ.seen.into_inner().unwrap();
    assert_eq!(seen.len(), 1);
    seen[0]
}

#[test]
fn a_step_enters_the_pool_only_when_its_element_loops_split() {
    // Two threads whatever the machine has, so the rule is what decides.
    let _ = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build_global();
    assert!(rayon::current_thread_index().is_none());
    let threads = rayon::current_num_threads();
    assert!(threads > 1, "the global pool was built with two threads");

    let mut large = block([8, 8, 8], Parallelism::Rayon);
    let tets = large.elastic_elements().unwrap().tets.len();
    assert!((1024..16384).contains(&tets), "{tets} tets");
    assert!(large.element_loops_split(true) && !large.element_loops_split(false));
    // Implicit (Hessian) step on ≥ 1024 tets: on a pool thread.
    assert!(stepped_on(&mut large, false).is_some_and(|i| i < threads));
    // Explicit step below the gradient loop's 16,384 tets: on the caller.
    assert_eq!(stepped_on(&mut large, true), None);

    let mut small = block([2, 2, 2], Parallelism::Rayon);
    assert!(!small.element_loops_split(true));
    assert_eq!(stepped_on(&mut small, false), None);

    let mut sequential = block([8, 8, 8], Parallelism::Sequential);
    assert!(!sequential.element_loops_split(true));
    assert_eq!(stepped_on(&mut sequential, false), None);

    // Already on a pool thread: stays there (no second entry).
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let (inside, stepped) =
        pool.install(|| (rayon::current_thread_index(), stepped_on(&mut large, false)));
    assert_eq!(inside, stepped);
}

/// Inside its step: queries an obstacle three times, then asks whether the run's budget is
/// passed, recording the thread it ran on.
struct BudgetProbe {
    thread: Option<usize>,
}

impl Integrator for BudgetProbe {
    fn name(&self) -> &'static str {
        "budget-probe"
    }
    fn order(&self) -> u32 {
        1
    }
    fn is_explicit(&self) -> bool {
        false
    }
    fn advance(
        &mut self,
        model: &mut Model,
        _state: &mut State,
        _dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        self.thread = rayon::current_thread_index();
        let plane = Obstacle::new(Shape::HalfSpace(HalfSpace::new(
            Vector3::zeros(),
            Vector3::new(0.0, 1.0, 0.0),
        )));
        for _ in 0..3 {
            plane.sample(&Vector3::new(0.0, 1.0, 0.0), 0.0);
        }
        StepError::stop_if_over_budget(model, report)
    }
}

#[test]
fn the_runs_budget_and_its_obstacle_queries_follow_a_step_onto_the_pool() {
    let _ = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build_global();
    let mut model = block([8, 8, 8], Parallelism::Rayon);
    assert!(model.element_loops_split(true));
    let mut state = State::at_rest(&model);
    let mut probe = BudgetProbe { thread: None };

    // No budget armed: the step succeeds on a pool thread, its queries counted here.
    let before = query_count();
    probe.step(&mut model, &mut state, 0.01).unwrap();
    assert!(probe.thread.is_some(), "the step ran on the pool");
    assert_eq!(
        query_count(),
        before + 3,
        "the step's queries count on the caller"
    );

    // A budget armed on this thread (no wall time at all) stops the step on the pool thread.
    let armed = cost_guard::arm(Some(0.0), None, None, None, 0);
    std::thread::sleep(std::time::Duration::from_millis(2));
    match probe.step(&mut model, &mut state, 0.01) {
        Err(StepError::OverBudget { what, .. }) => assert_eq!(what, "wall_seconds"),
        other => panic!("the budget did not reach the pool thread: {other:?}"),
    }
    assert!(probe.thread.is_some());
    drop(armed);
    // The pool threads keep no guard of their own afterwards.
    probe.step(&mut model, &mut state, 0.01).unwrap();
    let pool_guard_left =
        rayon::broadcast(|_| cost_guard::over_budget(u64::MAX, u64::MAX, u64::MAX).is_some());
    assert_eq!(pool_guard_left, vec![false, false]);
}
