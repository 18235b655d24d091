//! Claims about Newton's Hessian filters (`integrator.newton.filter`): every filter makes
//! element matrices positive semi-definite and leaves PSD ones as they are; unfiltered Newton
//! is invariant under a change of coordinates and the eigenvalue filters are not; every
//! filter converges to the same backward-Euler step as unfiltered Newton on an indefinite
//! case; every registered filter runs a scene (and linearly-implicit Euler uses it); bad
//! input is refused with the key and the valid names.

mod common;

use common::{TempDir, simulate};
use nalgebra::{DMatrix, DVector, SMatrix, Vector3};
use softbench::fem::{ElementFilter, FilterSpace};
use softbench::integrate::newton::{Newton, NewtonSettings, Problem};
use softbench::integrate::{FilterSettings, HessianFilter, State, StepReport};
use softbench::material::{LameParameters, MaterialKind, MaterialModel};
use softbench::mesh::TetMesh;
use softbench::model::{HessianOptions, Model, ModelSpec};
use softbench::rng::Rng;
use softbench::solve::{LinearSolverKind, SolverSettings};

type Matrix12 = SMatrix<f64, 12, 12>;

fn material(name: &str) -> MaterialModel {
    let lame = LameParameters::from_youngs_poisson(1e4, 0.45).unwrap();
    MaterialModel::from_name(name, lame).unwrap()
}

/// One tet (rest: the unit corner tet scaled by 0.1), no fixed vertices.
fn one_tet(material: MaterialModel) -> Model {
    let positions = vec![
        Vector3::zeros(),
        Vector3::new(0.1, 0.0, 0.0),
        Vector3::new(0.0, 0.1, 0.0),
        Vector3::new(0.0, 0.0, 0.1),
    ];
    let mesh = TetMesh {
        positions,
        tets: vec![[0, 1, 2, 3]],
    };
    Model::new(ModelSpec::elastic(mesh, material, 1000.0)).unwrap()
}

/// Positions of the tet deformed by `f` (x = F X).
fn deformed(f: &nalgebra::Matrix3<f64>) -> Vec<f64> {
    let rest = [
        Vector3::zeros(),
        Vector3::new(0.1, 0.0, 0.0),
        Vector3::new(0.0, 0.1, 0.0),
        Vector3::new(0.0, 0.0, 0.1),
    ];
    rest.iter()
        .flat_map(|x| (f * x).iter().copied().collect::<Vec<_>>())
        .collect()
}

/// The element matrix at `q` through `options`, dense, and how many elements were filtered.
fn element_matrix(model: &mut Model, q: &[f64], options: HessianOptions) -> (Matrix12, usize) {
    let mut h = model.new_hessian();
    model.hessian(q, &mut h, options).unwrap();
    let d = h.to_dense();
    (
        Matrix12::from_fn(|r, c| d[(r, c)]),
        model.filtered_elements(),
    )
}

fn eigenvalues(m: &Matrix12) -> (f64, f64) {
    let e = m.symmetric_eigenvalues();
    (e.min(), e.amax())
}

/// Every filter setting to check: each registered filter in both spaces, ε = 0 and ε > 0,
/// and for `progressive` several iterations.
fn settings() -> Vec<(FilterSettings, u32)> {
    let mut out = Vec::new();
    for &filter in HessianFilter::ALL {
        for &space in FilterSpace::ALL {
            for epsilon in [0.0, 10.0] {
                let ks: &[u32] = if filter == HessianFilter::Progressive {
                    &[0, 1, 3]
                } else {
                    &[0]
                };
                for &k in ks {
                    out.push((
                        FilterSettings {
                            filter,
                            epsilon,
                            space,
                        },
                        k,
                    ));
                }
            }
        }
    }
    out
}

