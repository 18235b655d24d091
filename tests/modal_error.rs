//! The error in the lowest vibration modes separates the motion from its ringing: on stiff
//! bodies built here, L-stable methods damp the high modes a reference keeps, so their
//! pointwise error falls slower than their order, while the error in the 10 lowest modes of
//! the body at rest falls at the classical order. (The modes themselves are checked against a
//! dense eigensolver in `softbench_core::model::modes`.)

mod common;

use common::{TempDir, run_study_ok};
use softbench::study::table::Table;

const METHODS: [(&str, f64); 6] = [
    ("backward-euler", 1.0),
    ("bdf2", 2.0),
    ("tr-bdf2", 2.0),
    ("energy-momentum", 2.0),
    ("esdirk32", 3.0),
    ("rodas3", 3.0),
];

/// A clamped bar released from rest under gravity: the scene text.
fn bar(cells: [usize; 3], size: [f64; 3], material: &str, youngs: f64, mass: &str) -> String {
    format!(
        "[mesh]\ngenerate = {{ box = {cells:?}, size = {size:?} }}\n[material]\n\
         model = \"{material}\"\nyoungs_modulus = {youngs:e}\npoisson_ratio = 0.3\n\
         density = 1000.0\nmass = \"{mass}\"\n[fixed]\n\
         rule = {{ axis = \"x\", side = \"min\", tolerance = 1e-6 }}\n[forces]\n\
         gravity = [0.0, -9.81, 0.0]\n[integrator]\nmethod = \"backward-euler\"\n\
         [run]\ndt = 0.001\nsteps = 10\n"
    )
}

/// Per method: the observed order of the pointwise (L2) error and of the modal error, from
/// the two smallest steps of a work-precision ladder on `scene`.
fn orders(tmp: &TempDir, name: &str, scene: &str) -> Vec<(&'static str, f64, f64, f64)> {
    tmp.write(&format!("{name}.toml"), scene);
    let methods: Vec<String> = METHODS.iter().map(|(m, _)| format!("\"{m}\"")).collect();
    let study = tmp.write(
        &format!("{name}-study.toml"),
        &format!(
            "name = \"{name}\"\nstudy = \"work-precision\"\nscenes = [\"{name}.toml\"]\n\
             [grid]\n\"run.dt\" = [0.005, 0.0025, 0.00125, 0.000625]\n\
             \"integrator.method\" = [{}]\n[set]\n\"integrator.newton.tolerance\" = 1e-10\n\
             \"integrator.newton.max_iterations\" = 30\n[work-precision]\nhorizon = 0.4\n\
             samples = 8\n",
            methods.join(", ")
        ),
    );
    let out = tmp.path().join("results");
    run_study_ok(&study, &out, &[]);
    let runs = Table::read(&out.join(name).join("runs.csv"))
        .unwrap()
        .unwrap();
    let report = std::fs::read_to_string(out.join(name).join("report.md")).unwrap();
    assert!(report.contains("| scene | method | order | in the lowest modes |"));
    // The report names the body whose modes it counts, with their highest frequency.
    let cutoff = runs.number(&runs.rows[0], "modal_omega_cutoff").unwrap();
    assert!(
        report.contains(&format!("10 up to {cutoff:.3e} rad/s on {name}")),
        "{report}"
    );
    let error = |method: &str, dt: f64, column: &str| {
        let r = runs
            .rows
            .iter()
            .find(|r| runs.get(r, "method") == Some(method) && runs.number(r, "dt") == Some(dt))
            .unwrap();
        assert_eq!(runs.get(r, "modal_modes"), Some("10"));
        runs.number(r, column)
            .unwrap_or_else(|| panic!("{method} dt = {dt}: no {column}"))
    };
    let order = |method: &str, column: &str| {
        (error(method, 0.00125, column) / error(method, 0.000625, column)).log2()
    };
    METHODS
        .iter()
        .map(|&(m, classical)| (m, classical, order(m, "error"), order(m, "modal_error")))
        .collect()
}

#[test]
fn the_error_in_the_lowest_modes_falls_at_the_classical_order() {
    let tmp = TempDir::new("modal-orders");
    let scene = bar(
        [8, 2, 2],
        [0.8, 0.1, 0.1],
        "stable-neo-hookean",
        1e6,
        "consistent",
    );
    for (method, classical, pointwise, modal) in orders(&tmp, "bar", &scene) {
        eprintln!("{method}: order {pointwise:.2} pointwise, {modal:.2} in the lowest modes");
        assert!(
            (modal - classical).abs() <= 0.2,
            "{method}: modal order {modal:.2}, classical {classical}"
        );
    }
}

#[test]
fn the_modal_order_is_never_further_from_the_classical_one_than_the_pointwise_order() {
    // Another material, shape, stiffness and mass matrix: at these steps backward Euler and
    // BDF2 are still pre-asymptotic in the modes kept, but the modal order is never the worse
    // measure of the two, and the third-order methods show their order only in the modes.
    let tmp = TempDir::new("modal-orders-2");
    let scene = bar([6, 3, 2], [0.5, 0.15, 0.08], "stvk", 3e6, "lumped");
    for (method, classical, pointwise, modal) in orders(&tmp, "plate", &scene) {
        eprintln!("{method}: order {pointwise:.2} pointwise, {modal:.2} in the lowest modes");
        assert!(
            (modal - classical).abs() <= (pointwise - classical).abs() + 0.05,
            "{method}: modal order {modal:.2}, pointwise {pointwise:.2}, classical {classical}"
        );
        if classical == 3.0 {
            assert!(
                modal >= 2.75 && pointwise <= 2.5,
                "{method}: {modal:.2}, {pointwise:.2}"
            );
        }
    }
}
