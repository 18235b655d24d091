//! The jello sphere: particles on a latitude–longitude grid of the sphere plus a centre
//! particle, as the seed describes it.
//!
//! Parameters: `rings` rings of latitude strictly between the poles (>= 2), `segments`
//! particles per ring (>= 6 and even, so every particle has an antipode on the grid),
//! `radius` (m) and `center`. The poles lie on the y axis (up); each pole is a single particle.
//!
//! Particle indices: 0 is the centre, 1 the north pole (`center + radius ŷ`), then the rings
//! from north to south, `segments` particles each: particle `s` of ring `r` has index
//! `2 + r·segments + s`, polar angle `π (r + 1) / (rings + 1)` and azimuth `2π s / segments`
//! (from +x towards +z). The south pole is last, `2 + rings·segments`. With R = rings and
//! S = segments there are `R S + 3` particles and these springs:
//! - radial: the centre to every other particle, `R S + 2`;
//! - structural (direct grid neighbours): along each ring, `R S`, and along each meridian,
//!   pole to ring to pole, `(R + 1) S`;
//! - shear (diagonal grid neighbours): both diagonals of each cell between adjacent rings,
//!   `2 (R − 1) S` (the cells at the poles are triangles, without diagonals);
//! - bending (every-other grid neighbours): skip one along each ring, `R S`, and along each
//!   meridian, `R S` (from a pole to the second ring, then ring r to ring r + 2); meridians
//!   stop at the poles;
//! - antipodal: each particle to the diametrically opposite one, `R S / 2 + 1` (the poles are
//!   a pair).

use super::{SpringBody, SpringCoefficients, SpringKind};
use nalgebra::Vector3;
use std::f64::consts::PI;

/// A jello sphere (see the module docs for the layout).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JelloSphere {
    /// Rings of latitude between the poles, >= 2.
    pub rings: usize,
    /// Particles per ring, >= 6 and even.
    pub segments: usize,
    /// Radius (m), > 0.
    pub radius: f64,
    /// Centre (m).
    pub center: Vector3<f64>,
}

impl JelloSphere {
    /// Index of the centre particle.
    pub const CENTER: usize = 0;
    /// Index of the north pole (`+y`).
    pub const NORTH_POLE: usize = 1;

    /// Index of the south pole (`−y`).
    pub fn south_pole(&self) -> usize {
        2 + self.rings * self.segments
    }

    /// Index of particle `s` (taken modulo `segments`) of ring `r`.
    pub fn ring_particle(&self, r: usize, s: usize) -> usize {
        2 + r * self.segments + s % self.segments
    }

    /// The body, with each spring's stiffness and damping from `coefficients(kind)` (called
    /// for `Radial`, `Structural`, `Shear`, `Bending` and `Antipodal`). No tets.
    ///
    /// # Panics
    /// If `rings < 2`, `segments` is odd or below 6, or `radius` is not positive and finite.
    pub fn build(&self, coefficients: impl Fn(SpringKind) -> SpringCoefficients) -> SpringBody {
        let (rings, segs) = (self.rings, self.segments);
        assert!(
            rings >= 2,
            "jello sphere: rings must be at least 2, got {rings}"
        );
        assert!(
            segs >= 6 && segs % 2 == 0,
            "jello sphere: segments must be even and at least 6, got {segs}"
        );
        assert!(
            self.radius > 0.0 && self.radius.is_finite(),
            "jello sphere: radius must be positive and finite, got {}",
            self.radius
        );
        let mut positions = Vec::with_capacity(rings * segs + 3);
        positions.push(self.center);
        positions.push(self.center + Vector3::y() * self.radius);
        for r in 0..rings {
            let polar = PI * (r + 1) as f64 / (rings + 1) as f64;
            for s in 0..segs {
                let azimuth = 2.0 * PI * s as f64 / segs as f64;
                let dir = Vector3::new(
                    polar.sin() * azimuth.cos(),
                    polar.cos(),
                    polar.sin() * azimuth.sin(),
                );
                positions.push(self.center + dir * self.radius);
            }
        }
        positions.push(self.center - Vector3::y() * self.radius);
        let mut body = SpringBody {
            positions,
            ..SpringBody::default()
        };
        let (north, south) = (Self::NORTH_POLE, self.south_pole());
        let p = |r: usize, s: usize| self.ring_particle(r, s);

        let c = coefficients(SpringKind::Radial);
        for v in 1..body.num_particles() {
            body.push(Self::CENTER, v, SpringKind::Radial, c);
        }

        let c = coefficients(SpringKind::Structural);
        for r in 0..rings {
            for s in 0..segs {
                body.push(p(r, s), p(r, s + 1), SpringKind::Structural, c);
            }
        }
        for s in 0..segs {
            body.push(north, p(0, s), SpringKind::Structural, c);
            for r in 0..rings - 1 {
                body.push(p(r, s), p(r + 1, s), SpringKind::Structural, c);
            }
            body.push(p(rings - 1, s), south, SpringKind::Structural, c);
        }

        let c = coefficients(SpringKind::Shear);
        for r in 0..rings - 1 {
            for s in 0..segs {
                body.push(p(r, s), p(r + 1, s + 1), SpringKind::Shear, c);
                body.push(p(r, s), p(r + 1, s + segs - 1), SpringKind::Shear, c);
            }
        }

        let c = coefficients(SpringKind::Bending);
        for r in 0..rings {
            for s in 0..segs {
                body.push(p(r, s), p(r, s + 2), SpringKind::Bending, c);
            }
        }
        for s in 0..segs {
            body.push(north, p(1, s), SpringKind::Bending, c);
            for r in 0..rings - 2 {
                body.push(p(r, s), p(r + 2, s), SpringKind::Bending, c);
            }
            body.push(p(rings - 2, s), south, SpringKind::Bending, c);
        }

        let c = coefficients(SpringKind::Antipodal);
        body.push(north, south, SpringKind::Antipodal, c);
        for r in 0..rings {
            let opposite = rings - 1 - r;
            for s in 0..segs {
                // Each pair once: from the northern ring, or on the equator from the first half.
                if r < opposite || (r == opposite && s < segs / 2) {
                    body.push(p(r, s), p(opposite, s + segs / 2), SpringKind::Antipodal, c);
                }
            }
        }
        body
    }
}
