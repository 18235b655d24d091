//! Claims about the material models: closed-form derivatives agree with finite differences,
//! rest is stress-free, energies are frame-indifferent and isotropic, every model linearizes to
//! its Lamé constants, and the inversion behaviour is what each model's docs promise.

use nalgebra::{Matrix3, Quaternion, SVector, UnitQuaternion, Vector3};
use softbench::material::{
    Corotated, LameParameters, Material, MaterialError, MaterialModel, Matrix9, NeoHookean,
    RotationVariantSvd, StVenantKirchhoff, StableNeoHookean, vec9,
};
use softbench::rng::Rng;

/// Largest accepted ‖FD − analytic‖ / max(‖analytic‖, scale).
const FD_TOLERANCE: f64 = 1e-6;
/// Central-difference step; F entries are O(1), so this is a relative step of about 1e-6.
const FD_STEP: f64 = 1e-6;

/// Lamé sets the claims are checked for: ordinary, nearly incompressible, and lambda = 0.
fn lame_sets() -> Vec<LameParameters> {
    vec![
        LameParameters::from_youngs_poisson(1e5, 0.3).unwrap(),
        LameParameters::from_youngs_poisson(1e5, 0.48).unwrap(),
        LameParameters::new(4e4, 0.0).unwrap(),
    ]
}

/// Every model for every Lamé set.
fn all_models() -> Vec<(MaterialModel, LameParameters)> {
    lame_sets()
        .into_iter()
        .flat_map(|lame| {
            MaterialModel::NAMES
                .iter()
                .map(move |name| (MaterialModel::from_name(name, lame).unwrap(), lame))
        })
        .collect()
}

fn random_rotation(rng: &mut Rng) -> Matrix3<f64> {
    loop {
        let q = Quaternion::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        if q.norm() > 0.1 && q.norm() < 1.0 {
            return UnitQuaternion::from_quaternion(q)
                .to_rotation_matrix()
                .into_inner();
        }
    }
}

/// I plus a uniform perturbation of each entry in [-0.3, 0.3), with det F > 0.2.
fn perturbed_identity(rng: &mut Rng) -> Matrix3<f64> {
    loop {
        let f = Matrix3::identity() + Matrix3::from_fn(|_, _| rng.range(-0.3, 0.3));
        if f.determinant() > 0.2 {
            return f;
        }
    }
}

/// U diag(sigma) Vᵀ with random rotations U and V.
fn with_singular_values(rng: &mut Rng, sigma: Vector3<f64>) -> Matrix3<f64> {
    random_rotation(rng) * Matrix3::from_diagonal(&sigma) * random_rotation(rng).transpose()
}

/// Inverted: one negative singular value in [-0.4, -0.1), the others in [0.6, 1.5), so every
/// σ_i + σ_j is at least 0.2 away from zero.
fn inverted(rng: &mut Rng) -> Matrix3<f64> {
    let sigma = Vector3::new(
        rng.range(0.6, 1.5),
        rng.range(0.6, 1.5),
        -rng.range(0.1, 0.4),
    );
    with_singular_values(rng, sigma)
}

/// Near-singular: one singular value of either sign with magnitude in [1e-5, 1e-3), the others
/// in [0.6, 1.5).
fn near_singular(rng: &mut Rng) -> Matrix3<f64> {
    let sign = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
    let sigma = Vector3::new(
        rng.range(0.6, 1.5),
        rng.range(0.6, 1.5),
        sign * rng.range(1e-5, 1e-3),
    );
    with_singular_values(rng, sigma)
}

/// The sample deformations for a model: 200 with det F > 0, plus 100 inverted and 100
/// near-singular ones if the model handles inversion.
fn samples(model: &MaterialModel, seed: u64) -> Vec<Matrix3<f64>> {
    let mut rng = Rng::new(seed);
    let mut fs: Vec<_> = (0..200).map(|_| perturbed_identity(&mut rng)).collect();
    if model.handles_inversion() {
        fs.extend((0..100).map(|_| inverted(&mut rng)));
        fs.extend((0..100).map(|_| near_singular(&mut rng)));
    }
    fs
}

fn unit(k: usize, l: usize) -> Matrix3<f64> {
    let mut e = Matrix3::zeros();
    e[(k, l)] = 1.0;
    e
}

fn fd_first_piola(model: &MaterialModel, f: &Matrix3<f64>) -> Matrix3<f64> {
    Matrix3::from_fn(|k, l| {
        let e = unit(k, l) * FD_STEP;
        let plus = model.energy_density(&(f + e)).unwrap();
        let minus = model.energy_density(&(f - e)).unwrap();
        (plus - minus) / (2.0 * FD_STEP)
    })
}