/// The matrix a filter setting gives the Newton system at iteration `k`: the first filter if
/// it is PSD by construction, else (none, on-demand) the fallback's; for on-demand also the
/// next assembly at the same point, which must use what the fallback flagged.
fn filtered(model: &mut Model, q: &[f64], s: &FilterSettings, k: u32) -> Vec<(Matrix12, usize)> {
    match s.fallback() {
        None => vec![element_matrix(
            model,
            q,
            HessianOptions::filtered(s.first(k).unwrap()),
        )],
        Some(fallback) => {
            let mut out = vec![element_matrix(model, q, HessianOptions::filtered(fallback))];
            if let Some(first) = s.first(k) {
                out.push(element_matrix(model, q, HessianOptions::filtered(first)));
            }
            out
        }
    }
}

#[test]
fn every_filter_makes_element_hessians_psd_and_leaves_psd_ones_alone() {
    let mut rng = Rng::new(26);
    let mut indefinite = 0;
    let mut psd_checked = 0;
    let mut bitwise = 0;
    for &kind in MaterialKind::ALL {
        let mat = material(kind.name());
        let mut model = one_tet(mat);
        for sample in 0..40 {
            // Half far from rest (inverted ones included where the material allows), half
            // near it, where element Hessians are mostly PSD.
            let spread = if sample % 2 == 0 { 1.2 } else { 0.08 };
            let mut f = nalgebra::Matrix3::identity()
                + nalgebra::Matrix3::from_fn(|_, _| rng.range(-spread, spread));
            if !mat.handles_inversion() && f.determinant() <= 0.05 {
                f.column_mut(0).scale_mut(-1.0);
                if f.determinant() <= 0.05 {
                    continue;
                }
            }
            let q = deformed(&f);
            let (exact, _) = element_matrix(&mut model, &q, HessianOptions::default());
            let (min, max_abs) = eigenvalues(&exact);
            let exact_psd = min >= -1e-12 * max_abs;
            indefinite += usize::from(min < -1e-6 * max_abs);
            for (s, k) in settings() {
                for (m, count) in filtered(&mut model, &q, &s, k) {
                    let (fmin, fmax) = eigenvalues(&m);
                    assert!(
                        fmin >= -1e-10 * fmax,
                        "{kind} {s:?} k={k}: not PSD, eigenvalues down to {fmin:.3e} \
                         (max {fmax:.3e}), exact min {min:.3e}"
                    );
                    if s.space == FilterSpace::Element && (s.epsilon > 0.0 || !exact_psd) {
                        // The 12×12 is what the filter decomposed: its floor holds exactly.
                        let floor = if s.filter == HessianFilter::OnDemand && exact_psd {
                            0.0
                        } else {
                            s.epsilon
                        };
                        assert!(
                            fmin >= floor - 1e-9 * fmax,
                            "{kind} {s:?}: eigenvalue {fmin:.3e} below epsilon"
                        );
                    }
                    if exact_psd && s.epsilon == 0.0 {
                        psd_checked += 1;
                        let diff = (m - exact).norm();
                        assert!(
                            diff <= 1e-12 * exact.norm(),
                            "{kind} {s:?}: a PSD element changed by {diff:.3e}"
                        );
                        if m == exact {
                            bitwise += 1;
                            assert_eq!(count, 0, "{kind} {s:?}: unchanged but counted");
                        }
                    }
                    if !exact_psd && min < -1e-6 * max_abs {
                        assert_eq!(count, 1, "{kind} {s:?}: an indefinite element not counted");
                    }
                }
            }
        }
    }
    eprintln!(
        "indefinite samples {indefinite}, PSD checks {psd_checked} ({bitwise} bitwise identical)"
    );
    assert!(indefinite >= 40, "too few indefinite samples: {indefinite}");
    assert!(psd_checked >= 200, "too few PSD samples: {psd_checked}");
}

