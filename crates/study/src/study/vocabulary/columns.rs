//! The columns of `runs.csv`, each named once. Every table begins with the identity columns
//! and the study's parameter columns and ends with the trailer; between them come the kind's
//! own columns and the groups of columns the measurements shared by several kinds fill:
//! [`SUMMARY`] (a run's work, times and drift, from its `RunSummary`) and [`CAPS`] (the
//! integrator's caps and tolerances that can decide a result). A group's names and the values
//! it writes are one table, so they cannot drift apart; a kind lists the groups it fills
//! ([`declare`]). The runner refuses a row with a value whose column is not declared ([`row`]),
//! and a study reports the declared columns that none of its runs filled
//! (`StudyRun::unfilled_columns`), which the test running every kind requires to be none.

use crate::study::vocabulary::format::cell;
use crate::study::vocabulary::spec::RunSpec;
use softbench_run::run::RunSummary;

/// The identity columns every `runs.csv` begins with.
pub const IDENTITY: [&str; 4] = ["run_id", "scene", "method", "linear_solver"];

/// The columns every `runs.csv` ends with.
pub const TRAILER: [&str; 2] = ["message", "config_hash"];

/// A column's name and how one run's value of it is written.
pub type Column<T> = (&'static str, fn(&T) -> String);

/// A group of columns.
pub struct Group<T: 'static> {
    /// Each column, in order.
    pub cells: &'static [Column<T>],
}

impl<T> Group<T> {
    /// The column names, in order.
    pub fn names(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.cells.iter().map(|(name, _)| *name)
    }

    /// Every column's value for `x`.
    pub fn cells(&self, x: &T) -> Vec<(&'static str, String)> {
        self.cells.iter().map(|(name, f)| (*name, f(x))).collect()
    }
}

/// A number as a cell.
fn f(x: f64) -> String {
    cell(Some(x))
}

/// The steps a run completed, at least one (the denominator of per-step counts).
fn steps(s: &RunSummary) -> f64 {
    s.steps_completed.max(1) as f64
}

/// An AMG hierarchy's figure, empty without one.
fn amg(s: &RunSummary, x: f64) -> String {
    cell((s.totals.amg_builds > 0).then_some(x))
}

/// What every run reports: its work, times, drift and solver figures.
pub static SUMMARY: Group<RunSummary> = Group {
    cells: &[
        ("steps", |s| s.steps_completed.to_string()),
        ("final_time", |s| f(s.final_time)),
        ("energy_drift_max", |s| f(s.energy_drift_max)),
        ("energy_drift_final", |s| f(s.energy_drift_final)),
        ("step_seconds_median", |s| f(s.step_seconds_median)),
        ("step_seconds_q1", |s| f(s.step_seconds_q1)),
        ("step_seconds_q3", |s| f(s.step_seconds_q3)),
        ("step_seconds_p95", |s| f(s.step_seconds_p95)),
        ("first_step_seconds", |s| f(s.first_step_seconds)),
        ("setup_seconds", |s| {
            f((s.first_step_seconds - s.step_seconds_median).max(0.0))
        }),
        ("wall_seconds", |s| f(s.totals.times.total)),
        ("force_evaluations", |s| {
            s.totals.evaluations.gradient.to_string()
        }),
        ("energy_evaluations", |s| {
            s.totals.evaluations.potential.to_string()
        }),
        ("hessian_evaluations", |s| {
            s.totals.evaluations.hessian.to_string()
        }),
        ("factorizations", |s| s.totals.factorizations.to_string()),
        ("linear_solves", |s| s.totals.linear_solves.to_string()),
        ("linear_iterations", |s| {
            s.totals.linear_iterations.to_string()
        }),
        ("newton_iterations", |s| {
            s.totals.newton_iterations.to_string()
        }),
        ("newton_iterations_per_step", |s| {
            f(f64::from(s.totals.newton_iterations) / steps(s))
        }),
        ("substeps", |s| s.totals.substeps.to_string()),
        ("rejected_substeps", |s| {
            s.totals.rejected_substeps.to_string()
        }),
        ("failed_substeps", |s| s.totals.failed_substeps.to_string()),
        ("local_iterations", |s| {
            s.totals.local_iterations.to_string()
        }),
        ("local_iterations_per_step", |s| {
            f(f64::from(s.totals.local_iterations) / steps(s))
        }),
        ("assemble_seconds", |s| f(s.totals.times.assemble)),
        ("factor_seconds", |s| f(s.totals.times.factor)),
        ("solve_seconds", |s| f(s.totals.times.solve)),
        ("qp_seconds", |s| f(s.totals.times.qp)),
        ("force_seconds", |s| f(s.totals.times.forces)),
        ("mass_solves", |s| s.totals.mass_solves.to_string()),
        ("mass_solve_seconds", |s| f(s.totals.times.mass_solve)),
        ("internal_dt_min", |s| cell(s.internal_dt.map(|d| d.min))),
        ("internal_dt_median", |s| {
            cell(s.internal_dt.map(|d| d.median))
        }),
        ("internal_dt_max", |s| cell(s.internal_dt.map(|d| d.max))),
        ("newton_unconverged_steps", |s| {
            s.newton_unconverged_steps.to_string()
        }),
        ("inverted_elements_max", |s| {
            s.inverted_elements_max.to_string()
        }),
        ("energy_excess_peak", |s| f(s.energy_excess_peak)),
        ("energy_growth_rate", |s| {
            cell(s.energy_growth.map(|g| g.rate))
        }),
        ("energy_growth_factor", |s| {
            cell(s.energy_growth.map(|g| g.factor))
        }),
        ("energy_limit", |s| f(s.energy_limit)),
        ("linear_solver_used", |s| s.totals.linear_solver.to_owned()),
        ("ordering", |s| s.totals.ordering.to_owned()),
        ("factor_nnz", |s| s.totals.factor_nnz.to_string()),
        ("symbolic_analyses", |s| {
            s.totals.symbolic_analyses.to_string()
        }),
        ("factor_flops", |s| f(s.totals.factor_flops)),
        ("factor_threads", |s| s.totals.factor_threads.to_string()),
        ("factor_scheduler", |s| s.totals.factor_scheduler.to_owned()),
        ("amg_operator_complexity", |s| {
            amg(s, s.totals.amg_operator_complexity)
        }),
        ("amg_grid_complexity", |s| {
            amg(s, s.totals.amg_grid_complexity)
        }),
        ("amg_builds", |s| s.totals.amg_builds.to_string()),
        ("amg_reuses", |s| s.totals.amg_reuses.to_string()),
        ("amg_lagged", |s| s.totals.amg_lagged.to_string()),
        ("linear_iterations_per_solve", |s| {
            f(s.totals.linear_iterations as f64 / f64::from(s.totals.linear_solves.max(1)))
        }),
    ],
};

