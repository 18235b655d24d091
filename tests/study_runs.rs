//! `softbench run`: every shipped study in quick mode produces every output file; resuming
//! skips finished runs (also after an interruption); `--force` and a changed config redo them.

mod common;

use common::{TempDir, run_study_ok, softbench};
use softbench::study::table::Table;
use std::path::{Path, PathBuf};

fn study(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("experiments")
        .join(name)
}

fn stderr(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Whether a study's scenes need the reference meshes (and `SOFTBENCH_DATA` is unset).
fn needs_missing_data(name: &str) -> bool {
    let text = std::fs::read_to_string(study(name)).unwrap();
    let needs = text.contains("armadillo") || text.contains("bunny");
    needs && common::reference_mesh("arma_6.node").is_none()
}

/// Every file the issue lists, checked for one results folder.
fn assert_complete(dir: &Path, required_columns: &[&str]) -> Table {
    let runs = Table::read(&dir.join("runs.csv"))
        .unwrap()
        .expect("runs.csv");
    for c in required_columns {
        assert!(
            runs.column(c).is_some(),
            "runs.csv lacks column {c}: {:?}",
            runs.header
        );
    }
    assert!(!runs.rows.is_empty());
    for row in &runs.rows {
        let id = &row[0];
        let series = dir.join("series").join(format!("{id}.csv"));
        assert!(series.is_file(), "missing {}", series.display());
        let outcome = runs.get(row, "outcome").unwrap();
        assert!(
            softbench::run::OutcomeKind::from_name(outcome).is_some(),
            "{id}: outcome `{outcome}` is not in the vocabulary"
        );
    }
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("meta.json")).unwrap()).unwrap();
    for key in [
        "softbench_version",
        "git_commit",
        "rustc",
        "cpu",
        "cores",
        "os",
    ] {
        assert!(
            !meta["machine"][key].is_null(),
            "meta.json lacks machine.{key}"
        );
    }
    assert!(meta["finished"].is_string() && meta["started"].is_string());
    assert!(meta["config"]["runs"].as_object().unwrap().len() >= runs.rows.len());
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    let mut plots = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        assert!(!name.ends_with(".partial"), "left behind: {name}");
        if let Some(stem) = name.strip_suffix(".png") {
            plots += 1;
            let png = std::fs::read(&path).unwrap();
            assert!(png.starts_with(b"\x89PNG"), "{name} is not a PNG");
            if stem.starts_with("pictures-") {
                // Pictures of the bodies are raster only, with their animation beside them.
                let gif = std::fs::read(dir.join(format!("{stem}.gif"))).unwrap();
                assert!(gif.starts_with(b"GIF89a"), "{stem}.gif is not a GIF");
            } else {
                let svg = std::fs::read_to_string(dir.join(format!("{stem}.svg"))).unwrap();
                assert!(svg.contains("<svg"), "{stem}.svg is not an SVG");
            }
            assert!(
                report.contains(&format!("({stem}.png)")),
                "report.md does not embed {stem}"
            );
        }
    }
    assert!(plots >= 2, "only {plots} plots in {}", dir.display());
    for row in &runs.rows {
        assert!(report.contains(runs.get(row, "method").unwrap()));
    }
    runs
}

fn run_quick(name: &str, out: &Path) -> std::process::Output {
    run_study_ok(&study(name), out, &["--quick"])
}

const IDENTITY: [&str; 4] = ["run_id", "scene", "method", "linear_solver"];