fn fd_first_piola_derivative(model: &MaterialModel, f: &Matrix3<f64>) -> Matrix9 {
    let mut d = Matrix9::zeros();
    for l in 0..3 {
        for k in 0..3 {
            let e = unit(k, l) * FD_STEP;
            let plus = model.first_piola(&(f + e)).unwrap();
            let minus = model.first_piola(&(f - e)).unwrap();
            d.set_column(k + 3 * l, &vec9(&((plus - minus) / (2.0 * FD_STEP))));
        }
    }
    d
}

/// The physical stiffness scale mu + lambda, the floor of the relative-error denominator.
fn scale(lame: &LameParameters) -> f64 {
    lame.mu + lame.lambda
}

/// The linear elasticity tensor mu (δ_ik δ_jl + δ_il δ_jk) + lambda δ_ij δ_kl over vec(F).
fn linear_elasticity_tensor(lame: &LameParameters) -> Matrix9 {
    Matrix9::from_fn(|row, col| {
        let (i, j, k, l) = (row % 3, row / 3, col % 3, col / 3);
        let d = |a: usize, b: usize| if a == b { 1.0 } else { 0.0 };
        lame.mu * (d(i, k) * d(j, l) + d(i, l) * d(j, k)) + lame.lambda * d(i, j) * d(k, l)
    })
}

fn assert_stress_matches_finite_differences(name: &str) {
    let mut worst: f64 = 0.0;
    for (seed, (model, lame)) in all_models().into_iter().enumerate() {
        if model.name() != name {
            continue;
        }
        for f in samples(&model, seed as u64) {
            let p = model.first_piola(&f).unwrap();
            let err = (fd_first_piola(&model, &f) - p).norm() / p.norm().max(scale(&lame));
            assert!(err <= FD_TOLERANCE, "{name}: error {err:e} at F = {f}");
            worst = worst.max(err);
        }
    }
    println!("{name}: worst relative error of P against FD of psi: {worst:e}");
}

fn assert_stress_derivative_matches_finite_differences(name: &str) {
    let mut worst: f64 = 0.0;
    for (seed, (model, lame)) in all_models().into_iter().enumerate() {
        if model.name() != name {
            continue;
        }
        for f in samples(&model, 100 + seed as u64) {
            let d = model.first_piola_derivative(&f).unwrap();
            let err =
                (fd_first_piola_derivative(&model, &f) - d).norm() / d.norm().max(scale(&lame));
            assert!(err <= FD_TOLERANCE, "{name}: error {err:e} at F = {f}");
            worst = worst.max(err);
        }
    }
    println!("{name}: worst relative error of dP/dF against FD of P: {worst:e}");
}

#[test]
fn neo_hookean_stress_matches_finite_differences() {
    assert_stress_matches_finite_differences("neo-hookean");
}

#[test]
fn neo_hookean_stress_derivative_matches_finite_differences() {
    assert_stress_derivative_matches_finite_differences("neo-hookean");
}

#[test]
fn stable_neo_hookean_stress_matches_finite_differences_including_inverted() {
    assert_stress_matches_finite_differences("stable-neo-hookean");
}

#[test]
fn stable_neo_hookean_stress_derivative_matches_finite_differences_including_inverted() {
    assert_stress_derivative_matches_finite_differences("stable-neo-hookean");
}

#[test]
fn stvk_stress_matches_finite_differences_including_inverted() {
    assert_stress_matches_finite_differences("stvk");
}

#[test]
fn stvk_stress_derivative_matches_finite_differences_including_inverted() {
    assert_stress_derivative_matches_finite_differences("stvk");
}

#[test]
fn corotated_stress_matches_finite_differences_including_inverted() {
    assert_stress_matches_finite_differences("corotated");
}

#[test]
fn corotated_stress_derivative_matches_finite_differences_including_inverted() {
    assert_stress_derivative_matches_finite_differences("corotated");
}

#[test]
fn every_model_has_zero_energy_and_zero_stress_at_rest() {
    let rest = Matrix3::identity();
    for (model, lame) in all_models() {
        let psi = model.energy_density(&rest).unwrap();
        let p = model.first_piola(&rest).unwrap();
        assert!(
            psi.abs() <= 1e-12 * scale(&lame),
            "{}: psi(I) = {psi:e}",
            model.name()
        );
        assert!(
            p.norm() <= 1e-12 * scale(&lame),
            "{}: P(I) = {p}",
            model.name()
        );
    }
}

