use nalgebra::Vector3;
use softbench::material::*;
use softbench::mesh::TetMesh;
use softbench::model::*;
use softbench::parallel::Parallelism;
use std::time::Instant;
fn box_mesh(n: [usize; 3], size: [f64; 3]) -> TetMesh {
    let id = |i: usize, j: usize, k: usize| i + (n[0] + 1) * (j + (n[1] + 1) * k);
    let mut positions = Vec::new();
    for k in 0..=n[2] {
        for j in 0..=n[1] {
            for i in 0..=n[0] {
                positions.push(Vector3::new(
                    size[0] * i as f64 / n[0] as f64,
                    size[1] * j as f64 / n[1] as f64,
                    size[2] * k as f64 / n[2] as f64,
                ));
            }
        }
    }
    let mut mesh = TetMesh {
        positions,
        tets: Vec::new(),
    };
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                for perm in [
                    [0, 1, 2],
                    [0, 2, 1],
                    [1, 0, 2],
                    [1, 2, 0],
                    [2, 0, 1],
                    [2, 1, 0],
                ] {
                    let mut c = [i, j, k];
                    let mut tet = [id(c[0], c[1], c[2]), 0, 0, 0];
                    for (s, &axis) in perm.iter().enumerate() {
                        c[axis] += 1;
                        tet[s + 1] = id(c[0], c[1], c[2]);
                    }
                    mesh.tets.push(tet);
                    let t = mesh.tets.len() - 1;
                    if mesh.signed_volume6(t) < 0.0 {
                        mesh.tets[t].swap(2, 3);
                    }
                }
            }
        }
    }
    mesh
}
fn main() {
    let mesh = box_mesh([26, 26, 25], [1.0, 1.0, 1.0]);
    let nt = mesh.num_tets() as f64;
    let mat = MaterialModel::NeoHookean(NeoHookean::new(
        LameParameters::from_youngs_poisson(6e5, 0.4).unwrap(),
    ));
    for par in [Parallelism::Sequential, Parallelism::Rayon] {
        let mut spec = ModelSpec::elastic(mesh.clone(), mat, 1000.0);
        spec.parallelism = par;
        let t = Instant::now();
        let mut model = Model::new(spec).unwrap();
        println!("build {:?}", t.elapsed());
        let q: Vec<f64> = model
            .rest_state()
            .iter()
            .enumerate()
            .map(|(i, x)| x + 1e-4 * ((i * 7919 % 13) as f64))
            .collect();
        let mut g = vec![0.0; q.len()];
        let mut h = model.new_hessian();
        model
            .hessian(&q, &mut h, HessianOptions::default())
            .unwrap();
        for (name, f) in [("energy", 0), ("gradient", 1), ("hessian", 2)] {
            let mut times = vec![];
            for _ in 0..15 {
                let t = Instant::now();
                match f {
                    0 => {
                        model.potential(&q).unwrap();
                    }
                    1 => model.gradient(&q, &mut g).unwrap(),
                    _ => model
                        .hessian(&q, &mut h, HessianOptions::default())
                        .unwrap(),
                }
                times.push(t.elapsed().as_secs_f64());
            }
            times.sort_by(|a, b| a.partial_cmp(b).unwrap());
            println!(
                "{par:?} {name}: median {:.2} ms = {:.2} M tets/s",
                times[7] * 1e3,
                nt / times[7] / 1e6
            );
        }
    }
    let _ = Vector3::<f64>::zeros();
}
