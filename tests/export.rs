//! Frames for viewers: VTU files read back by an independent reader (Python's meshio), the PVD
//! collection, OBJ frames read back by our own OBJ reader.

mod common;

use std::io::Write;
use std::path::Path;
use std::process::Command;

use common::TempDir;
use nalgebra::Vector3;
use softbench::export::{FrameContent, FrameWriter, SERIES_FILE};
use softbench::integrate::State;
use softbench::material::{LameParameters, MaterialModel, NeoHookean};
use softbench::mesh::generate::box_mesh;
use softbench::mesh::surface::boundary_faces;
use softbench::mesh::{Skinning, read_surface_mesh};
use softbench::model::{AxisRule, FixedSelection, Model, ModelSpec, Side};
use softbench::rng::Rng;
use softbench::run::Observer;

/// A 3×2×2 box (1×0.5×0.5 m) clamped at x = 0.
fn clamped_box() -> Model {
    let mut spec = ModelSpec::elastic(
        box_mesh([3, 2, 2], [1.0, 0.5, 0.5]),
        MaterialModel::NeoHookean(NeoHookean::new(
            LameParameters::from_youngs_poisson(1e5, 0.3).unwrap(),
        )),
        1000.0,
    );
    spec.fixed = FixedSelection {
        rules: vec![AxisRule {
            axis: 0,
            side: Side::Min,
            tolerance: 1e-9,
        }],
        ..Default::default()
    };
    Model::new(spec).unwrap()
}

/// A deformed state with a distinct velocity at every free DOF.
fn moving_state(model: &Model, t: f64) -> State {
    let mut rng = Rng::new(9);
    let q = model
        .rest_state()
        .iter()
        .map(|x| x + rng.range(-0.02, 0.02))
        .collect();
    let v = (0..model.num_dofs()).map(|i| 0.1 + i as f64).collect();
    State { q, v, t }
}

/// An observer that ignores rows.
fn no_rows() -> impl Observer {
    |_: &softbench::run::Sample| Ok(())
}

