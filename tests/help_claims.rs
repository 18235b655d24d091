//! What the subcommands' `--help` texts claim, checked against what the commands do.

mod common;

use common::softbench;
use softbench::study::matches;

/// A command's help text with its line breaks and indentation folded into single spaces.
fn help(command: &str) -> String {
    let output = softbench(&[command, "--help"]);
    assert!(output.status.success());
    String::from_utf8_lossy(&output.stdout)
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

#[test]
fn run_only_matches_ids_as_its_help_says() {
    let text = help("run");
    assert!(
        text.contains("Only the runs whose id contains PATTERN; a PATTERN with `*` (any text) must match the whole id, e.g. `jello*-rk4`"),
        "{text}"
    );
    // Without `*`: anywhere in the id.
    assert!(matches("soft_jello_cube-rk4", "jello"));
    // With `*`: the whole id, from its first character to its last.
    assert!(matches("jello_cube-rk4", "jello*-rk4"));
    assert!(!matches("soft_jello_cube-rk4", "jello*-rk4"));
    assert!(!matches("jello_cube-rk4-cholesky", "jello*-rk4"));
}

#[test]
fn list_prints_every_family_its_help_names() {
    let text = help("list");
    assert!(
        text.contains(
            "integrators, linear solvers, materials, contact responses, obstacle kinds, export \
             and mesh formats (with their facts), the study kinds, and the scenes and studies"
        ),
        "{text}"
    );
    let output = softbench(&["list"]);
    assert!(output.status.success());
    let listing = String::from_utf8_lossy(&output.stdout);
    for title in [
        "integrators (",
        "linear solvers (",
        "materials (",
        "contact responses (",
        "obstacle kinds (",
        "export formats (",
        "mesh formats (",
        "study kinds (",
        "scenes (",
        "studies (",
    ] {
        assert!(
            listing.lines().any(|l| l.starts_with(title)),
            "no `{title}` section in:\n{listing}"
        );
    }
}