/// Quick mode gives the full study's verdict class: each run of a quick `table` has the
/// `stability` verdict of the same run in the committed full run `results/<study>/runs.csv`
/// (rerun when the verdicts change, so it is the full mode of this code). Returns how many
/// runs were compared, so a caller can see the comparison is not empty.
fn assert_full_verdict_classes(study: &str, quick: &Table) -> usize {
    let committed = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("results")
        .join(study)
        .join("runs.csv");
    let full = Table::read(&committed)
        .unwrap()
        .expect("committed runs.csv");
    let mut compared = 0;
    // Rows a `--only` run left out have no verdict.
    for q in quick
        .rows
        .iter()
        .filter(|q| quick.get(q, "stability") != Some(""))
    {
        let id = quick.get(q, "run_id").unwrap();
        let f = full
            .rows
            .iter()
            .find(|f| full.get(f, "run_id") == Some(id))
            .unwrap_or_else(|| panic!("{id} is not in {}", committed.display()));
        assert_eq!(
            quick.get(q, "stability"),
            full.get(f, "stability"),
            "{id}: quick mode's verdict class differs from the full study's"
        );
        compared += 1;
    }
    compared
}

#[test]
fn quickstart_quick_writes_every_output() {
    let tmp = TempDir::new("study-quickstart");
    run_quick("quickstart.toml", tmp.path());
    let dir = tmp.path().join("quickstart");
    let mut columns = IDENTITY.to_vec();
    columns.extend([
        "dt",
        "outcome",
        "newton_unconverged_steps",
        "energy_drift_max",
        "energy_drift_final",
        "momentum_drift",
        "step_seconds_median",
        "step_seconds_p95",
    ]);
    let runs = assert_complete(&dir, &columns);
    // Explicit methods get no linear solver and are not repeated per solver.
    for row in &runs.rows {
        let method = runs.get(row, "method").unwrap();
        let solver = runs.get(row, "linear_solver").unwrap();
        let explicit = ["symplectic-euler", "rk4"].contains(&method);
        assert_eq!(solver == "-", explicit, "{method} / {solver}");
    }
    assert_eq!(runs.rows.len(), 12);

    // `softbench plot` redraws every plot from the CSV files alone.
    let mut removed = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "png" || e == "svg") {
            std::fs::remove_file(&path).unwrap();
            removed += 1;
        }
    }
    assert!(removed >= 4);
    // ... and rewrites the report's findings (here: of a report that lost them).
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    let start = report
        .find("## Findings\n")
        .expect("the report has findings");
    let end = start + report[start..].find("\nStudy file `").unwrap() + 1;
    let findings = &report[start..end];
    assert!(findings.contains("| scene | metric |"), "{findings}");
    let cut = format!("{}{}", &report[..start], &report[end..]);
    std::fs::write(dir.join("report.md"), &cut).unwrap();
    // A figure of the user's survives the redraw; a stale plot of softbench's own (a scene no
    // longer in the study) does not.
    std::fs::write(dir.join("scaling_box_step_time.png"), b"theirs").unwrap();
    std::fs::write(dir.join("energy-gone_scene.png"), b"stale").unwrap();
    let o = softbench(&["plot", dir.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(dir.join("scaling_box_step_time.png")).unwrap(),
        b"theirs"
    );
    assert!(!dir.join("energy-gone_scene.png").exists());
    std::fs::remove_file(dir.join("scaling_box_step_time.png")).unwrap();
    assert_complete(&dir, &IDENTITY);
    assert_eq!(
        std::fs::read_to_string(dir.join("report.md")).unwrap(),
        report,
        "the findings are back, the rest unchanged"
    );
}

#[test]
fn parallel_jobs_give_the_same_numbers() {
    let tmp = TempDir::new("study-jobs");
    let file = study("quickstart.toml");
    let mut tables = Vec::new();
    for jobs in ["1", "2"] {
        let out = tmp.path().join(format!("jobs{jobs}"));
        run_study_ok(&file, &out, &["--quick", "--jobs", jobs]);
        tables.push(
            Table::read(&out.join("quickstart/runs.csv"))
                .unwrap()
                .unwrap(),
        );
    }
    // Everything but wall times is bitwise the same, in the same order.
    let deterministic = [
        "run_id",
        "outcome",
        "energy_drift_max",
        "energy_drift_final",
        "steps",
        "force_evaluations",
        "newton_iterations",
        "config_hash",
    ];
    for c in deterministic {
        let column = |t: &Table| {
            t.rows
                .iter()
                .map(|r| t.get(r, c).unwrap().to_owned())
                .collect::<Vec<_>>()
        };
        assert_eq!(column(&tables[0]), column(&tables[1]), "column {c}");
    }
}