/// Runs `script` (Python, with `meshio` and `json` imported) and returns its stdout. When
/// meshio cannot be imported: under CI (`CI` set) the test fails; otherwise it prints a visible
/// `skipped:` line and returns `None`.
fn run_with_meshio(script: &str) -> Option<String> {
    let probe = Command::new("python3")
        .args(["-c", "import meshio"])
        .output();
    let importable = probe.as_ref().is_ok_and(|o| o.status.success());
    if !importable {
        let why = match &probe {
            Ok(o) => String::from_utf8_lossy(&o.stderr).trim().to_owned(),
            Err(e) => format!("cannot run python3: {e}"),
        };
        if std::env::var_os("CI").is_some() {
            panic!(
                "CI is set but Python's meshio is not importable ({why}); .ci/run installs it \
                 with `python3 -m pip install meshio`"
            );
        }
        let test = std::thread::current()
            .name()
            .unwrap_or("<unnamed test>")
            .to_string();
        let _ = writeln!(
            std::io::stderr(),
            "skipped: {test}: Python's meshio is not importable ({why}); \
             `python3 -m pip install meshio` to run it"
        );
        return None;
    }
    let out = Command::new("python3")
        .args(["-c", &format!("import json, meshio\n{script}")])
        .output()
        .expect("cannot run python3");
    assert!(
        out.status.success(),
        "meshio script failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(String::from_utf8(out.stdout).unwrap())
}

#[test]
fn an_exported_vtu_is_read_back_by_meshio_with_velocity_and_j() {
    let model = clamped_box();
    let state = moving_state(&model, 0.25);
    let dir = TempDir::new("export-meshio");
    let frames_dir = dir.path().join("frames");
    let mut rows = no_rows();
    let content = FrameContent::tets(&model, model.tets().to_vec());
    let mut writer = FrameWriter::new(&frames_dir, 1, 0, content, &mut rows).unwrap();
    writer.after_step(0, &model, &state).unwrap();
    let frames = writer.finish(&model, &state, 0).unwrap();
    assert_eq!(frames.len(), 1, "finish does not repeat the last frame");
    let file = frames_dir.join(&frames[0].file);
    assert_eq!(frames[0].file, "frame_00000.vtu");

    // Floats go through `repr` strings: Python's repr and Rust's `parse` are both exact.
    let script = format!(
        "m = meshio.read({:?})\n\
         exact = lambda a: [repr(float(x)) for x in a.ravel()]\n\
         cells = [c for c in m.cells if c.type == 'tetra']\n\
         print(json.dumps({{\n\
           'points': exact(m.points),\n\
           'tetra': cells[0].data.tolist(),\n\
           'blocks': len(m.cells),\n\
           'velocity_shape': list(m.point_data['velocity'].shape),\n\
           'velocity': exact(m.point_data['velocity']),\n\
           'J_shape': list(m.cell_data['J'][0].shape),\n\
           'J': exact(m.cell_data['J'][0]),\n\
           'energy': exact(m.cell_data['energy'][0]),\n\
         }}))",
        file.to_str().unwrap()
    );
    let Some(stdout) = run_with_meshio(&script) else {
        return;
    };
    let got: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let n = model.rest_positions().len();
    let m = model.tets().len();
    let as_f64s = |v: &serde_json::Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_str().unwrap().parse().unwrap())
            .collect()
    };
    let as_vec3s = |v: &serde_json::Value| -> Vec<Vector3<f64>> {
        as_f64s(v)
            .chunks_exact(3)
            .map(|c| Vector3::new(c[0], c[1], c[2]))
            .collect()
    };
    // Counts and shapes.
    assert_eq!(got["blocks"], 1);
    assert_eq!(got["points"].as_array().unwrap().len(), 3 * n);
    assert_eq!(got["tetra"].as_array().unwrap().len(), m);
    assert_eq!(got["velocity_shape"], serde_json::json!([n, 3]));
    assert_eq!(got["J_shape"], serde_json::json!([m]));
    // Values, bit for bit (binary arrays; JSON floats round-trip).
    assert_eq!(as_vec3s(&got["points"]), model.full_positions(&state.q));
    let tets: Vec<[usize; 4]> = got["tetra"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| std::array::from_fn(|i| t[i].as_u64().unwrap() as usize))
        .collect();
    assert_eq!(tets, model.tets());
    let velocity = as_vec3s(&got["velocity"]);
    for (v, vel) in velocity.iter().enumerate() {
        let f = model.dofs().free_index(v);
        let expected = if model.dofs().is_fixed(v) {
            Vector3::zeros()
        } else {
            let f = 3 * f as usize;
            Vector3::new(state.v[f], state.v[f + 1], state.v[f + 2])
        };
        assert_eq!(*vel, expected, "vertex {v}");
    }
    assert!(velocity.iter().any(|v| *v == Vector3::zeros()));
    let (mut det_f, mut energy) = (vec![0.0; m], vec![0.0; m]);
    model
        .element_measures(&state.q, &mut det_f, &mut energy)
        .unwrap();
    assert_eq!(as_f64s(&got["J"]), det_f);
    assert_eq!(as_f64s(&got["energy"]), energy);
    assert!(
        det_f.iter().any(|&j| (j - 1.0).abs() > 1e-3),
        "J is not trivially 1"
    );
}

/// The `(timestep, file)` entries of a `.pvd` file, in order.
fn pvd_entries(path: &Path) -> Vec<(f64, String)> {
    let text = std::fs::read_to_string(path).unwrap();
    let attribute = |line: &str, key: &str| -> String {
        let start = line.find(&format!("{key}=\"")).unwrap() + key.len() + 2;
        line[start..].split('"').next().unwrap().to_owned()
    };
    text.lines()
        .filter(|l| l.trim_start().starts_with("<DataSet"))
        .map(|l| {
            (
                attribute(l, "timestep").parse().unwrap(),
                attribute(l, "file"),
            )
        })
        .collect()
}

