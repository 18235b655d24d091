//! Per-call cost of psi, P and dP/dF for each material, over a batch of 1024 random F near I
//! (det F > 0, so every model is defined). Criterion reports the batch time; the throughput
//! line gives calls per second, and batch time / 1024 is the time per call.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::Matrix3;
use softbench::material::{LameParameters, Material, MaterialModel};
use softbench::rng::Rng;
use std::hint::black_box;
use std::time::Duration;

const BATCH: usize = 1024;

fn deformations() -> Vec<Matrix3<f64>> {
    let mut rng = Rng::new(2024);
    let mut fs = Vec::with_capacity(BATCH);
    while fs.len() < BATCH {
        let f = Matrix3::identity() + Matrix3::from_fn(|_, _| rng.range(-0.3, 0.3));
        if f.determinant() > 0.2 {
            fs.push(f);
        }
    }
    fs
}

/// The three kernels of one material, monomorphized for `M`.
fn bench_material<M: Material>(c: &mut Criterion, name: &str, m: M, fs: &[Matrix3<f64>]) {
    let mut group = c.benchmark_group(name);
    group.throughput(Throughput::Elements(fs.len() as u64));
    group.bench_function("psi", |b| {
        b.iter(|| {
            for f in fs {
                black_box(m.energy_density(black_box(f)).unwrap());
            }
        })
    });
    group.bench_function("P", |b| {
        b.iter(|| {
            for f in fs {
                black_box(m.first_piola(black_box(f)).unwrap());
            }
        })
    });
    group.bench_function("dPdF", |b| {
        b.iter(|| {
            for f in fs {
                black_box(m.first_piola_derivative(black_box(f)).unwrap());
            }
        })
    });
    group.finish();
}

fn materials(c: &mut Criterion) {
    let lame = LameParameters::from_youngs_poisson(1e5, 0.3).unwrap();
    let fs = deformations();
    for name in MaterialModel::NAMES {
        // Dispatch once per material, as element loops do.
        match MaterialModel::from_name(name, lame).unwrap() {
            MaterialModel::NeoHookean(m) => bench_material(c, name, m, &fs),
            MaterialModel::StableNeoHookean(m) => bench_material(c, name, m, &fs),
            MaterialModel::StVenantKirchhoff(m) => bench_material(c, name, m, &fs),
            MaterialModel::Corotated(m) => bench_material(c, name, m, &fs),
            MaterialModel::ConstraintNeoHookean(m) => bench_material(c, name, m, &fs),
        }
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_millis(500))
        .without_plots();
    targets = materials
}
criterion_main!(benches);