/// The per-vertex terms VBD uses (closed forms where a material has one) equal `P n` and the
/// full derivative contracted with `n ⊗ n`.
#[test]
fn every_vertex_term_matches_the_contracted_stress_and_derivative() {
    let mut rng = Rng::new(77);
    for (seed, (model, lame)) in all_models().into_iter().enumerate() {
        for f in samples(&model, 300 + seed as u64) {
            let n = Vector3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 2.0
                - Vector3::repeat(1.0);
            let (pn, h) = model.vertex_terms(&f, &n).unwrap();
            let p = model.first_piola(&f).unwrap();
            let d = model.first_piola_derivative(&f).unwrap();
            // H[r, s] = Σ_{c,d} n_c n_d D[3c + r, 3d + s] (column-major vec(F)).
            let block = Matrix3::from_fn(|r, s| {
                (0..3)
                    .flat_map(|c| (0..3).map(move |e| (c, e)))
                    .map(|(c, e)| n[c] * n[e] * d[(3 * c + r, 3 * e + s)])
                    .sum::<f64>()
            });
            let size = scale(&lame) * n.norm_squared();
            assert!(
                (pn - p * n).norm() <= 1e-12 * (p.norm() * n.norm()).max(size),
                "{}: P n",
                model.name()
            );
            assert!(
                (h - block).norm() <= 1e-11 * block.norm().max(size),
                "{}: vertex block {h} vs {block}",
                model.name()
            );
        }
    }
}

#[test]
fn every_stress_derivative_is_symmetric() {
    for (seed, (model, lame)) in all_models().into_iter().enumerate() {
        for f in samples(&model, 200 + seed as u64) {
            let d = model.first_piola_derivative(&f).unwrap();
            let asymmetry = (d - d.transpose()).norm() / d.norm().max(scale(&lame));
            assert!(
                asymmetry <= 1e-12,
                "{}: asymmetry {asymmetry:e}",
                model.name()
            );
        }
    }
}

#[test]
fn every_energy_is_invariant_under_rotating_the_deformed_shape() {
    let mut rng = Rng::new(7);
    for (seed, (model, _)) in all_models().into_iter().enumerate() {
        for f in samples(&model, 300 + seed as u64) {
            let q = random_rotation(&mut rng);
            let psi = model.energy_density(&f).unwrap();
            let rotated = model.energy_density(&(q * f)).unwrap();
            let err = (rotated - psi).abs() / psi.abs().max(1e-300);
            assert!(err <= 1e-10, "{}: psi(QF) off by {err:e}", model.name());
        }
    }
}

#[test]
fn every_energy_is_isotropic_under_rotating_the_rest_shape() {
    let mut rng = Rng::new(8);
    for (seed, (model, _)) in all_models().into_iter().enumerate() {
        for f in samples(&model, 400 + seed as u64) {
            let q = random_rotation(&mut rng);
            let psi = model.energy_density(&f).unwrap();
            let rotated = model.energy_density(&(f * q)).unwrap();
            let err = (rotated - psi).abs() / psi.abs().max(1e-300);
            assert!(err <= 1e-10, "{}: psi(FQ) off by {err:e}", model.name());
        }
    }
}

#[test]
fn every_model_linearizes_to_its_lame_parameters() {
    for (model, lame) in all_models() {
        let d = model.first_piola_derivative(&Matrix3::identity()).unwrap();
        // The course Neo-Hookean (C = mu/2, D = lambda/2) linearizes to lambda - 2/3 mu; every
        // other model to its own Lamé constants.
        let expected = match model {
            MaterialModel::NeoHookean(_) => LameParameters {
                mu: lame.mu,
                lambda: lame.lambda - 2.0 / 3.0 * lame.mu,
            },
            _ => lame,
        };
        let c = linear_elasticity_tensor(&expected);
        let err = (d - c).norm() / c.norm();
        assert!(
            err <= 1e-12,
            "{} with {lame:?}: dP/dF(I) is off the linear elasticity tensor by {err:e}",
            model.name()
        );
    }
}

#[test]
fn neo_hookean_with_matched_linearization_linearizes_to_its_lame_parameters() {
    for lame in lame_sets() {
        let nh = NeoHookean::with_matched_linearization(lame);
        let d = nh.first_piola_derivative(&Matrix3::identity()).unwrap();
        let c = linear_elasticity_tensor(&lame);
        let err = (d - c).norm() / c.norm();
        assert!(err <= 1e-12, "{lame:?}: off by {err:e}");
    }
}

fn assert_all_finite(model: &impl Material, f: &Matrix3<f64>) {
    let psi = model.energy_density(f).unwrap();
    let p = model.first_piola(f).unwrap();
    let d = model.first_piola_derivative(f).unwrap();
    assert!(psi.is_finite(), "psi({f}) = {psi}");
    assert!(p.iter().all(|x| x.is_finite()), "P({f}) = {p}");
    assert!(d.iter().all(|x| x.is_finite()), "dP/dF({f}) = {d}");
}

