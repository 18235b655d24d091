//! Prescribed motion of an obstacle: a translation that interpolates waypoints linearly in time.

use nalgebra::Vector3;

/// A piecewise-linear translation through `(time, offset)` waypoints. Before the first time
/// the obstacle rests at the first offset, after the last at the last one.
#[derive(Clone, Debug, PartialEq)]
pub struct Path {
    times: Vec<f64>,
    offsets: Vec<Vector3<f64>>,
}

impl Path {
    /// # Panics
    /// If there are no waypoints, the lengths differ, or the times are not finite and
    /// strictly increasing.
    pub fn new(times: Vec<f64>, offsets: Vec<Vector3<f64>>) -> Self {
        assert!(
            !times.is_empty() && times.len() == offsets.len(),
            "Path: need as many offsets as times, and at least one"
        );
        assert!(
            times.iter().all(|t| t.is_finite()) && times.windows(2).all(|w| w[0] < w[1]),
            "Path: times must be finite and strictly increasing, got {times:?}"
        );
        Self { times, offsets }
    }

    /// The segment `[times[i], times[i + 1])` holding `t`, if `t` is inside the waypoints'
    /// time range.
    fn segment(&self, t: f64) -> Option<usize> {
        let last = self.times.len() - 1;
        if last == 0 || t < self.times[0] || t >= self.times[last] {
            return None;
        }
        Some(self.times.partition_point(|&ti| ti <= t) - 1)
    }

    /// The offset at time `t` (m).
    pub fn offset(&self, t: f64) -> Vector3<f64> {
        match self.segment(t) {
            Some(i) => {
                let s = (t - self.times[i]) / (self.times[i + 1] - self.times[i]);
                self.offsets[i].lerp(&self.offsets[i + 1], s)
            }
            None if t < self.times[0] => self.offsets[0],
            None => self.offsets[self.offsets.len() - 1],
        }
    }

    /// The velocity at time `t` (m/s): constant on each segment, zero outside the range.
    pub fn velocity(&self, t: f64) -> Vector3<f64> {
        self.segment(t).map_or(Vector3::zeros(), |i| {
            (self.offsets[i + 1] - self.offsets[i]) / (self.times[i + 1] - self.times[i])
        })
    }
}
