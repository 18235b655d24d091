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

/// Takes no step: records the rayon thread index `advance` ran on, queries an obstacle three
/// times and asks whether the run's budget is passed.
struct Probe {
    explicit: bool,
    seen: Mutex<Vec<Option<usize>>>,
}

impl Probe {
    fn new(explicit: bool) -> Self {
        Self {
            explicit,
            seen: Mutex::new(Vec::new()),
        }
    }

    fn last(&mut self) -> Option<usize> {
        *self.seen.get_mut().unwrap().last().expect("a step")
    }
}

impl Integrator for Probe {
    fn name(&self) -> &'static str {
        "probe"
    }
    fn order(&self) -> u32 {
        1
    }
    fn is_explicit(&self) -> bool {
        self.explicit
    }
    fn advance(
        &mut self,
        model: &mut Model,
        _state: &mut State,
        _dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        self.seen
            .get_mut()
            .unwrap()
            .push(rayon::current_thread_index());
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
    let mut integ = Probe::new(explicit);
    let mut state = State::at_rest(model);
    integ.step(model, &mut state, 0.01).unwrap();
    assert_eq!(state.t, 0.01, "the step's bookkeeping still runs");
    assert_eq!(integ.seen.get_mut().unwrap().len(), 1);
    integ.last()
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

#[test]
fn the_runs_budget_and_its_obstacle_queries_follow_a_step_onto_the_pool() {
    let _ = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build_global();
    let mut model = block([8, 8, 8], Parallelism::Rayon);
    assert!(model.element_loops_split(true));
    let mut state = State::at_rest(&model);
    let mut probe = Probe::new(false);

    // No budget armed: the step succeeds on a pool thread, its queries counted here.
    let before = query_count();
    probe.step(&mut model, &mut state, 0.01).unwrap();
    assert!(probe.last().is_some(), "the step ran on the pool");
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
    assert!(probe.last().is_some());
    drop(armed);
    // The pool threads keep no guard of their own afterwards.
    probe.step(&mut model, &mut state, 0.01).unwrap();
    let pool_guard_left =
        rayon::broadcast(|_| cost_guard::over_budget(u64::MAX, u64::MAX, u64::MAX).is_some());
    assert_eq!(pool_guard_left, vec![false, false]);
}