/// Reflected, collapsed to a plane, to a line, to a point, and random inverted deformations.
fn through_inversion() -> Vec<Matrix3<f64>> {
    let mut rng = Rng::new(9);
    let mut fs = vec![
        Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0)),
        Matrix3::from_diagonal(&Vector3::new(-1.0, -1.0, -1.0)),
        Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 0.0)),
        Matrix3::from_diagonal(&Vector3::new(1.0, 0.0, 0.0)),
        Matrix3::zeros(),
        with_singular_values(&mut rng, Vector3::new(1.3, 0.7, 0.0)),
    ];
    fs.extend((0..50).map(|_| inverted(&mut rng)));
    fs.extend((0..50).map(|_| -perturbed_identity(&mut rng)));
    fs
}

#[test]
fn stable_neo_hookean_is_finite_through_inversion() {
    for lame in lame_sets() {
        let snh = StableNeoHookean::new(lame);
        for f in through_inversion() {
            assert_all_finite(&snh, &f);
        }
    }
}

#[test]
fn stable_neo_hookean_resists_inversion() {
    // At F = diag(1, 1, -1) the stress pushes the third axis back toward J > 0.
    let snh = StableNeoHookean::new(lame_sets()[0]);
    let f = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0));
    let p = snh.first_piola(&f).unwrap();
    assert!(
        p[(2, 2)] < 0.0,
        "P_33 = {} does not push toward J > 0",
        p[(2, 2)]
    );
}

#[test]
fn stable_neo_hookean_with_zero_lambda_is_rest_stable_and_finite() {
    // Lamé lambda = 0 (Poisson ratio 0): the model's own lambda is 5/6 mu, alpha is finite.
    let lame = LameParameters::new(4e4, 0.0).unwrap();
    let snh = StableNeoHookean::new(lame);
    assert_eq!(snh.lambda(), 5.0 / 6.0 * 4e4);
    assert!((snh.alpha() - 2.2).abs() < 1e-15, "alpha = {}", snh.alpha());
    assert!(snh.first_piola(&Matrix3::identity()).unwrap().norm() < 1e-9);
    // The void material mu = lambda = 0 would give alpha = 0/0; it is 1 and everything is zero.
    let void = StableNeoHookean::new(LameParameters::new(0.0, 0.0).unwrap());
    assert_eq!(void.alpha(), 1.0);
    for f in through_inversion() {
        assert_eq!(void.energy_density(&f).unwrap(), 0.0);
        assert_eq!(void.first_piola(&f).unwrap(), Matrix3::zeros());
        assert_eq!(void.first_piola_derivative(&f).unwrap(), Matrix9::zeros());
    }
}

#[test]
fn corotated_stays_finite_where_the_rotation_is_not_unique() {
    // σ_i + σ_j = 0 for the reflection and F = 0: the twist-mode denominator is clamped.
    for lame in lame_sets() {
        let corotated = Corotated::new(lame);
        for f in through_inversion() {
            assert_all_finite(&corotated, &f);
        }
    }
}

#[test]
fn stvk_is_finite_everywhere_but_does_not_resist_reflection_or_collapse() {
    let lame = lame_sets()[0];
    let stvk = StVenantKirchhoff::new(lame);
    for f in through_inversion() {
        assert_all_finite(&stvk, &f);
    }
    let reflected = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0));
    assert_eq!(stvk.energy_density(&reflected).unwrap(), 0.0);
    assert_eq!(stvk.first_piola(&reflected).unwrap(), Matrix3::zeros());
    let collapsed = Matrix3::zeros();
    let psi0 = 0.75 * lame.mu + 9.0 / 8.0 * lame.lambda;
    assert!((stvk.energy_density(&collapsed).unwrap() - psi0).abs() < 1e-9 * psi0);
    assert_eq!(stvk.first_piola(&collapsed).unwrap(), Matrix3::zeros());
}

#[test]
fn neo_hookean_rejects_inverted_and_collapsed_elements() {
    let nh = NeoHookean::new(lame_sets()[0]);
    let mut rng = Rng::new(10);
    let mut fs = vec![
        Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0)),
        Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 0.0)),
        Matrix3::zeros(),
    ];
    fs.extend((0..20).map(|_| inverted(&mut rng)));
    for f in fs {
        let det_f = f.determinant();
        assert!(det_f <= 0.0);
        assert_eq!(nh.energy_density(&f).unwrap_err().det_f, det_f);
        assert_eq!(nh.first_piola(&f).unwrap_err().det_f, det_f);
        assert_eq!(nh.first_piola_derivative(&f).unwrap_err().det_f, det_f);
    }
    const { assert!(!NeoHookean::HANDLES_INVERSION) };
}

