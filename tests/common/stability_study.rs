//! Stability studies on clamped boxes built in the test: the scene text, its omega_max, and a
//! study of a few methods over it.

use super::bodies::{clamped_at_min_x, omega_max};
use super::{TempDir, run_study_ok};
use softbench::material::{LameParameters, MaterialModel};
use softbench::mesh::generate::box_mesh;
use softbench::model::{Model, ModelSpec};
use softbench::study::table::Table;

/// A clamped box of `cells` over `size` (m) with a material, E (Pa), consistent mass and gravity
/// g (m/s², along -y): the scene text and its omega_max (rad/s) at rest.
pub fn clamped_box(
    cells: [usize; 3],
    size: [f64; 3],
    material: &str,
    youngs: f64,
    g: f64,
) -> (String, f64) {
    let lame = LameParameters::from_youngs_poisson(youngs, 0.3).unwrap();
    let mut spec = ModelSpec::elastic(
        box_mesh(cells, size),
        MaterialModel::from_name(material, lame).unwrap(),
        1000.0,
    );
    spec.fixed = clamped_at_min_x();
    spec.gravity = Some(nalgebra::Vector3::new(0.0, -g, 0.0));
    let omega = omega_max(&mut Model::new(spec).unwrap());
    let text = format!(
        "[mesh]\ngenerate = {{ box = {cells:?}, size = {size:?} }}\n[material]\n\
         model = \"{material}\"\nyoungs_modulus = {youngs:e}\npoisson_ratio = 0.3\n\
         density = 1000.0\nmass = \"consistent\"\n[fixed]\n\
         rule = {{ axis = \"x\", side = \"min\", tolerance = 1e-6 }}\n[forces]\n\
         gravity = [0.0, {:e}, 0.0]\n[integrator]\nmethod = \"backward-euler\"\n\
         [run]\ndt = 0.001\nsteps = 10\n",
        -g
    );
    (text, omega)
}

/// Run a stability study of `methods` on `scene_text` with the `[stability]` lines given (no
/// reference unless they set `error_samples`); its runs.csv.
pub fn stability(
    tmp: &TempDir,
    name: &str,
    scene_text: &str,
    methods: &[&str],
    table: &str,
) -> Table {
    tmp.write(&format!("{name}-scene.toml"), scene_text);
    let list: Vec<String> = methods.iter().map(|m| format!("\"{m}\"")).collect();
    let study = tmp.write(
        &format!("{name}.toml"),
        &format!(
            "name = \"{name}\"\nstudy = \"stability\"\nscenes = [\"{name}-scene.toml\"]\n\
             [grid]\n\"integrator.method\" = [{}]\n[stability]\n{}{table}\n",
            list.join(", "),
            if table.contains("error_samples") {
                ""
            } else {
                "error_samples = 0\n"
            }
        ),
    );
    let out = tmp.path().join("results");
    run_study_ok(&study, &out, &[]);
    Table::read(&out.join(name).join("runs.csv"))
        .unwrap()
        .unwrap()
}

pub fn row<'a>(runs: &'a Table, method: &str) -> &'a Vec<String> {
    runs.rows
        .iter()
        .find(|r| runs.get(r, "method") == Some(method))
        .unwrap_or_else(|| panic!("no row for {method}"))
}
