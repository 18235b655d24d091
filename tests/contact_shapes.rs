//! Obstacle shapes: signed distances at known points, and gradients and Hessians against
//! central finite differences — for each shape, under rigid transforms, in groups and on paths.

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use softbench::contact::{
    Capsule, Cuboid, HalfSpace, Obstacle, Path, Sdf, SdfValue, Shape, Sphere,
};
use softbench::rng::Rng;

const H: f64 = 1e-6;

/// Central differences of the distance (gradient) and of the gradient (Hessian).
fn finite_differences(
    f: &dyn Fn(&Vector3<f64>) -> SdfValue,
    p: &Vector3<f64>,
) -> (Vector3<f64>, Matrix3<f64>) {
    let mut grad = Vector3::zeros();
    let mut hess = Matrix3::zeros();
    for i in 0..3 {
        let mut e = Vector3::zeros();
        e[i] = H;
        let (plus, minus) = (f(&(p + e)), f(&(p - e)));
        grad[i] = (plus.distance - minus.distance) / (2.0 * H);
        hess.set_column(i, &((plus.gradient - minus.gradient) / (2.0 * H)));
    }
    (grad, hess)
}

/// Check the derivatives of `f` at `p` against finite differences.
#[track_caller]
fn assert_derivatives(f: &dyn Fn(&Vector3<f64>) -> SdfValue, p: &Vector3<f64>) {
    let value = f(p);
    let (grad, hess) = finite_differences(f, p);
    let scale = 1.0 + value.hessian.norm();
    assert!(
        (value.gradient - grad).norm() < 1e-6,
        "gradient at {p:?}: {:?} vs finite differences {grad:?}",
        value.gradient
    );
    assert!(
        (value.hessian - hess).norm() < 1e-4 * scale,
        "Hessian at {p:?}: {} vs finite differences {hess}",
        value.hessian
    );
    assert!(
        (value.gradient.norm() - 1.0).abs() < 1e-12,
        "|gradient| = 1"
    );
    assert!(
        (value.hessian * value.gradient).norm() < 1e-9 * scale,
        "the normal is in the Hessian's null space"
    );
}

/// Random points in a cube of half-width `r`, away from the kinks `avoid` says are near.
fn points(
    seed: u64,
    r: f64,
    count: usize,
    avoid: impl Fn(&Vector3<f64>) -> bool,
) -> Vec<Vector3<f64>> {
    let mut rng = Rng::new(seed);
    let mut out = Vec::new();
    while out.len() < count {
        let p = Vector3::new(rng.range(-r, r), rng.range(-r, r), rng.range(-r, r));
        if !avoid(&p) {
            out.push(p);
        }
    }
    out
}

fn turned() -> Rotation3<f64> {
    Rotation3::from_axis_angle(
        &nalgebra::Unit::new_normalize(Vector3::new(1.0, 2.0, -0.5)),
        0.7,
    )
}

#[test]
fn half_space_distance_is_height_above_the_plane() {
    let ground = HalfSpace::new(Vector3::new(0.0, 1.0, 0.0), Vector3::new(0.0, 2.0, 0.0));
    let v = ground.eval(&Vector3::new(3.0, 1.5, -2.0));
    assert_eq!(v.distance, 0.5);
    assert_eq!(v.gradient, Vector3::y());
    assert_eq!(ground.eval(&Vector3::new(0.0, 0.25, 0.0)).distance, -0.75);
    let tilted = HalfSpace::new(Vector3::zeros(), Vector3::new(1.0, 1.0, 0.3));
    for p in points(1, 2.0, 20, |_| false) {
        assert_derivatives(&|x| tilted.eval(x), &p);
    }
}

#[test]
fn sphere_distance_and_derivatives_match_finite_differences() {
    let c = Vector3::new(0.1, -1.2, 0.3);
    let s = Sphere::new(c, 1.0);
    assert!((s.eval(&(c + Vector3::new(0.0, 2.5, 0.0))).distance - 1.5).abs() < 1e-15);
    assert!((s.eval(&(c + Vector3::new(0.6, 0.0, 0.0))).distance + 0.4).abs() < 1e-15);
    for p in points(2, 2.5, 50, |p| (p - c).norm() < 0.05) {
        assert_derivatives(&|x| s.eval(x), &p);
    }
}

#[test]
fn box_distance_and_derivatives_match_finite_differences() {
    let h = Vector3::new(0.5, 0.3, 0.2);
    let b = Cuboid::new(Vector3::zeros(), h, Rotation3::identity());
    // Face, edge and corner regions outside, and inside.
    assert!((b.eval(&Vector3::new(0.0, 0.5, 0.0)).distance - 0.2).abs() < 1e-15);
    let edge = b.eval(&Vector3::new(0.8, 0.7, 0.0));
    assert!((edge.distance - (0.3f64.powi(2) + 0.4f64.powi(2)).sqrt()).abs() < 1e-15);
    let corner = b.eval(&Vector3::new(1.5, 1.3, 1.2));
    assert!((corner.distance - 3f64.sqrt()).abs() < 1e-15);
    let inside = b.eval(&Vector3::new(0.1, 0.25, 0.0));
    assert!((inside.distance + 0.05).abs() < 1e-15);
    assert_eq!(inside.gradient, Vector3::y());
    // Away from the kinks: the box's faces' planes (outside) and the medial planes (inside).
    let near_kink = |p: &Vector3<f64>| {
        let e = p.abs() - h;
        let outside = e.iter().any(|x| *x > 0.0);
        if outside {
            e.iter().any(|x| x.abs() < 0.02)
        } else {
            let mut s = [e[0], e[1], e[2]];
            s.sort_by(f64::total_cmp);
            s[2] - s[1] < 0.02
        }
    };
    for p in points(3, 1.5, 80, near_kink) {
        assert_derivatives(&|x| b.eval(x), &p);
    }
    // An oriented box equals the axis-aligned one seen in its frame.
    let r = turned();
    let c = Vector3::new(0.2, -0.1, 0.4);
    let oriented = Cuboid::new(c, h, r);
    for p in points(4, 1.5, 80, |p| near_kink(p)) {
        let world = c + r * p;
        let (a, o) = (b.eval(&p), oriented.eval(&world));
        assert!((a.distance - o.distance).abs() < 1e-14);
        assert!((r * a.gradient - o.gradient).norm() < 1e-14);
        assert_derivatives(&|x| oriented.eval(x), &world);
    }
}

