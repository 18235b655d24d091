//! The contact QP of one SQP iteration, solved by clarabel (interior point):
//!
//! `min 1/2 dx^T H dx + g^T dx  subject to  n_i . dx_(v_i) >= -sdf_i` for each contact row `i`,
//!
//! the quadratic model of the incremental potential with the non-penetration constraints
//! `n . (x - x_c) >= 0` linearized at the current iterate (`x_c = x - sdf n` is the nearest
//! surface point). In clarabel's form `A dx + s = b, s >= 0`: row `i` of `A` is `-n_i^T` on the
//! three DOFs of its vertex and `b_i = sdf_i`.

use crate::sparse::{SparsityPattern, SymmetricMatrix};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT,
    SolverStatus,
};
use nalgebra::Vector3;
use std::sync::Arc;
use std::time::Instant;

/// One linearized non-penetration constraint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactRow {
    /// Index of the vertex's first DOF (3 × its free index).
    pub dof: usize,
    /// Outward normal of the obstacle at the vertex.
    pub normal: Vector3<f64>,
    /// Signed distance of the vertex at the linearization point (m).
    pub distance: f64,
}

/// A solved QP.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct QpSolution {
    /// The step.
    pub dx: Vec<f64>,
    /// One multiplier (>= 0) per row: the contact impulse scaled by dt^2 (units of the
    /// objective per metre).
    pub multipliers: Vec<f64>,
    /// Interior-point iterations.
    pub iterations: u32,
    /// Wall time, setup included (s).
    pub seconds: f64,
}

/// The upper triangle of a pattern in CSC, and where each entry sits in the full values.
#[derive(Debug)]
struct UpperTriangle {
    pattern: Arc<SparsityPattern>,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    slots: Vec<usize>,
}

impl UpperTriangle {
    fn new(pattern: &Arc<SparsityPattern>) -> Self {
        let (mut col_ptr, mut row_idx, mut slots) = (vec![0], Vec::new(), Vec::new());
        for c in 0..pattern.dim() {
            for k in pattern.col_ptr()[c]..pattern.col_ptr()[c + 1] {
                if pattern.row_idx()[k] <= c {
                    row_idx.push(pattern.row_idx()[k]);
                    slots.push(k);
                }
            }
            col_ptr.push(row_idx.len());
        }
        Self {
            pattern: pattern.clone(),
            col_ptr,
            row_idx,
            slots,
        }
    }
}

/// Solves contact QPs over one Hessian pattern (its upper triangle is extracted once).
#[derive(Debug, Default)]
pub struct ContactQp {
    upper: Option<UpperTriangle>,
}

impl ContactQp {
    /// clarabel's settings: quiet, the default tolerances (1e-8), QDLDL for the KKT systems.
    /// (clarabel's `faer-sparse` feature solved the 1029-DOF ball's QP in 38 ms instead of
    /// 65 ms, but it builds a second faer version, about 7 minutes on 2 cores for every clean
    /// build; the constrained response is not worth that.)
    fn settings() -> DefaultSettings<f64> {
        DefaultSettingsBuilder::default()
            .verbose(false)
            .direct_solve_method("qdldl".to_owned())
            .build()
            .expect("valid clarabel settings")
    }

    /// Solve the QP for the (positive definite) `h`, gradient `g` and `rows`. Fails with
    /// clarabel's status when it finds no solution.
    pub fn solve(
        &mut self,
        h: &SymmetricMatrix,
        g: &[f64],
        rows: &[ContactRow],
    ) -> Result<QpSolution, String> {
        let start = Instant::now();
        let n = g.len();
        if !self
            .upper
            .as_ref()
            .is_some_and(|u| Arc::ptr_eq(&u.pattern, h.pattern()))
        {
            self.upper = Some(UpperTriangle::new(h.pattern()));
        }
        let upper = self.upper.as_ref().expect("set above");
        let values = upper.slots.iter().map(|&k| h.values()[k]).collect();
        let p = CscMatrix::new(n, n, upper.col_ptr.clone(), upper.row_idx.clone(), values);
        let m = rows.len();
        let (mut ri, mut ci, mut vi) = (Vec::new(), Vec::new(), Vec::new());
        for (r, row) in rows.iter().enumerate() {
            for i in 0..3 {
                ri.push(r);
                ci.push(row.dof + i);
                vi.push(-row.normal[i]);
            }
        }
        let a = CscMatrix::new_from_triplets(m, n, ri, ci, vi);
        let b: Vec<f64> = rows.iter().map(|r| r.distance).collect();
        let cones = [NonnegativeConeT(m)];
        let mut solver = DefaultSolver::new(&p, g, &a, &b, &cones, Self::settings())
            .map_err(|e| format!("clarabel setup failed: {e}"))?;
        solver.solve();
        let s = &solver.solution;
        match s.status {
            SolverStatus::Solved | SolverStatus::AlmostSolved => Ok(QpSolution {
                dx: s.x.clone(),
                multipliers: s.z.clone(),
                iterations: s.iterations,
                seconds: start.elapsed().as_secs_f64(),
            }),
            status => Err(format!(
                "the contact QP ({n} variables, {m} constraints) ended with status {status:?}"
            )),
        }
    }
}
