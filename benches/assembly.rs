//! Gradient and Hessian assembly throughput (tets per second), serial and parallel, with the
//! course Neo-Hookean: on a generated ~100k-tet box and on the course armadillo (`arma_6`,
//! when `SOFTBENCH_DATA` points at the reference meshes).
//!
//! `cargo bench --bench assembly` (add `-- --quick` for a shorter run).

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::Vector3;
use softbench::material::{LameParameters, MaterialModel, NeoHookean};
use softbench::mesh::TetMesh;
use softbench::model::{HessianOptions, Model, ModelSpec};
use softbench::parallel::Parallelism;
use softbench::rng::Rng;
use std::time::Duration;

fn meshes() -> Vec<(String, TetMesh)> {
    let mut list = vec![("box_101k".to_string(), bench_box([26, 26, 25]))];
    if let Ok(dir) = std::env::var("SOFTBENCH_DATA") {
        let path = std::path::Path::new(&dir).join("arma_6.node");
        match softbench::mesh::read_tet_mesh(&path) {
            Ok(mesh) => list.push(("arma_6".to_string(), mesh)),
            Err(e) => eprintln!("skipping arma_6: {e}"),
        }
    } else {
        eprintln!("skipping arma_6: SOFTBENCH_DATA is not set");
    }
    list
}

fn bench_box(cells: [usize; 3]) -> TetMesh {
    softbench::mesh::generate::box_mesh(cells, [1.0, 1.0, 1.0])
}

fn assembly(c: &mut Criterion) {
    let material = MaterialModel::NeoHookean(NeoHookean::new(
        LameParameters::from_youngs_poisson(6e5, 0.4).unwrap(),
    ));
    let mut group = c.benchmark_group("assembly");
    for (name, mesh) in meshes() {
        let tets = mesh.num_tets() as u64;
        for (par_name, par) in [
            ("serial", Parallelism::Sequential),
            ("parallel", Parallelism::Rayon),
        ] {
            let mut spec = ModelSpec::elastic(mesh.clone(), material, 1000.0);
            spec.parallelism = par;
            let mut model = Model::new(spec).unwrap();
            // A small random deformation so no branch sees the rest state.
            let mut rng = Rng::new(7);
            let scale = mesh.bounding_box().map_or(1.0, |(lo, hi)| (hi - lo).norm()) * 1e-3;
            let q: Vec<f64> = model
                .rest_state()
                .iter()
                .map(|x| x + rng.range(-scale, scale))
                .collect();
            let mut g = vec![0.0; q.len()];
            let mut h = model.new_hessian();
            group.throughput(Throughput::Elements(tets));
            group.bench_function(
                BenchmarkId::new(format!("gradient/{par_name}"), &name),
                |b| b.iter(|| model.gradient(&q, &mut g).unwrap()),
            );
            group.bench_function(
                BenchmarkId::new(format!("hessian/{par_name}"), &name),
                |b| {
                    b.iter(|| {
                        model
                            .hessian(&q, &mut h, HessianOptions::default())
                            .unwrap()
                    })
                },
            );
            group.bench_function(BenchmarkId::new(format!("energy/{par_name}"), &name), |b| {
                b.iter(|| model.potential(&q).unwrap())
            });
        }
    }
    group.finish();
    let _ = Vector3::<f64>::zeros();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2))
        .without_plots();
    targets = assembly
}
criterion_main!(benches);
