//! Claims about the registries: every registered linear solver, material, contact response,
//! obstacle kind, export format, Hessian filter (and filter space), Newton direction,
//! globalization, convergence criterion, L-BFGS initial Hessian, step-size controller,
//! local-solver acceleration and VBD sweep appears in `softbench list` with its description, and can be parsed (and, for
//! solvers and materials, built) from the name it is listed under; a program can register its
//! own linear solver and find it by name.

use std::process::Command;

use softbench::contact::{ContactResponse, ObstacleKind};
use softbench::export::ExportFormat;
use softbench::fem::FilterSpace;
use softbench::integrate::HessianFilter;
use softbench::integrate::acceleration::Acceleration;
use softbench::integrate::newton::{Criterion, Direction, Globalization, LbfgsInitial};
use softbench::integrate::vbd::VbdSweep;
use softbench::material::{LameParameters, MaterialKind, MaterialModel};
use softbench::registry::{NamedEnum, RegisterError};
use softbench::solve::{
    DenseCholeskySolver, LINEAR_SOLVERS, LinearSolver, LinearSolverKind, SolverEntry,
    SolverSettings,
};

/// The name under which a test registers a solver of its own.
const PROGRAMS_SOLVER: &str = "my-dense";

fn list_output() -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_softbench"))
        .arg("list")
        .output()
        .expect("softbench runs");
    assert!(out.status.success(), "softbench list failed: {out:?}");
    String::from_utf8(out.stdout).expect("utf-8")
}

/// The line of `text` that lists `name` (first word after the indent) with `description`.
fn lists(text: &str, name: &str, description: &str) -> bool {
    text.lines()
        .any(|l| l.split_whitespace().next() == Some(name) && l.trim_end().ends_with(description))
}

#[test]
fn every_linear_solver_is_listed_and_builds_from_its_name() {
    let text = list_output();
    // The binary lists the built-in solvers; `a_program_registers_its_own_linear_solver` may
    // have added its own to this process's registry by now.
    let all: Vec<_> = LinearSolverKind::all()
        .into_iter()
        .filter(|k| k.name() != PROGRAMS_SOLVER)
        .collect();
    assert!(all.len() >= 4);
    for kind in all {
        assert!(
            lists(&text, kind.name(), kind.description()),
            "{kind} missing from: {text}"
        );
        let parsed = LinearSolverKind::from_name(kind.name()).unwrap();
        assert_eq!(parsed, kind);
        let solver = parsed.build(&SolverSettings::default());
        assert_eq!(solver.name(), kind.name());
    }
}

#[test]
fn every_material_is_listed_and_builds_from_its_name() {
    let text = list_output();
    let lame = LameParameters::from_youngs_poisson(1e5, 0.3).unwrap();
    for &kind in MaterialKind::ALL {
        assert!(
            lists(&text, kind.name(), kind.description()),
            "{kind}: {text}"
        );
        let model = MaterialModel::from_name(kind.name(), lame).unwrap();
        assert_eq!(model.kind(), kind);
        assert_eq!(model.name(), kind.name());
        assert_eq!(model.handles_inversion(), kind.facts().handles_inversion);
    }
}

fn check_enum<T: NamedEnum + std::str::FromStr + PartialEq + std::fmt::Debug>(text: &str) {
    assert!(!T::all_values().is_empty());
    for &v in T::all_values() {
        assert!(lists(text, v.name(), v.description()), "{v:?}: {text}");
        let parsed: T = v.name().parse().ok().expect("parses its own name");
        assert_eq!(parsed, v);
    }
}

#[test]
fn every_closed_family_is_listed_and_parses() {
    let text = list_output();
    check_enum::<ContactResponse>(&text);
    check_enum::<ObstacleKind>(&text);
    check_enum::<ExportFormat>(&text);
    check_enum::<HessianFilter>(&text);
    check_enum::<FilterSpace>(&text);
    check_enum::<Acceleration>(&text);
    check_enum::<VbdSweep>(&text);
    check_enum::<Direction>(&text);
    check_enum::<Globalization>(&text);
    check_enum::<Criterion>(&text);
    check_enum::<LbfgsInitial>(&text);
    check_enum::<softbench::integrate::Controller>(&text);
}

#[test]
fn a_program_registers_its_own_linear_solver() {
    LINEAR_SOLVERS
        .register(SolverEntry {
            name: PROGRAMS_SOLVER,
            description: "a program's own solver (dense LL^T under another name)",
            direct: true,
            reports_inertia: false,
            build: |_| Box::new(DenseCholeskySolver::new()),
        })
        .unwrap();
    let kind = LinearSolverKind::from_name(PROGRAMS_SOLVER).unwrap();
    assert!(LinearSolverKind::all().contains(&kind));
    let solver: Box<dyn LinearSolver> = kind.build(&SolverSettings::default());
    assert_eq!(solver.name(), "dense");
    let dup = LINEAR_SOLVERS.register(SolverEntry {
        name: "cholesky",
        description: "",
        direct: true,
        reports_inertia: false,
        build: |_| Box::new(DenseCholeskySolver::new()),
    });
    assert!(matches!(dup, Err(RegisterError::Duplicate { .. })));
    let err = LinearSolverKind::from_name("choleski")
        .unwrap_err()
        .to_string();
    assert!(err.contains("did you mean `cholesky`?"), "{err}");
}
