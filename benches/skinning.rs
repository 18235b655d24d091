//! Building the skinning of the course armadillo's display mesh (`armadillo.obj`, 26,002
//! vertices) onto `arma_6` (627 tets), and applying it once. Needs `SOFTBENCH_DATA`; without it
//! the bench says so and measures nothing.
//!
//! `cargo bench --bench skinning`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use softbench::mesh::{Skinning, read_surface_mesh, read_tet_mesh};
use std::time::Duration;

fn skinning(c: &mut Criterion) {
    let Some(dir) = std::env::var_os("SOFTBENCH_DATA") else {
        eprintln!("skipping skinning: SOFTBENCH_DATA is not set");
        return;
    };
    let dir = std::path::Path::new(&dir);
    let (mesh, display) = match (
        read_tet_mesh(dir.join("arma_6.node")),
        read_surface_mesh(dir.join("armadillo.obj")),
    ) {
        (Ok(m), Ok(d)) => (m, d),
        (Err(e), _) | (_, Err(e)) => {
            eprintln!("skipping skinning: {e}");
            return;
        }
    };
    let mut group = c.benchmark_group("skinning");
    group.throughput(Throughput::Elements(display.num_vertices() as u64));
    group.bench_function("build/armadillo.obj-on-arma_6", |b| {
        b.iter(|| Skinning::new(&mesh, &display.positions).unwrap())
    });
    let skin = Skinning::new(&mesh, &display.positions).unwrap();
    let mut out = vec![nalgebra::Vector3::zeros(); skin.num_display_vertices()];
    group.bench_function("apply/armadillo.obj-on-arma_6", |b| {
        b.iter(|| skin.apply_into(&mesh.positions, &mut out))
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_secs(1))
        .without_plots();
    targets = skinning
}
criterion_main!(benches);
