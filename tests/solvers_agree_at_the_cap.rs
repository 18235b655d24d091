//! A Newton solve that the iteration cap ends unconverged accepts the same state whichever
//! linear solver computed its directions: CG's inexact directions (stopped at the forcing term)
//! are redone exactly, so comparing CG with Cholesky compares solvers, not Newton caps.

mod common;

use common::TempDir;
use std::path::Path;

/// Elastic energy after each sampled step, and the run's summary totals.
fn run(scene: &Path, out: &Path, extra: &[&str]) -> (Vec<f64>, serde_json::Value) {
    let o = common::simulate(scene, out, extra);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut reader = csv::Reader::from_path(out.join("trajectory.csv")).unwrap();
    let headers = reader.headers().unwrap().clone();
    let col = headers.iter().position(|h| h == "elastic").unwrap();
    let elastic = reader
        .records()
        .map(|r| r.unwrap()[col].parse::<f64>().unwrap())
        .collect();
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    (elastic, file["summary"].clone())
}

/// Runs `scene` with Cholesky, CG and `auto` (overrides `extra`) and checks that every
/// step's elastic energy agrees, that the cap ended solves (else the test shows nothing) and
/// that CG redid them exactly.
fn solvers_agree(tmp: &TempDir, scene: &Path, extra: &[&str]) {
    let mut runs = Vec::new();
    for solver in ["cholesky", "cg", "auto"] {
        let set = format!("integrator.linear_solver={solver}");
        let mut args = vec!["--set", set.as_str(), "--threads", "1"];
        args.extend_from_slice(extra);
        let (elastic, summary) = run(scene, &tmp.path().join(solver), &args);
        let totals = &summary["totals"];
        eprintln!(
            "{solver}: elastic {elastic:?}, unconverged steps {}, exact redos {}, CG iterations {}",
            summary["newton_unconverged_steps"], totals["exact_redos"], totals["linear_iterations"]
        );
        runs.push((solver, elastic, summary));
    }
    let (_, cholesky, summary) = &runs[0];
    assert!(summary["newton_unconverged_steps"].as_u64().unwrap() > 0);
    assert_eq!(summary["totals"]["exact_redos"], 0);
    assert_eq!(
        runs[1].2["totals"]["exact_redos"],
        summary["newton_unconverged_steps"]
    );
    for (solver, elastic, _) in &runs[1..] {
        assert_eq!(elastic.len(), cholesky.len());
        for (step, (a, b)) in elastic.iter().zip(cholesky).enumerate() {
            assert!(
                (a - b).abs() <= 1e-6 * b.abs().max(1e-12),
                "{solver}, row {step}: elastic {a} J, Cholesky {b} J"
            );
        }
    }
}

#[test]
fn cholesky_and_cg_agree_on_the_course_armadillo_at_the_course_settings() {
    if common::reference_mesh("arma_6.node").is_none() {
        return;
    }
    let tmp = TempDir::new("cap-armadillo");
    // Course settings: dt = 0.01 s, 5 Newton iterations, the drag's first steps (before the
    // redo, CG ended step 1 at 2344 J of elastic energy and Cholesky at 1787 J).
    solvers_agree(
        &tmp,
        &common::scene("armadillo_drag.toml"),
        &["--set", "run.steps=2"],
    );
}

#[test]
fn cholesky_and_cg_agree_on_a_body_of_our_own_when_the_cap_ends_every_solve() {
    let tmp = TempDir::new("cap-box");
    // A soft clamped bar dropped under gravity at a large step with two Newton iterations:
    // no solve converges.
    let scene = tmp.write(
        "bar.toml",
        "[mesh]\ngenerate = { box = [8, 2, 2], size = [0.8, 0.1, 0.1] }\n[material]\n\
         model = \"stable-neo-hookean\"\nyoungs_modulus = 2e4\npoisson_ratio = 0.45\n\
         density = 1000.0\n[fixed]\nrule = { axis = \"x\", side = \"min\", tolerance = 1e-6 }\n\
         [forces]\ngravity = [0.0, -9.81, 0.0]\n[integrator]\nmethod = \"backward-euler\"\n\
         newton = { max_iterations = 2, tolerance = 1e-10 }\n[run]\ndt = 0.05\nsteps = 4\n",
    );
    solvers_agree(&tmp, &scene, &[]);
}