#[test]
fn on_demand_keeps_clamping_what_the_fallback_flagged_until_it_is_psd() {
    let mut model = one_tet(material("stable-neo-hookean"));
    let s = FilterSettings {
        filter: HessianFilter::OnDemand,
        ..Default::default()
    };
    let squashed = deformed(&nalgebra::Matrix3::from_diagonal(&Vector3::new(
        0.3, 1.0, 1.0,
    )));
    let (exact, _) = element_matrix(&mut model, &squashed, HessianOptions::default());
    assert!(
        eigenvalues(&exact).0 < 0.0,
        "the squashed tet must be indefinite"
    );
    // Before any fallback nothing is flagged: the exact matrix.
    let first = HessianOptions::filtered(s.first(0).unwrap());
    let (m, n) = element_matrix(&mut model, &squashed, first);
    assert_eq!((m, n), (exact, 0));
    // The fallback clamps and flags it; the next assemblies clamp it without a fallback.
    let (clamped, n) = element_matrix(
        &mut model,
        &squashed,
        HessianOptions::filtered(s.fallback().unwrap()),
    );
    assert_eq!(n, 1);
    assert_eq!(element_matrix(&mut model, &squashed, first), (clamped, 1));
    // At rest it is PSD: unflagged, and exact from then on even when squashed again.
    let rest = deformed(&nalgebra::Matrix3::identity());
    element_matrix(&mut model, &rest, first);
    assert_eq!(element_matrix(&mut model, &squashed, first), (exact, 0));
}

/// `‖T dy − dx‖ / ‖dx‖` for the filtered Newton step of one element with mass `m I`:
/// `dx = −(Φ(H) + m I)⁻¹ g` in x, `dy` the same in the coordinates `x = T y`, where the
/// element matrix is `Tᵀ H T`, the mass `m T²` and the gradient `T g`.
fn covariance_error(
    h: &Matrix12,
    g: &[f64; 12],
    t: &[f64; 12],
    m: f64,
    f: Option<&ElementFilter>,
) -> f64 {
    let filter = |a: &Matrix12| {
        let mut a = *a;
        if let Some(f) = f {
            f.apply(&mut a);
        }
        a
    };
    let tm = Matrix12::from_diagonal(&SMatrix::<f64, 12, 1>::from_row_slice(t));
    let gx = DVector::from_row_slice(g);
    let ax = filter(h) + Matrix12::identity() * m;
    let dx = -DMatrix::from_fn(12, 12, |r, c| ax[(r, c)])
        .lu()
        .solve(&gx)
        .unwrap();
    let hy = tm.transpose() * h * tm;
    let ay = filter(&hy) + tm.transpose() * tm * m;
    let gy = DVector::from_fn(12, |i, _| t[i] * g[i]);
    let dy = -DMatrix::from_fn(12, 12, |r, c| ay[(r, c)])
        .lu()
        .solve(&gy)
        .unwrap();
    let back = DVector::from_fn(12, |i, _| t[i] * dy[i]);
    (back - &dx).norm() / dx.norm()
}

#[test]
fn unfiltered_newton_is_invariant_under_a_change_of_coordinates_and_filters_are_not() {
    let mut model = one_tet(material("stable-neo-hookean"));
    // Squashed and sheared: an indefinite element Hessian.
    let f = nalgebra::Matrix3::new(0.35, 0.4, 0.0, 0.0, 1.0, 0.3, 0.0, 0.0, 1.1);
    let (h, _) = element_matrix(&mut model, &deformed(&f), HessianOptions::default());
    let (min, max_abs) = eigenvalues(&h);
    assert!(
        min < -1e-3 * max_abs,
        "not indefinite: {min:.3e} / {max_abs:.3e}"
    );
    let mut rng = Rng::new(7);
    let g: [f64; 12] = std::array::from_fn(|_| rng.range(-1.0, 1.0));
    // An anisotropic rescaling of the coordinates (a uniform one commutes with every filter).
    let t: [f64; 12] = std::array::from_fn(|_| 10f64.powf(rng.range(-1.0, 1.0)));
    // A mass large enough that H + m I is positive definite, so the unfiltered step exists.
    let m = 2.0 * min.abs();
    let exact = covariance_error(&h, &g, &t, m, None);
    eprintln!("affine covariance error: none {exact:.2e}");
    assert!(
        exact < 1e-10,
        "unfiltered Newton is not covariant: {exact:.3e}"
    );
    for &filter in HessianFilter::ALL {
        let s = FilterSettings {
            filter,
            ..Default::default()
        };
        let e = covariance_error(&h, &g, &t, m, Some(&s.psd(0)));
        eprintln!("affine covariance error: {filter} (its PSD element filter) {e:.2e}");
        // Every filter decomposes H, so every one breaks covariance on an indefinite element.
        assert!(e > 1e-3, "{filter} kept covariance: {e:.3e}");
    }
}