/// The caps and tolerances of a run's integrator that can decide its result, reported next
/// to it (empty where they do not apply): Newton's iteration cap, whether convergence was
/// required, how many iterations share a factorization and the inexact-Newton forcing; AMG's
/// settings where AMG can run; an adaptive method's tolerances and controller.
pub static CAPS: Group<RunSpec> = Group {
    cells: &[
        ("newton_max_iterations", |r| {
            newton(r, |n| n.max_iterations.to_string())
        }),
        ("newton_required", |r| {
            newton(r, |n| n.require_convergence.to_string())
        }),
        ("newton_refactor_every", |r| {
            newton(r, |n| n.refactor_every.to_string())
        }),
        ("newton_forcing_max", |r| {
            newton(r, |n| n.forcing_max.to_string())
        }),
        ("amg_strength_threshold", |r| {
            amg_setting(r, |a| a.strength_threshold.to_string())
        }),
        ("amg_rebuild_every", |r| {
            amg_setting(r, |a| a.rebuild_every.to_string())
        }),
        ("amg_galerkin_every", |r| {
            amg_setting(r, |a| a.galerkin_every.to_string())
        }),
        ("amg_smoother", |r| {
            amg_setting(r, |a| a.smoother.name().to_owned())
        }),
        ("adaptive_rtol", |r| {
            adaptive(r, |a| a.tolerance.to_string())
        }),
        ("adaptive_atol", |r| {
            adaptive(r, |a| a.absolute_tolerance.to_string())
        }),
        ("adaptive_controller", |r| {
            adaptive(r, |a| a.controller.name().to_owned())
        }),
        ("adaptive_max_substeps", |r| {
            adaptive(r, |a| a.max_substeps.to_string())
        }),
    ],
};

/// A Newton setting of a method on the Newton loop, else empty.
fn newton(r: &RunSpec, value: fn(&softbench_core::integrate::NewtonSettings) -> String) -> String {
    let integrator = &r.loaded.config.integrator;
    if integrator.method.uses_newton() {
        value(&integrator.newton)
    } else {
        String::new()
    }
}

