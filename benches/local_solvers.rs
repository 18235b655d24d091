//! One step of the local solvers on a generated 12,000-tet box (20×10×10 cells of 0.05 m,
//! ρ 1000 kg/m³, E 1e6 Pa, ν 0.45, dt 0.01 s, gravity, the x = 0 end fixed): `vbd` with 20
//! iterations on Stable Neo-Hookean, and `xpbd` with 50 substeps (1 iteration) on its own
//! constraint energy `xpbd-neo-hookean` (same E and ν; XPBD refuses other materials).
//! Lumped mass. Each step starts from the rest state.
//!
//! `cargo bench --bench local_solvers` (add `-- --quick` for a shorter run).

#[path = "support/clamped_box.rs"]
mod clamped_box;

use clamped_box::clamped_box;
use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use softbench::integrate::vbd::{Vbd, VbdSettings};
use softbench::integrate::xpbd::{Xpbd, XpbdSettings};
use softbench::integrate::{Integrator, State};
use softbench::model::Model;
use std::time::Duration;

fn box_model(material: &str) -> Model {
    let model = clamped_box(material, [20, 10, 10]);
    assert_eq!(model.elastic_elements().unwrap().tets.len(), 12_000);
    model
}

fn bench(c: &mut Criterion, name: &str, mut model: Model, mut integ: Box<dyn Integrator>) {
    let start = State::at_rest(&model);
    // One step first, so set-up (colouring, incidence lists) is not measured.
    integ.step(&mut model, &mut start.clone(), 0.01).unwrap();
    c.bench_function(name, |b| {
        b.iter_batched(
            || start.clone(),
            |mut s| integ.step(&mut model, &mut s, 0.01).unwrap(),
            BatchSize::LargeInput,
        )
    });
}

fn local_solvers(c: &mut Criterion) {
    let vbd = VbdSettings {
        iterations: 20,
        ..Default::default()
    };
    bench(
        c,
        "vbd_20_iterations_box12k",
        box_model("stable-neo-hookean"),
        Box::new(Vbd::new(vbd)),
    );
    let xpbd = XpbdSettings {
        substeps: 50,
        iterations: 1,
        ..Default::default()
    };
    bench(
        c,
        "xpbd_50_substeps_box12k",
        box_model("xpbd-neo-hookean"),
        Box::new(Xpbd::new(xpbd)),
    );
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .without_plots();
    targets = local_solvers
}
criterion_main!(benches);