/// A free box squashed to 40% along x and twisted by 60° about it: elements with negative
/// eigenvalues, and a backward-Euler step long enough that M + dt² K is indefinite.
fn twisted_box(model_name: &str) -> (Model, State) {
    let mesh = softbench::mesh::generate::box_mesh([4, 2, 2], [0.4, 0.1, 0.1]);
    let mut model = Model::new(ModelSpec::elastic(mesh, material(model_name), 1000.0)).unwrap();
    let mut state = State::at_rest(&model);
    for p in state.q.chunks_exact_mut(3) {
        let angle = (p[0] / 0.4) * std::f64::consts::FRAC_PI_3;
        let (y, z) = (p[1] - 0.05, p[2] - 0.05);
        p[0] *= 0.4;
        p[1] = 0.05 + y * angle.cos() - z * angle.sin();
        p[2] = 0.05 + y * angle.sin() + z * angle.cos();
    }
    // Some element is indefinite at the start.
    let mut h = model.new_hessian();
    let probe = FilterSettings {
        filter: HessianFilter::OnDemand,
        ..Default::default()
    };
    model
        .hessian(
            &state.q,
            &mut h,
            HessianOptions::filtered(probe.fallback().unwrap()),
        )
        .unwrap();
    assert!(
        model.filtered_elements() > 0,
        "no element with a negative eigenvalue"
    );
    (model, state)
}

/// One converged backward-Euler step of `dt` from `state` with `settings`.
fn solve_step(
    model: &mut Model,
    state: &State,
    dt: f64,
    settings: NewtonSettings,
) -> (Vec<f64>, StepReport) {
    let x_hat: Vec<f64> = state
        .q
        .iter()
        .zip(&state.v)
        .map(|(q, v)| q + dt * v)
        .collect();
    let mut newton = Newton::new(
        LinearSolverKind::from_name("cholesky")
            .unwrap()
            .build(&SolverSettings::default()),
        settings,
    );
    let mut x = x_hat.clone();
    let mut report = StepReport::default();
    newton
        .minimize(
            model,
            &Problem {
                x_hat: &x_hat,
                x_ref: &state.q,
                beta: dt * dt,
                damping_anchor: &state.q,
                ..Default::default()
            },
            &mut x,
            &mut report,
        )
        .unwrap();
    assert!(newton.trace().converged, "{settings:?}: not converged");
    (x, report)
}

#[test]
fn every_filter_converges_to_the_unfiltered_step_on_an_indefinite_case() {
    let dt = 0.05;
    let tight = |filter, space| NewtonSettings {
        filter,
        filter_space: space,
        tolerance: 1e-11,
        max_iterations: 200,
        max_backtracks: 60,
        require_convergence: true,
        ..Default::default()
    };
    let (mut model, state) = twisted_box("stable-neo-hookean");
    let (reference, report) = solve_step(
        &mut model,
        &state,
        dt,
        tight(HessianFilter::None, FilterSpace::Element),
    );
    eprintln!(
        "none: {} iterations, {} fallbacks, {} projected elements",
        report.newton_iterations, report.indefinite_fallbacks, report.projected_elements
    );
    assert!(
        report.indefinite_fallbacks > 0,
        "the case is not indefinite"
    );
    let moved = common::bodies::distance(&reference, &state.q);
    for &filter in HessianFilter::ALL {
        for &space in FilterSpace::ALL {
            let (x, report) = solve_step(&mut model, &state, dt, tight(filter, space));
            let diff = common::bodies::distance(&x, &reference);
            eprintln!(
                "{filter} ({space}): {} iterations, {} fallbacks, {} projected elements, \
                 |x - x_none| / |x_none - q| = {:.2e}",
                report.newton_iterations,
                report.indefinite_fallbacks,
                report.projected_elements,
                diff / moved
            );
            assert!(
                diff <= 1e-5 * moved,
                "{filter} ({space}) ends {diff:.3e} from the unfiltered step (moved {moved:.3e})"
            );
            if filter != HessianFilter::None {
                assert!(
                    report.projected_elements > 0,
                    "{filter} ({space}) filtered nothing"
                );
            }
        }
    }
}