#[test]
fn rotation_variant_svd_has_proper_rotations_and_reconstructs_f() {
    let mut rng = Rng::new(11);
    let mut fs = through_inversion();
    fs.extend((0..100).map(|_| perturbed_identity(&mut rng)));
    fs.extend((0..100).map(|_| near_singular(&mut rng)));
    for f in fs {
        let svd = RotationVariantSvd::new(&f).unwrap();
        let back = svd.u * Matrix3::from_diagonal(&svd.sigma) * svd.v.transpose();
        assert!((back - f).norm() <= 1e-13 * f.norm().max(1.0), "F = {f}");
        assert!((svd.u.determinant() - 1.0).abs() < 1e-12);
        assert!((svd.v.determinant() - 1.0).abs() < 1e-12);
        let negative = svd.sigma.iter().filter(|s| **s < 0.0).count();
        assert!(negative <= 1, "sigma = {}", svd.sigma);
        if negative == 1 {
            let smallest = svd
                .sigma
                .iter()
                .map(|s| s.abs())
                .fold(f64::INFINITY, f64::min);
            assert_eq!(svd.sigma.min().abs(), smallest, "sigma = {}", svd.sigma);
        }
    }
    assert!(RotationVariantSvd::new(&Matrix3::from_element(f64::NAN)).is_none());
}

#[test]
fn material_model_round_trips_every_name() {
    let lame = lame_sets()[0];
    for name in MaterialModel::NAMES {
        assert_eq!(MaterialModel::from_name(name, lame).unwrap().name(), name);
    }
    assert_eq!(
        MaterialModel::from_name("stvk", lame).unwrap(),
        MaterialModel::StVenantKirchhoff(StVenantKirchhoff::new(lame))
    );
}

#[test]
fn material_model_rejects_an_unknown_name_listing_the_valid_ones() {
    let err = MaterialModel::from_name("neohookean", lame_sets()[0]).unwrap_err();
    assert_eq!(err, MaterialError::UnknownModel("neohookean".into()));
    let message = err.to_string();
    assert!(message.contains("neohookean"), "{message}");
    for name in MaterialModel::NAMES {
        assert!(message.contains(name), "{message}");
    }
}

#[test]
fn lame_parameters_follow_from_youngs_modulus_and_poisson_ratio() {
    let lame = LameParameters::from_youngs_poisson(1e5, 0.25).unwrap();
    assert!((lame.mu - 4e4).abs() < 1e-9);
    assert!((lame.lambda - 4e4).abs() < 1e-9);
    let lame = LameParameters::from_youngs_poisson(2.6e3, 0.3).unwrap();
    assert!((lame.mu - 1e3).abs() < 1e-9);
    assert!((lame.lambda - 1.5e3).abs() < 1e-9);
    let lame = LameParameters::from_youngs_poisson(1e5, 0.0).unwrap();
    assert_eq!(
        lame,
        LameParameters {
            mu: 5e4,
            lambda: 0.0
        }
    );
}

#[test]
fn lame_parameters_reject_invalid_constants_naming_the_field() {
    for nu in [0.5, 0.6, -1.0, -2.0, f64::NAN, f64::INFINITY] {
        let message = LameParameters::from_youngs_poisson(1e5, nu)
            .unwrap_err()
            .to_string();
        assert!(message.contains("poisson_ratio"), "nu = {nu}: {message}");
    }
    for e in [0.0, -1e5, f64::NAN, f64::INFINITY] {
        let message = LameParameters::from_youngs_poisson(e, 0.3)
            .unwrap_err()
            .to_string();
        assert!(message.contains("youngs_modulus"), "E = {e}: {message}");
    }
    for (mu, lambda, field) in [
        (f64::NAN, 1.0, "mu"),
        (-1.0, 1.0, "mu"),
        (1.0, f64::NAN, "lambda"),
        (1.0, -1.0, "lambda"),
        (1.0, f64::INFINITY, "lambda"),
    ] {
        let message = LameParameters::new(mu, lambda).unwrap_err().to_string();
        assert!(message.starts_with(field), "({mu}, {lambda}): {message}");
    }
}

#[test]
fn vec9_is_column_major() {
    let m = Matrix3::from_fn(|i, j| (i + 3 * j) as f64);
    assert_eq!(vec9(&m), SVector::<f64, 9>::from_fn(|k, _| k as f64));
}