#[test]
fn list_names_scenes_and_studies() {
    let o = softbench(&["list"]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    for expected in [
        "integrators",
        "backward-euler",
        "linear solvers",
        "materials",
        "scenes",
        "soft_beam",
        "studies",
        "quickstart",
        "armadillo_stability",
    ] {
        assert!(text.contains(expected), "`{expected}` missing from: {text}");
    }
}

#[test]
fn energy_drift_quick_writes_every_output() {
    let tmp = TempDir::new("study-drift");
    run_quick("energy_drift.toml", tmp.path());
    let mut columns = IDENTITY.to_vec();
    columns.extend(["dt", "outcome", "energy_drift_max", "momentum_drift"]);
    let runs = assert_complete(&tmp.path().join("energy_drift"), &columns);
    // Free bodies: every method that finished conserves linear momentum to round-off.
    for row in &runs.rows {
        if runs.get(row, "outcome") == Some("completed") {
            let drift = runs
                .number(row, "momentum_drift")
                .expect("free body: momentum reported");
            assert!(drift < 1e-9, "{}: momentum drift {drift}", row[0]);
        }
    }
}

#[test]
fn stiffness_sweep_quick_writes_every_output() {
    let tmp = TempDir::new("study-sweep");
    run_quick("stiffness_sweep.toml", tmp.path());
    let mut columns = IDENTITY.to_vec();
    columns.extend([
        "material.youngs_modulus",
        "stability",
        "outcome",
        "max_stable_dt",
        "omega_max",
        "dt_theory",
    ]);
    let dir = tmp.path().join("stiffness_sweep");
    let runs = assert_complete(&dir, &columns);
    assert!(dir.join("sweep-max_stable_dt.png").is_file());
    // Every run, with limits found and methods stable to the ceiling among them.
    assert_eq!(assert_full_verdict_classes("stiffness_sweep", &runs), 20);
    // The maps' scan density reads as a count, not in the table's number format ("3e0").
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    let headings: Vec<&str> = report
        .lines()
        .filter_map(|l| l.strip_suffix(" steps per decade:"))
        .collect();
    assert!(!headings.is_empty(), "no map heading in:\n{report}");
    for heading in headings {
        let density = heading.rsplit(' ').next().unwrap();
        assert!(
            density.parse::<u32>().is_ok(),
            "`{heading} steps per decade:`"
        );
    }
}

#[test]
fn armadillo_stability_quick_writes_every_output() {
    if needs_missing_data("armadillo_stability.toml") {
        return;
    }
    let tmp = TempDir::new("study-arma");
    // Explicit and symplectic Euler on both scenes with the course material: the quick study
    // judges the full study's range, 2 us to 0.02 s, so these trials are the full study's
    // and give its verdict classes (no stable step in range, a limit). Its implicit methods
    // are left out here: their maps run 1e5 Newton steps at the floor, minutes each
    // (stiffness_sweep's test covers `stable-to-ceiling`).
    // (`*euler-model=` leaves out the implicit ones, whose ids name their linear solver.)
    run_study_ok(
        &study("armadillo_stability.toml"),
        tmp.path(),
        &["--quick", "--only", "armadillo_*-*euler-model=neo-hookean"],
    );
    let mut columns = IDENTITY.to_vec();
    columns.extend([
        "stability",
        "outcome",
        "max_stable_dt",
        "omega_max",
        "dt_theory",
        "cost_per_simulated_second",
        "evaluations_per_simulated_second",
        "error_at_stable_dt",
        "newton_max_iterations",
        "max_steps",
        "min_steps",
    ]);
    let runs = assert_complete(&tmp.path().join("armadillo_stability"), &columns);
    // The explicit limit of the course armadillo is a few microseconds.
    let theory = runs.number(&runs.rows[0], "dt_theory").unwrap();
    assert!((1e-7..1e-4).contains(&theory), "2/omega_max = {theory}");
    // Quick mode gives each of them the committed full study's verdict.
    assert_eq!(assert_full_verdict_classes("armadillo_stability", &runs), 4);
}

#[test]
fn work_precision_quick_writes_every_output() {
    if needs_missing_data("work_precision.toml") {
        return;
    }
    let tmp = TempDir::new("study-wp");
    run_quick("work_precision.toml", tmp.path());
    let mut columns = IDENTITY.to_vec();
    columns.extend([
        "dt",
        "outcome",
        "error",
        "newton_unconverged_steps",
        "wall_seconds",
        "force_evaluations",
        "hessian_evaluations",
        "factorizations",
        "linear_iterations",
    ]);
    assert_complete(&tmp.path().join("work_precision"), &columns);
}

#[test]
fn implicit_families_quick_puts_tolerance_and_step_ladders_on_one_study() {
    let tmp = TempDir::new("study-families");
    // The soft beam only: the cantilever's tight tolerances take a minute.
    let only = ["--quick", "--only", "soft_beam"];
    run_study_ok(&study("implicit_families.toml"), tmp.path(), &only);
    let mut columns = IDENTITY.to_vec();
    columns.extend([
        "dt",
        "outcome",
        "error",
        "error_final",
        "wall_seconds",
        "force_evaluations",
        "factorizations",
        "substeps",
        "rejected_substeps",
        "failed_substeps",
        "adaptive_rtol",
        "adaptive_atol",
        "adaptive_controller",
    ]);
    let runs = assert_complete(&tmp.path().join("implicit_families"), &columns);
    let mut adaptive = 0;
    for r in &runs.rows {
        let method = runs.get(r, "method").unwrap();
        let rtol = runs.get(r, "adaptive_rtol").unwrap();
        if method.starts_with("adaptive-") {
            adaptive += 1;
            // The tolerance that set the steps is next to the error it gave.
            assert!(rtol.parse::<f64>().is_ok(), "{method}: rtol {rtol:?}");
            assert_eq!(runs.get(r, "adaptive_controller"), Some("pi"));
        } else {
            assert_eq!(rtol, "", "{method} is not adaptive");
        }
        if runs.get(r, "outcome") == Some("completed") && runs.get(r, "scored") == Some("yes") {
            let (e, f) = (
                runs.number(r, "error").unwrap(),
                runs.number(r, "error_final").unwrap(),
            );
            assert!(f <= e, "{method}: final error {f} above the largest {e}");
        }
    }
    assert!(adaptive >= 6, "{adaptive} adaptive runs");
}

/// Modification times of the series files, by name.
fn series_times(dir: &Path) -> Vec<(String, std::time::SystemTime)> {
    let mut v: Vec<_> = std::fs::read_dir(dir.join("series"))
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                e.metadata().unwrap().modified().unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

#[test]
fn rerunning_skips_finished_runs_and_force_redoes_them() {
    let tmp = TempDir::new("study-resume");
    let out = tmp.path().to_str().unwrap().to_owned();
    let file = study("quickstart.toml");
    let args = ["run", file.to_str().unwrap(), "--quick", "--out", &out];
    run_quick("quickstart.toml", tmp.path());
    let dir = tmp.path().join("quickstart");
    let before = series_times(&dir);
    let table_before = Table::read(&dir.join("runs.csv")).unwrap().unwrap();

    let again = softbench(&args);
    assert!(again.status.success());
    assert!(
        stderr(&again).contains("12 of 12 runs already complete"),
        "{}",
        stderr(&again)
    );
    assert_eq!(series_times(&dir), before, "a finished run was redone");
    assert_eq!(
        Table::read(&dir.join("runs.csv")).unwrap().unwrap(),
        table_before
    );

    // --only with --force redoes just the matching runs.
    let mut forced = args.to_vec();
    forced.extend(["--force", "--only", "soft_beam-rk4"]);
    let o = softbench(&forced);
    assert!(o.status.success(), "{}", stderr(&o));
    let after = series_times(&dir);
    let changed: Vec<&String> = after
        .iter()
        .zip(&before)
        .filter(|(a, b)| a.1 != b.1)
        .map(|(a, _)| &a.0)
        .collect();
    assert_eq!(
        changed,
        vec!["soft_beam-rk4.csv", "soft_beam-rk4.snapshots"]
    );

    // A changed configuration is not "already complete".
    let changed_study = std::fs::read_to_string(&file)
        .unwrap()
        .replace("\"run.sample_every\" = 5", "\"run.sample_every\" = 10")
        .replace(
            "\"scenes/",
            &format!("\"{}/", file.parent().unwrap().join("scenes").display()),
        );
    let copy = tmp.write("quickstart.toml", &changed_study);
    let o = softbench(&["run", copy.to_str().unwrap(), "--quick", "--out", &out]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("already complete"), "{}", stderr(&o));
}

#[test]
fn an_interrupted_study_resumes_where_it_stopped() {
    let tmp = TempDir::new("study-interrupt");
    let out = tmp.path().to_str().unwrap().to_owned();
    let file = study("energy_drift.toml");
    let args = ["run", file.to_str().unwrap(), "--quick", "--out", &out];
    let dir = tmp.path().join("energy_drift");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_softbench"))
        .args(args)
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Interrupt as soon as the first runs are recorded.
    let start = std::time::Instant::now();
    let mut finished_early = false;
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            assert!(status.success());
            finished_early = true;
            break;
        }
        let rows = Table::read(&dir.join("runs.csv"))
            .ok()
            .flatten()
            .map_or(0, |t| t.rows.len());
        if rows >= 2 {
            child.kill().unwrap();
            child.wait().unwrap();
            break;
        }
        assert!(
            start.elapsed().as_secs() < 300,
            "the study never recorded a run"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let recorded = Table::read(&dir.join("runs.csv")).unwrap().unwrap();
    // Whatever was interrupted left no partial file that a reader could mistake for output.
    assert!(recorded.rows.len() >= 2);

    let o = softbench(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let total = Table::read(&dir.join("runs.csv")).unwrap().unwrap();
    assert_eq!(total.rows.len(), 78);
    let message = format!("{} of 78 runs already complete", recorded.rows.len());
    if finished_early {
        assert!(stderr(&o).contains("78 of 78 runs already complete"));
    } else {
        assert!(
            stderr(&o).contains(&message),
            "expected `{message}` in {}",
            stderr(&o)
        );
    }
    // Rows recorded before the interruption are kept as they were.
    for row in &recorded.rows {
        assert!(total.rows.contains(row), "row of {} changed", row[0]);
    }
    assert_complete(&dir, &IDENTITY);
}

/// A study always draws the pictures of its bodies; `--render` is accepted (so `run --render`
/// works as `simulate --render` does) and changes nothing: the second run, with the flag,
/// reuses the runs and draws the (deleted) pictures again, byte for byte the same. It fails
/// if the flag is refused.
#[test]
fn run_draws_the_pictures_without_render_and_the_flag_changes_nothing() {
    let tmp = TempDir::new("study-render");
    let dir = tmp.path().join("quickstart");
    let pictures = || {
        ["pictures-soft_beam.png", "pictures-soft_beam.gif"]
            .map(|name| std::fs::read(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}")))
    };
    let only = ["--quick", "--only", "soft_beam-rk4*"];
    run_study_ok(&study("quickstart.toml"), tmp.path(), &only);
    let without = pictures();
    for name in ["pictures-soft_beam.png", "pictures-soft_beam.gif"] {
        std::fs::remove_file(dir.join(name)).unwrap();
    }
    let with_flag = [only.as_slice(), &["--render"]].concat();
    run_study_ok(&study("quickstart.toml"), tmp.path(), &with_flag);
    assert!(without == pictures(), "--render changed the pictures");
}