const SCENE: &str = r#"
[mesh]
generate = { box = [3, 1, 1], size = [0.3, 0.1, 0.1] }

[material]
model = "stable-neo-hookean"
youngs_modulus = 1e4
poisson_ratio = 0.45
density = 1000.0

[fixed]
rule = { axis = "x", side = "min", tolerance = 1e-6 }

[forces]
gravity = [0.0, -9.81, 0.0]

[integrator]
method = "backward-euler"

[run]
dt = 0.02
steps = 3
"#;

fn summary(dir: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

#[test]
fn every_registered_filter_runs_a_scene_and_counts_what_it_filtered() {
    let dir = TempDir::new("hessian-filters");
    let scene = dir.write("scene.toml", SCENE);
    for method in ["backward-euler", "linearly-implicit-euler"] {
        for &filter in HessianFilter::ALL {
            for &space in FilterSpace::ALL {
                let out = dir.path().join(format!("{method}-{filter}-{space}"));
                let sets = [
                    format!("integrator.method={method}"),
                    format!("integrator.newton.filter={filter}"),
                    format!("integrator.newton.filter_space={space}"),
                    // ε > 0 changes every element (ε floors eigenvalues that are smaller):
                    // a count that proves the filter ran, even on PSD elements.
                    "integrator.newton.filter_epsilon=1".to_string(),
                ];
                let mut args = Vec::new();
                for s in &sets {
                    args.extend(["--set", s.as_str()]);
                }
                let result = simulate(&scene, &out, &args);
                assert!(
                    result.status.success(),
                    "{method} {filter} {space}: {}",
                    String::from_utf8_lossy(&result.stderr)
                );
                let s = summary(&out);
                let projected = s["summary"]["totals"]["projected_elements"]
                    .as_u64()
                    .unwrap();
                let header = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
                assert!(
                    header
                        .lines()
                        .next()
                        .unwrap()
                        .ends_with(",projected_elements"),
                    "trajectory.csv has no projected_elements column"
                );
                // none and on-demand filter only when the system is indefinite.
                let fallbacks = s["summary"]["totals"]["indefinite_fallbacks"]
                    .as_u64()
                    .unwrap();
                if !matches!(filter, HessianFilter::None | HessianFilter::OnDemand) {
                    assert!(projected > 0, "{method} {filter} {space}: nothing filtered");
                } else if fallbacks == 0 {
                    assert_eq!(
                        projected, 0,
                        "{method} {filter} {space}: filtered a PD system"
                    );
                }
            }
        }
    }
}

#[test]
fn project_hessian_is_the_clamp_filter() {
    let dir = TempDir::new("hessian-filters-alias");
    let scene = dir.write("scene.toml", SCENE);
    let run = |name: &str, set: &str| {
        let out = dir.path().join(name);
        let result = simulate(
            &scene,
            &out,
            &["--set", set, "--set", "integrator.newton.filter_epsilon=1"],
        );
        assert!(
            result.status.success(),
            "{}",
            String::from_utf8_lossy(&result.stderr)
        );
        let s = summary(&out);
        (
            s["summary"]["totals"]["projected_elements"]
                .as_u64()
                .unwrap(),
            std::fs::read_to_string(out.join("final_positions.csv")).unwrap(),
        )
    };
    let alias = run("alias", "integrator.newton.project_hessian=true");
    let clamp = run("clamp", "integrator.newton.filter=clamp");
    assert!(alias.0 > 0);
    assert_eq!(alias, clamp);
}

#[test]
fn bad_filter_input_is_refused_with_the_key_and_the_valid_names() {
    let dir = TempDir::new("hessian-filters-bad");
    let scene = dir.write("scene.toml", SCENE);
    let refuse = |sets: &[&str], expect: &[&str]| {
        let out = dir.path().join("out");
        let mut args = Vec::new();
        for s in sets {
            args.extend(["--set", *s]);
        }
        let result = simulate(&scene, &out, &args);
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(2), "{sets:?}: {stderr}");
        for e in expect {
            assert!(stderr.contains(e), "{sets:?}: `{e}` missing from: {stderr}");
        }
        assert!(!out.join("summary.json").exists());
    };
    refuse(
        &["integrator.newton.filter=clmap"],
        &[
            "filter",
            "clmap",
            "none, clamp, abs, on-demand, progressive",
        ],
    );
    refuse(
        &["integrator.newton.filter_space=strain"],
        &["filter space", "strain", "element, stress"],
    );
    for bad in ["-1", "nan", "inf"] {
        refuse(
            &[&format!("integrator.newton.filter_epsilon={bad}")],
            &["newton.filter_epsilon", "finite and >= 0"],
        );
    }
    refuse(
        &[
            "integrator.newton.project_hessian=true",
            "integrator.newton.filter=abs",
        ],
        &["newton.project_hessian", "newton.filter", "abs"],
    );
}

