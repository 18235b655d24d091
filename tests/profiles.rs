//! `softbench profiles`: performance and data profiles of a work-precision study, from its
//! runs.csv — the files, the numbers against the table they come from, and bad input.

mod common;

use common::softbench;
use std::path::Path;

fn write(path: &Path, text: &str) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, text).unwrap();
}

const HEADER: &str =
    "scene,method,linear_solver,outcome,error,wall_seconds,force_evaluations,hessian_evaluations\n";

#[test]
fn profiles_of_a_table_count_what_it_says() {
    let dir = tempfile::tempdir().unwrap();
    let results = dir.path().join("study");
    write(
        &results.join("runs.csv"),
        &format!(
            "{HEADER}\
             beam,fast,cholesky,completed,1e-3,0.5,10,10\n\
             beam,slow,cholesky,completed,1e-5,2.0,40,40\n\
             beam,slow,cholesky,completed,1e-3,1.5,30,30\n\
             beam,broken,cholesky,blew-up,1e-9,0.1,1,1\n\
             ball,fast,cholesky,completed,1e-2,0.2,5,5\n\
             ball,slow,cholesky,completed,1e-4,1.0,20,20\n"
        ),
    );
    let o = softbench(&[
        "profiles",
        results.to_str().unwrap(),
        "--targets",
        "1e-2,1e-4",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = results.join("profiles");
    for f in [
        "profiles.csv",
        "costs.csv",
        "profiles.md",
        "performance-wall.png",
        "performance-work.svg",
        "data-wall.png",
        "data-work.svg",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    // 4 problems: beam and ball at 1e-2 and 1e-4. fast solves both at 1e-2 (cheapest there);
    // slow solves all four (cheapest at 1e-4 where it alone solves); broken none.
    let md = std::fs::read_to_string(out.join("profiles.md")).unwrap();
    assert!(md.contains("| `fast` | 2 | 2 | 0.50 | 0.50 |"), "{md}");
    assert!(md.contains("| `slow` | 4 | 2 | 0.50 | 1.00 |"), "{md}");
    assert!(md.contains("| `broken` | 0 | 0 | 0.00 | 0.00 |"), "{md}");
    let costs = std::fs::read_to_string(out.join("costs.csv")).unwrap();
    assert!(costs.contains("beam,1e-2,slow,1.5,60"), "{costs}");
    assert!(costs.contains("beam,1e-4,fast,,"), "{costs}");
}

#[test]
fn bad_input_exits_2_and_says_what_is_wrong() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let o = softbench(&["profiles", empty.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no runs.csv"));
    // A stability study's table: no error or evaluation columns.
    let other = dir.path().join("other");
    write(
        &other.join("runs.csv"),
        "scene,method,outcome,dt_limit\nbeam,rk4,completed,1e-3\n",
    );
    let o = softbench(&["profiles", other.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("error") && err.contains("wall_seconds"),
        "{err}"
    );
    let good = dir.path().join("good");
    write(
        &good.join("runs.csv"),
        &format!("{HEADER}beam,fast,cholesky,completed,1e-3,0.5,10,10\n"),
    );
    let o = softbench(&["profiles", good.to_str().unwrap(), "--targets", "1e-3,-1"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("target -1"));
    assert!(
        !good.join("profiles").exists(),
        "nothing written on bad input"
    );
}