#[test]
fn capsule_distance_and_derivatives_match_finite_differences() {
    let (a, b) = (Vector3::new(-0.5, 0.0, 0.0), Vector3::new(0.5, 0.2, 0.1));
    let cap = Capsule::new(a, b, 0.25);
    // Beside the middle of the segment, and beyond an end.
    let mid = (a + b) / 2.0;
    let across = (b - a).cross(&Vector3::z()).normalize();
    assert!((cap.eval(&(mid + across)).distance - 0.75).abs() < 1e-14);
    let beyond = b + (b - a).normalize() * 0.5;
    assert!((cap.eval(&beyond).distance - 0.25).abs() < 1e-14);
    let near_kink = |p: &Vector3<f64>| {
        let s = (p - a).dot(&(b - a)) / (b - a).norm_squared();
        s.abs() < 0.02 || (s - 1.0).abs() < 0.02 || cap.eval(p).distance < -0.2
    };
    for p in points(5, 1.2, 80, near_kink) {
        assert_derivatives(&|x| cap.eval(x), &p);
    }
}

#[test]
fn transformed_obstacle_is_the_shape_seen_in_its_frame() {
    let pose = Isometry3::from_parts(
        Translation3::new(0.3, -0.2, 1.0),
        UnitQuaternion::from_rotation_matrix(&turned()),
    );
    let capsule = Capsule::new(
        Vector3::new(-0.5, 0.0, 0.0),
        Vector3::new(0.5, 0.0, 0.0),
        0.2,
    );
    let obstacle = Obstacle::new(Shape::Capsule(capsule)).with_transform(pose);
    for p in points(6, 1.0, 40, |p| p.x.abs() > 0.48 && p.x.abs() < 0.52) {
        let world = pose * nalgebra::Point3::from(p);
        let local = capsule.eval(&p);
        let s = obstacle.sample(&world.coords, 0.0);
        assert!((s.sdf.distance - local.distance).abs() < 1e-14);
        assert!((s.sdf.gradient - pose.rotation * local.gradient).norm() < 1e-14);
        assert_derivatives(&|x| obstacle.sample(x, 0.0).sdf, &world.coords);
    }
}

#[test]
fn group_is_the_union_of_its_members() {
    let ball = Obstacle::new(Shape::Sphere(Sphere::new(Vector3::new(1.0, 0.0, 0.0), 0.5)));
    let ground = Obstacle::new(Shape::HalfSpace(HalfSpace::new(
        Vector3::new(0.0, -1.0, 0.0),
        Vector3::y(),
    )));
    let group = Obstacle::new(Shape::Group(vec![ball.clone(), ground.clone()]))
        .with_transform(Isometry3::translation(0.0, 0.5, 0.0));
    for p in points(7, 2.0, 100, |_| false) {
        let shifted = p - Vector3::new(0.0, 0.5, 0.0);
        let expected = ball
            .sample(&shifted, 0.0)
            .sdf
            .distance
            .min(ground.sample(&shifted, 0.0).sdf.distance);
        assert!((group.sample(&p, 0.0).sdf.distance - expected).abs() < 1e-14);
        // Pieces are the members, in order.
        let mut pieces = Vec::new();
        group.for_each_piece(&p, 0.0, &mut |i, s| pieces.push((i, s.sdf.distance)));
        assert_eq!(pieces.len(), 2);
        assert_eq!((pieces[0].0, pieces[1].0), (0, 1));
        assert!((pieces[0].1.min(pieces[1].1) - expected).abs() < 1e-14);
    }
}

#[test]
fn obstacle_on_a_path_moves_with_linear_interpolation() {
    let path = Path::new(
        vec![0.0, 1.0, 3.0],
        vec![
            Vector3::zeros(),
            Vector3::new(0.0, 1.0, 0.0),
            Vector3::new(2.0, 1.0, 0.0),
        ],
    );
    assert_eq!(path.offset(-1.0), Vector3::zeros());
    assert_eq!(path.offset(0.5), Vector3::new(0.0, 0.5, 0.0));
    assert_eq!(path.offset(2.0), Vector3::new(1.0, 1.0, 0.0));
    assert_eq!(path.offset(5.0), Vector3::new(2.0, 1.0, 0.0));
    assert_eq!(path.velocity(0.5), Vector3::new(0.0, 1.0, 0.0));
    assert_eq!(path.velocity(2.0), Vector3::new(1.0, 0.0, 0.0));
    assert_eq!(path.velocity(4.0), Vector3::zeros());
    let sphere = Sphere::new(Vector3::zeros(), 0.5);
    let moving = Obstacle::new(Shape::Sphere(sphere)).with_path(path);
    let p = Vector3::new(0.0, 1.2, 0.0);
    assert!((moving.sample(&p, 0.0).sdf.distance - 0.7).abs() < 1e-15);
    let s = moving.sample(&p, 0.5);
    assert!((s.sdf.distance - 0.2).abs() < 1e-15);
    assert_eq!(s.velocity, Vector3::new(0.0, 1.0, 0.0));
}
