//! Barrier functions of the squared distance `s = d²` with threshold `ŝ = d̂²`: zero for
//! `s >= ŝ`, positive below, with first and second derivatives in `s` (callers chain them
//! with the distance's own derivatives). Working in `s` avoids square roots in every
//! distance formula, as ipc-toolkit does.
//!
//! - `clamped-log` (IPC, Li et al. 2020, on squared distances): `b(s) = −(s − ŝ)² ln(s / ŝ)`,
//!   C² at `ŝ`, `+∞` as `s → 0`: contact can never close.
//! - `distance-log` (the IPC paper's form, on the distance itself): `b = −(d − d̂)² ln(d / d̂)`,
//!   C² at `d̂` in `d` (C¹ in `s`), `+∞` at contact; it grows more slowly toward contact than
//!   `clamped-log` at the same κ.
//!
//! A barrier that stays finite at contact (the cubic `(ŝ − s)³/ŝ²` was tried) lets a loaded
//! contact close until collision detection allows no step at all: on each scene of the
//! contact study it stalled within ten steps, so none is offered.

/// A barrier of the squared distance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BarrierKind {
    /// `−(s − ŝ)² ln(s/ŝ)`.
    #[default]
    ClampedLog,
    /// `−(d − d̂)² ln(d / d̂)` with `d = √s`.
    DistanceLog,
}

impl BarrierKind {
    /// The name in scene files.
    pub fn name(self) -> &'static str {
        match self {
            Self::ClampedLog => "clamped-log",
            Self::DistanceLog => "distance-log",
        }
    }

    /// `b(s)`: 0 for `s >= s_hat`, `+∞` for `s <= 0` with the logarithm.
    pub fn value(self, s: f64, s_hat: f64) -> f64 {
        if s >= s_hat {
            return 0.0;
        }
        match self {
            _ if s <= 0.0 => f64::INFINITY,
            Self::ClampedLog => -(s - s_hat).powi(2) * (s / s_hat).ln(),
            Self::DistanceLog => {
                let (d, d_hat) = (s.sqrt(), s_hat.sqrt());
                -(d - d_hat).powi(2) * (d / d_hat).ln()
            }
        }
    }

    /// `db/ds` (≤ 0).
    pub fn first_derivative(self, s: f64, s_hat: f64) -> f64 {
        if s >= s_hat {
            return 0.0;
        }
        match self {
            Self::ClampedLog => (s_hat - s) * (2.0 * (s / s_hat).ln() - s_hat / s + 1.0),
            Self::DistanceLog => {
                let (d, d_hat) = (s.sqrt(), s_hat.sqrt());
                distance_log_first(d, d_hat) / (2.0 * d)
            }
        }
    }

    /// `d²b/ds²` (≥ 0).
    pub fn second_derivative(self, s: f64, s_hat: f64) -> f64 {
        if s >= s_hat {
            return 0.0;
        }
        match self {
            Self::ClampedLog => {
                let r = s_hat / s;
                -2.0 * (s / s_hat).ln() + r * r + 2.0 * r - 3.0
            }
            Self::DistanceLog => {
                let (d, d_hat) = (s.sqrt(), s_hat.sqrt());
                let (b1, b2) = (distance_log_first(d, d_hat), distance_log_second(d, d_hat));
                (b2 * d - b1) / (4.0 * d * s)
            }
        }
    }
}

/// `dB/dd` of `B(d) = −(d − d̂)² ln(d/d̂)`.
fn distance_log_first(d: f64, d_hat: f64) -> f64 {
    -2.0 * (d - d_hat) * (d / d_hat).ln() - (d - d_hat).powi(2) / d
}

/// `d²B/dd²`.
fn distance_log_second(d: f64, d_hat: f64) -> f64 {
    let r = (d - d_hat) / d;
    -2.0 * (d / d_hat).ln() - 4.0 * r + r * r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivatives_match_finite_differences_for_every_barrier() {
        let s_hat = 1e-6;
        for kind in [BarrierKind::ClampedLog, BarrierKind::DistanceLog] {
            for frac in [1e-4, 1e-2, 0.1, 0.5, 0.9, 0.999] {
                let s = frac * s_hat;
                let h = 1e-6 * s;
                let fd1 = (kind.value(s + h, s_hat) - kind.value(s - h, s_hat)) / (2.0 * h);
                let d1 = kind.first_derivative(s, s_hat);
                assert!(
                    (fd1 - d1).abs() <= 1e-6 * d1.abs().max(1e-30),
                    "{kind:?} s/ŝ {frac}: {fd1} vs {d1}"
                );
                let fd2 = (kind.first_derivative(s + h, s_hat)
                    - kind.first_derivative(s - h, s_hat))
                    / (2.0 * h);
                let d2 = kind.second_derivative(s, s_hat);
                assert!(
                    (fd2 - d2).abs() <= 1e-5 * d2.abs().max(1e-30),
                    "{kind:?} s/ŝ {frac}: {fd2} vs {d2}"
                );
                assert!(d1 <= 0.0 && d2 >= 0.0 && kind.value(s, s_hat) > 0.0);
            }
            // Zero, with zero derivatives, from the threshold on.
            for s in [s_hat, 2.0 * s_hat] {
                assert_eq!(kind.value(s, s_hat), 0.0);
                assert_eq!(kind.first_derivative(s, s_hat), 0.0);
                assert_eq!(kind.second_derivative(s, s_hat), 0.0);
            }
        }
        for kind in [BarrierKind::ClampedLog, BarrierKind::DistanceLog] {
            assert_eq!(kind.value(0.0, s_hat), f64::INFINITY);
        }
    }
}