#[test]
fn the_pvd_lists_every_frame_with_increasing_times() {
    let model = clamped_box();
    let dir = TempDir::new("export-pvd");
    let frames_dir = dir.path().join("frames");
    let mut rows = no_rows();
    let content = FrameContent::tets(&model, model.tets().to_vec());
    let mut writer = FrameWriter::new(&frames_dir, 3, 10, content, &mut rows).unwrap();
    let mut state = moving_state(&model, 0.0);
    for step in 0..=10 {
        state.t = 0.01 * step as f64;
        writer.after_step(step, &model, &state).unwrap();
    }
    let frames = writer.finish(&model, &state, 10).unwrap();
    let steps: Vec<usize> = frames.iter().map(|f| f.step).collect();
    assert_eq!(steps, [0, 3, 6, 9, 10]);
    let entries = pvd_entries(&frames_dir.join(SERIES_FILE));
    assert_eq!(entries.len(), frames.len());
    for (frame, (t, file)) in frames.iter().zip(&entries) {
        assert_eq!(*file, frame.file);
        assert_eq!(*t, frame.t);
        assert!(frames_dir.join(file).is_file(), "{file}");
    }
    assert!(entries.windows(2).all(|w| w[0].0 < w[1].0), "{entries:?}");
    let names: Vec<String> = std::fs::read_dir(&frames_dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert!(names.iter().all(|n| !n.ends_with(".partial")), "{names:?}");
    assert_eq!(names.len(), frames.len() + 1);

    // A new series in the same folder replaces the old one: no stale frames remain.
    let mut rows = no_rows();
    let content = FrameContent::tets(&model, model.tets().to_vec());
    let writer = FrameWriter::new(&frames_dir, 1, 0, content, &mut rows).unwrap();
    writer.finish(&model, &state, 0).unwrap();
    let count = std::fs::read_dir(&frames_dir).unwrap().count();
    assert_eq!(count, 2, "one frame and series.pvd");
    assert_eq!(pvd_entries(&frames_dir.join(SERIES_FILE)).len(), 1);
}

#[test]
fn obj_frames_of_the_boundary_surface_parse_back_with_the_right_counts() {
    let model = clamped_box();
    let state = moving_state(&model, 0.5);
    let dir = TempDir::new("export-obj");
    let mut rows = no_rows();
    let content = FrameContent::boundary_surface(model.tets());
    let writer = FrameWriter::new(dir.path(), 1, 7, content, &mut rows).unwrap();
    let frames = writer.finish(&model, &state, 7).unwrap();
    assert_eq!(frames[0].file, "frame_00007.obj");
    let surface = read_surface_mesh(dir.path().join(&frames[0].file)).unwrap();
    let faces = boundary_faces(model.tets());
    let mut used: Vec<usize> = faces.iter().flatten().copied().collect();
    used.sort_unstable();
    used.dedup();
    assert_eq!(surface.num_triangles(), faces.len());
    assert_eq!(surface.num_vertices(), used.len(), "only boundary vertices");
    assert!(used.len() < model.rest_positions().len());
    assert!(surface.is_closed_manifold());
    // Positions round-trip exactly, and triangles map back to the boundary faces.
    let x = model.full_positions(&state.q);
    for (p, &v) in surface.positions.iter().zip(&used) {
        assert_eq!(*p, x[v]);
    }
    let back: Vec<[usize; 3]> = surface
        .triangles
        .iter()
        .map(|t| t.map(|i| used[i]))
        .collect();
    assert_eq!(back, faces);
    assert!(
        !dir.path().join(SERIES_FILE).exists(),
        "no PVD for OBJ frames"
    );
}

#[test]
fn obj_frames_of_a_skinned_display_mesh_follow_the_tets() {
    let model = clamped_box();
    let state = moving_state(&model, 0.5);
    // A display mesh: the box's boundary surface, shrunk a little towards the centre.
    let rest = softbench::mesh::TetMesh {
        positions: model.rest_positions().to_vec(),
        tets: model.tets().to_vec(),
    };
    let mut display = rest.boundary_surface();
    let centre = Vector3::new(0.5, 0.25, 0.25);
    for p in &mut display.positions {
        *p = centre + (*p - centre) * 0.9;
    }
    let skin = Skinning::new(&rest, &display.positions).unwrap();
    assert!(skin.outside().is_empty());
    let expected = skin.apply(&model.full_positions(&state.q));
    let dir = TempDir::new("export-skinned");
    let mut rows = no_rows();
    let content = FrameContent::skinned(skin, display.triangles.clone(), "shrunk box");
    let writer = FrameWriter::new(dir.path(), 1, 3, content, &mut rows).unwrap();
    let frames = writer.finish(&model, &state, 3).unwrap();
    let surface = read_surface_mesh(dir.path().join(&frames[0].file)).unwrap();
    assert_eq!(surface.num_vertices(), display.num_vertices());
    assert_eq!(surface.triangles, display.triangles);
    assert_eq!(surface.positions, expected);
}
