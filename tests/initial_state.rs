//! `[initial]`: stretched, mirrored (inverted) and twisted starts, checked on the state the
//! scene builds; bad values are refused naming the key.

mod common;

use nalgebra::Vector3;
use softbench::data::DataPaths;
use softbench::parallel::Parallelism;
use softbench::scene;

const BAR: &str = "[mesh]\ngenerate = { box = [8, 2, 2], size = [0.8, 0.1, 0.1] }\n\
    [material]\nmodel = \"stable-neo-hookean\"\nyoungs_modulus = 1e5\npoisson_ratio = 0.3\n\
    density = 1000.0\n[integrator]\nmethod = \"backward-euler\"\n[run]\ndt = 0.01\nsteps = 5\n";

fn build(initial: &str) -> Result<scene::Scene, String> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bar.toml");
    std::fs::write(&path, format!("{BAR}[initial]\n{initial}")).unwrap();
    let loaded = scene::load(&path, &[]).map_err(|e| e.to_string())?;
    scene::build(&loaded, &DataPaths::from_env(), Parallelism::Sequential)
        .map_err(|e| e.to_string())
}

fn vertex(q: &[f64], k: usize) -> Vector3<f64> {
    Vector3::new(q[3 * k], q[3 * k + 1], q[3 * k + 2])
}

#[test]
fn a_twist_turns_each_section_by_rate_times_its_distance_from_the_centroid() {
    let built = build("twist = { axis = \"x\", rate = 2.0 }\n").unwrap();
    let rest = built.model.rest_positions();
    let c = rest.iter().sum::<Vector3<f64>>() / rest.len() as f64;
    let mut largest = 0.0f64;
    for (k, &v) in built.model.dofs().free_vertices().iter().enumerate() {
        let (x, r) = (vertex(&built.initial.q, k) - c, rest[v] - c);
        // Along the axis nothing moves; across it the section turns by 2 rad/m * r_x.
        assert!((x.x - r.x).abs() < 1e-12);
        let angle = 2.0 * r.x;
        let expected = Vector3::new(
            r.x,
            r.y * angle.cos() - r.z * angle.sin(),
            r.y * angle.sin() + r.z * angle.cos(),
        );
        assert!(
            (x - expected).norm() < 1e-12,
            "vertex {v}: {x:?} vs {expected:?}"
        );
        largest = largest.max(angle.abs());
    }
    assert!((largest - 0.8).abs() < 1e-12, "the ends turn by ±0.8 rad");
    // A twisted bar stores elastic energy and starts at rest.
    let mut model = built.model;
    assert!(
        model.potential(&built.initial.q).unwrap() > model.potential(&model.rest_state()).unwrap()
    );
    assert!(built.initial.v.iter().all(|v| *v == 0.0));
}

#[test]
fn a_negative_stretch_mirrors_the_body_and_inverts_every_element() {
    let built = build("stretch = [-1.0, 1.0, 1.0]\n").unwrap();
    let inverted = built.model.inverted_elements(&built.initial.q).unwrap();
    assert_eq!(inverted, built.model.elastic_elements().unwrap().tets.len());
}

fn refused(initial: &str) -> String {
    match build(initial) {
        Ok(_) => panic!("{initial} was accepted"),
        Err(e) => e,
    }
}

#[test]
fn bad_starts_are_refused_naming_the_key() {
    let err = refused("stretch = [0.0, 1.0, 1.0]\n");
    assert!(
        err.contains("initial.stretch") && err.contains("nonzero"),
        "{err}"
    );
    let err = refused("twist = { axis = \"x\", rate = nan }\n");
    assert!(err.contains("initial.twist.rate"), "{err}");
    let err = refused("twist = { axis = \"w\", rate = 1.0 }\n");
    assert!(err.contains("axis") || err.contains("variant"), "{err}");
}
