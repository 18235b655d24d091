//! The claim that `factor` and `solve` allocate nothing once `analyze` (and a first warm-up
//! factorization) has run, checked with a counting global allocator (counted per thread, so
//! parallel tests do not interfere).

#[path = "support/grid_spd.rs"]
mod grid_spd;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use grid_spd::{Grid, Spec, rhs};
use softbench::solve::{LinearSolver, LinearSolverKind, Preconditioner, SolverSettings};

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations() -> usize {
    ALLOCATIONS.with(|c| c.get())
}

#[test]
fn factor_and_solve_allocate_nothing_after_analyze() {
    // Big enough that AUTO picks the supernodal path.
    let grid = Grid::new(8, 8, 8);
    let p = grid.pattern();
    let a1 = grid.matrix(&p, 1, &Spec::default());
    let a2 = grid.matrix(&p, 2, &Spec::default());
    let b = rhs(grid.dofs(), 3);
    let mut x = b.clone();
    let mut cases: Vec<(String, Box<dyn LinearSolver>)> = Vec::new();
    for kind in LinearSolverKind::all() {
        if kind == LinearSolverKind::from_name("cg").unwrap() {
            for preconditioner in [
                Preconditioner::None,
                Preconditioner::Jacobi,
                Preconditioner::BlockJacobi3,
                Preconditioner::IncompleteCholesky,
            ] {
                let mut settings = SolverSettings::default();
                settings.cg.preconditioner = preconditioner;
                settings.cg.warm_start = true;
                cases.push((format!("cg {preconditioner:?}"), kind.build(&settings)));
            }
        } else {
            cases.push((kind.to_string(), kind.build(&SolverSettings::default())));
        }
    }
    for (name, mut s) in cases {
        s.analyze(&p).unwrap();
        // The first numeric factorization on a thread lets faer's dense kernels set up their
        // per-thread state (a few hundred small allocations, once); warm up past it.
        s.factor(&a2).unwrap();
        s.solve(&mut x).unwrap();
        let before = allocations();
        for a in [&a1, &a2, &a1] {
            s.analyze(&p).unwrap();
            s.factor(a).unwrap();
            x.copy_from_slice(&b);
            s.solve(&mut x).unwrap();
        }
        assert_eq!(allocations() - before, 0, "{name}");
    }
}