#[test]
fn stable_neo_hookean_closed_form_eigensystem_matches_the_numerical_one() {
    use softbench::material::{Material, Matrix9, StVenantKirchhoff, StableNeoHookean};
    let lame = LameParameters::from_youngs_poisson(1e4, 0.45).unwrap();
    let snh = StableNeoHookean::new(lame);
    let mut rng = Rng::new(9);
    let mut negative = 0;
    for sample in 0..200 {
        let spread = [0.05, 0.5, 1.5][sample % 3];
        let f = nalgebra::Matrix3::identity()
            + nalgebra::Matrix3::from_fn(|_, _| rng.range(-spread, spread));
        let d = snh.first_piola_derivative(&f).unwrap();
        let (values, vectors) = snh.stress_eigensystem(&f).expect("a closed form");
        let scale = d.norm();
        // Orthonormal eigenvectors that rebuild dP/dF ...
        let orthogonality = (vectors.transpose() * vectors - Matrix9::identity()).norm();
        assert!(
            orthogonality < 1e-12,
            "F = {f}: QᵀQ − I = {orthogonality:.3e}"
        );
        let rebuilt = vectors * Matrix9::from_diagonal(&values) * vectors.transpose();
        assert!(
            (rebuilt - d).norm() <= 1e-12 * scale,
            "F = {f}: Q Λ Qᵀ differs from dP/dF by {:.3e} (|D| = {scale:.3e})",
            (rebuilt - d).norm()
        );
        // ... with the eigenvalues of the numerical decomposition.
        let mut closed: Vec<f64> = values.iter().copied().collect();
        let mut numerical: Vec<f64> = d.symmetric_eigenvalues().iter().copied().collect();
        closed.sort_by(f64::total_cmp);
        numerical.sort_by(f64::total_cmp);
        for (a, b) in closed.iter().zip(&numerical) {
            assert!(
                (a - b).abs() <= 1e-12 * scale,
                "F = {f}: {closed:?} vs {numerical:?}"
            );
        }
        negative += usize::from(closed[0] < 0.0);
        // The stress-space filter through the closed form equals the one through the
        // numerical decomposition.
        let filter = ElementFilter {
            space: FilterSpace::Stress,
            ..ElementFilter::CLAMP
        };
        let (mut closed_form, mut numeric) = (d, d);
        let changed = filter.apply_eigensystem(&values, &vectors, &mut closed_form);
        assert_eq!(changed, filter.apply(&mut numeric), "F = {f}");
        assert!((closed_form - numeric).norm() <= 1e-10 * scale, "F = {f}");
    }
    assert!(negative >= 20, "too few indefinite samples: {negative}");
    // Materials without a closed form say so (their filters decompose numerically).
    let stvk = StVenantKirchhoff::new(lame);
    assert!(
        stvk.stress_eigensystem(&nalgebra::Matrix3::identity())
            .is_none()
    );
}
