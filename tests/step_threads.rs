//! Where a step runs: a step whose element loops go parallel moves onto rayon's pool once, so
//! its many parallel calls (the factorization's kernels, the element loops) start from a pool
//! thread; a step too small for threads, a sequential model or an explicit step below the
//! gradient loop's rule stays on the caller and pays no entry.

use std::sync::Mutex;

use softbench::integrate::{Integrator, State, StepError, StepReport};
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