/// An AMG setting where AMG can run (a method on the Newton loop with CG and AMG, or `auto`,
/// which may choose it), else empty.
fn amg_setting(r: &RunSpec, value: fn(&softbench_core::solve::AmgSettings) -> String) -> String {
    let integrator = &r.loaded.config.integrator;
    let solver = integrator.linear_solver.name();
    let uses_amg = solver == "auto"
        || (solver == "cg"
            && integrator.solver.cg.preconditioner == softbench_core::solve::Preconditioner::Amg);
    if integrator.method.uses_newton() && uses_amg {
        value(&integrator.solver.cg.amg)
    } else {
        String::new()
    }
}

/// An adaptive method's setting, else empty.
fn adaptive(
    r: &RunSpec,
    value: fn(&softbench_core::integrate::AdaptiveSettings) -> String,
) -> String {
    let integrator = &r.loaded.config.integrator;
    if integrator.method.is_adaptive() {
        value(&integrator.adaptive)
    } else {
        String::new()
    }
}

/// A kind's measured columns: its `own`, then every group it fills (names its own list
/// already has are not repeated; the test of [`declare`] keeps own lists free of them).
pub fn declare(own: &[&'static str], summary: bool, caps: bool) -> Vec<&'static str> {
    let mut columns: Vec<&'static str> = own.to_vec();
    let groups = summary
        .then(|| SUMMARY.names().collect::<Vec<_>>())
        .into_iter()
        .chain(caps.then(|| CAPS.names().collect::<Vec<_>>()))
        .flatten();
    for name in groups {
        if !columns.contains(&name) {
            columns.push(name);
        }
    }
    columns
}

/// A row of a table with `header`: `fixed` gives the values of the identity, parameter,
/// outcome and trailer columns, `cells` (a run's measured values) the rest; a measured column
/// the run has no value for is empty. A value whose column the header lacks is an error
/// naming it: it would be dropped from the table without a word.
pub fn row(
    header: &[String],
    fixed: &dyn Fn(&str) -> Option<String>,
    cells: &[(&'static str, String)],
) -> Result<Vec<String>, String> {
    if let Some((name, _)) = cells.iter().find(|(n, _)| !header.iter().any(|h| h == n)) {
        return Err(format!(
            "the run wrote a value for `{name}`, a column its study kind does not declare"
        ));
    }
    Ok(header
        .iter()
        .map(|column| {
            fixed(column)
                .or_else(|| {
                    cells
                        .iter()
                        .find(|(n, _)| n == column)
                        .map(|(_, v)| v.clone())
                })
                .unwrap_or_default()
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_groups_names_are_distinct_and_disjoint_from_the_others() {
        let summary: Vec<&str> = SUMMARY.names().collect();
        let caps: Vec<&str> = CAPS.names().collect();
        for (what, names) in [("summary", &summary), ("caps", &caps)] {
            let mut sorted = names.clone();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), names.len(), "a {what} column is named twice");
        }
        assert!(summary.iter().all(|n| !caps.contains(n)));
        for fixed in IDENTITY.iter().chain(&TRAILER) {
            assert!(!summary.contains(fixed) && !caps.contains(fixed), "{fixed}");
        }
    }

    #[test]
    fn a_row_refuses_an_undeclared_value_and_leaves_an_unset_column_empty() {
        let header: Vec<String> = ["run_id", "error", "steps"].map(String::from).to_vec();
        let fixed = |c: &str| (c == "run_id").then(|| "a".to_owned());
        let row = row(
            &header,
            &fixed,
            &[("error", "0.1".into()), ("steps", "3".into())],
        );
        assert_eq!(row.unwrap(), ["a", "0.1", "3"]);
        let extra = super::row(
            &header,
            &fixed,
            &[
                ("error", "0.1".into()),
                ("steps", "3".into()),
                ("errr", "1".into()),
            ],
        );
        assert!(extra.unwrap_err().contains("`errr`"));
        let unset = super::row(&header, &fixed, &[("error", "0.1".into())]);
        assert_eq!(unset.unwrap(), ["a", "0.1", ""]);
    }

    #[test]
    fn declare_puts_the_groups_after_the_own_columns_once() {
        let columns = declare(&["dt", "error", "steps"], true, true);
        assert_eq!(&columns[..3], ["dt", "error", "steps"]);
        assert_eq!(columns.iter().filter(|c| **c == "steps").count(), 1);
        assert!(columns.contains(&"newton_forcing_max"));
        assert_eq!(
            columns.len(),
            3 + SUMMARY.names().count() - 1 + CAPS.names().count()
        );
        assert_eq!(declare(&["x"], false, false), ["x"]);
    }
}
