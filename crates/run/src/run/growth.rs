//! The growth of a run's energy excess over time, measured from its envelope.
//!
//! An unstable method makes the energy it gains grow exponentially (a mode whose amplification
//! per step exceeds one); a stable one keeps it bounded (round-off and truncation error that
//! oscillates or settles) or loses energy. [`Envelope`] keeps the largest excess in each of at
//! most [`MAX_WINDOWS`] equal windows of the run so far (merging neighbours when full, so its
//! memory is fixed however long the run) and [`Envelope::fit`] fits an exponential to the
//! windows of the run's last half: its rate, how well it fits, and by how much it grew.
//!
//! A fit is *sustained growth* when it is an exponential (R² at least [`MIN_FIT_R2`]) that grew
//! by at least [`SUSTAINED_GROWTH`] over at least [`MIN_FIT_WINDOWS`] windows. A power law `t^p`
//! grows by `2^p` over a last half, so a truncation error drifting like any power up to t^9 is
//! not one; a jump (an impact) fits a line badly; a transient that decays shrinks.

/// Windows kept at most; when full, neighbours merge and the window length doubles.
pub const MAX_WINDOWS: usize = 64;

/// The growth over the fitted windows that makes a fit sustained growth.
pub const SUSTAINED_GROWTH: f64 = 1e3;

/// The coefficient of determination of `ln(excess)` against time that makes it an exponential.
pub const MIN_FIT_R2: f64 = 0.9;

/// Windows a sustained fit needs at least.
pub const MIN_FIT_WINDOWS: usize = 4;

/// The largest excess per window of a run so far.
#[derive(Clone, Debug)]
pub struct Envelope {
    /// Steps per window.
    stride: usize,
    /// `(end time, largest excess)` of each completed window.
    windows: Vec<(f64, f64)>,
    /// The window being filled: steps in it so far, its end time and its largest excess.
    open: (usize, f64, f64),
}

impl Default for Envelope {
    fn default() -> Self {
        Self {
            stride: 1,
            windows: Vec::with_capacity(MAX_WINDOWS),
            open: (0, 0.0, f64::NEG_INFINITY),
        }
    }
}

/// An exponential fitted to the window maxima of a run's last half.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct GrowthFit {
    /// The e-folding rate of the excess (1/s); negative when it shrinks.
    pub rate: f64,
    /// Coefficient of determination of the fit of `ln(excess)` against time.
    pub r2: f64,
    /// `exp(rate * span)`: by how much the fitted excess grew over the fitted windows.
    pub factor: f64,
    /// Windows fitted.
    pub windows: usize,
}

impl GrowthFit {
    /// Whether the fit is sustained exponential growth (see the module docs).
    pub fn sustained(&self) -> bool {
        self.rate > 0.0
            && self.r2 >= MIN_FIT_R2
            && self.factor >= SUSTAINED_GROWTH
            && self.windows >= MIN_FIT_WINDOWS
    }
}

impl Envelope {
    /// Record the excess `excess` after a step ending at `t`.
    pub fn push(&mut self, t: f64, excess: f64) {
        let (steps, _, peak) = self.open;
        self.open = (steps + 1, t, peak.max(excess));
        if self.open.0 < self.stride {
            return;
        }
        self.windows.push((self.open.1, self.open.2));
        self.open = (0, 0.0, f64::NEG_INFINITY);
        if self.windows.len() == MAX_WINDOWS {
            // Merge neighbours: half as many windows, twice as long.
            for i in 0..MAX_WINDOWS / 2 {
                let (a, b) = (self.windows[2 * i], self.windows[2 * i + 1]);
                self.windows[i] = (b.0, a.1.max(b.1));
            }
            self.windows.truncate(MAX_WINDOWS / 2);
            self.stride *= 2;
        }
    }

    /// The windows so far, the one being filled last (if it has a step).
    fn all(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        let open = (self.open.0 > 0).then_some((self.open.1, self.open.2));
        self.windows.iter().copied().chain(open)
    }

    /// An exponential fitted to the windows of the last half of the run so far (all of them
    /// while there are fewer than four), with every maximum clamped from below at `floor` > 0
    /// (round-off, where a logarithm means nothing). `None` with fewer than two windows.
    pub fn fit(&self, floor: f64) -> Option<GrowthFit> {
        let count = self.all().count();
        let skip = if count < 2 * MIN_FIT_WINDOWS {
            count.saturating_sub(MIN_FIT_WINDOWS)
        } else {
            count / 2
        };
        let points: Vec<(f64, f64)> = self
            .all()
            .skip(skip)
            .map(|(t, e)| (t, e.max(floor).ln()))
            .collect();
        let n = points.len();
        if n < 2 {
            return None;
        }
        let mean_t = points.iter().map(|p| p.0).sum::<f64>() / n as f64;
        let mean_y = points.iter().map(|p| p.1).sum::<f64>() / n as f64;
        let (mut stt, mut sty, mut syy) = (0.0, 0.0, 0.0);
        for (t, y) in &points {
            stt += (t - mean_t).powi(2);
            sty += (t - mean_t) * (y - mean_y);
            syy += (y - mean_y).powi(2);
        }
        if stt <= 0.0 || stt.is_nan() || !syy.is_finite() {
            return None;
        }
        let rate = sty / stt;
        // A flat series (every window at the floor) fits perfectly and grows by nothing.
        let r2 = if syy > 0.0 {
            (sty * sty / (stt * syy)).min(1.0)
        } else {
            1.0
        };
        let span = points[n - 1].0 - points[0].0;
        Some(GrowthFit {
            rate,
            r2,
            factor: (rate * span).exp(),
            windows: n,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn envelope(steps: usize, dt: f64, excess: impl Fn(f64) -> f64) -> Envelope {
        let mut e = Envelope::default();
        for n in 1..=steps {
            let t = n as f64 * dt;
            e.push(t, excess(t));
        }
        e
    }

    #[test]
    fn an_exponential_is_sustained_growth_at_its_rate() {
        let e = envelope(10_000, 1e-3, |t| {
            1e-12 * (3.0 * t).exp() * (1.5 + (40.0 * t).sin())
        });
        let fit = e.fit(1e-30).unwrap();
        assert!((fit.rate - 3.0).abs() < 0.1, "{fit:?}");
        assert!(fit.r2 > 0.99 && fit.sustained(), "{fit:?}");
    }

    #[test]
    fn power_laws_jumps_and_decays_are_not() {
        for p in [1.0, 2.0, 4.0, 8.0] {
            let fit = envelope(5000, 1e-3, |t| t.powf(p)).fit(1e-30).unwrap();
            assert!(!fit.sustained(), "t^{p}: {fit:?}");
        }
        let jump = envelope(5000, 1e-3, |t| if t > 3.8 { 1.0 } else { 1e-9 });
        assert!(!jump.fit(1e-30).unwrap().sustained());
        let decay = envelope(5000, 1e-3, |t| 10.0 * (-5.0 * t).exp());
        let fit = decay.fit(1e-30).unwrap();
        assert!(fit.rate < 0.0 && !fit.sustained(), "{fit:?}");
        let flat = envelope(5000, 1e-3, |_| -1.0);
        assert!(!flat.fit(1e-12).unwrap().sustained());
    }

    #[test]
    fn windows_merge_so_memory_stays_bounded_and_span_the_run() {
        let e = envelope(1_000_003, 1e-6, |t| t);
        assert!(e.windows.len() < MAX_WINDOWS);
        let last = e.all().last().unwrap();
        assert!((last.0 - 1.000003).abs() < 1e-12 && (last.1 - 1.000003).abs() < 1e-12);
    }
}
