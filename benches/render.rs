//! Drawing one picture of a body: the boundary surface of a generated tet mesh of about 50k
//! tets (a ball of 48k tets and a box of 50.4k tets), flat-shaded into the
//! 240x200 tile the filmstrips and study panels use and into an 800x600 image; plus the
//! surface extraction a run does once. The target: a 50k-tet mesh renders a frame in well
//! under a second.
//!
//! `cargo bench --bench render`.

use criterion::{Criterion, criterion_group, criterion_main};
use softbench::mesh::TetMesh;
use softbench::mesh::generate::{ball, box_mesh};
use softbench::mesh::surface::classify_faces;
use softbench::render::film::draw_frame;
use softbench::render::raster::{Bounds, Camera, Canvas};
use softbench::render::{Coloring, SnapshotFrame, Snapshots};
use std::time::Duration;

/// The boundary surface of `mesh` at rest as one snapshot frame.
fn snapshots(mesh: &TetMesh) -> Snapshots {
    let faces = classify_faces(&mesh.tets).boundary;
    let mut vertices: Vec<usize> = faces.iter().flatten().copied().collect();
    vertices.sort_unstable();
    vertices.dedup();
    let local = |v: usize| vertices.binary_search(&v).unwrap() as u32;
    let positions = vertices
        .iter()
        .map(|&v| mesh.positions[v].map(|x| x as f32).into())
        .collect();
    Snapshots {
        up: [0.0, 1.0, 0.0],
        end_time: 1.0,
        triangles: faces.iter().map(|f| f.map(local)).collect(),
        frames: vec![SnapshotFrame {
            positions,
            ..SnapshotFrame::default()
        }],
        failure: String::new(),
    }
}

fn render(c: &mut Criterion) {
    let meshes = [
        ("ball-r10", ball(1.0, 10)),
        ("box-20x20x21", box_mesh([20, 20, 21], [1.0, 1.0, 1.05])),
    ];
    let mut group = c.benchmark_group("render");
    for (name, mesh) in &meshes {
        let s = snapshots(mesh);
        eprintln!(
            "{name}: {} tets, {} surface triangles",
            mesh.tets.len(),
            s.triangles.len()
        );
        group.bench_function(format!("surface/{name}"), |b| {
            b.iter(|| classify_faces(&mesh.tets))
        });
        let frame = &s.frames[0];
        for (w, h) in [(240, 200), (800, 600)] {
            let camera = Camera::framing(&Bounds::of(&frame.positions).unwrap(), s.up, w, h);
            let mut canvas = Canvas::new(w, h);
            group.bench_function(format!("frame/{name}/{w}x{h}"), |b| {
                b.iter(|| draw_frame(&mut canvas, &camera, &s, frame, Coloring::Plain))
            });
        }
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_secs(1))
        .without_plots();
    targets = render
}
criterion_main!(benches);
