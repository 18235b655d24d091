//! One numeric axis: which values it can show, its range, its ticks and their labels.
//!
//! Every axis is drawn by plotters as a linear axis in *display* coordinates: the value itself
//! on a linear axis, `log10(value)` on a log axis. Ticks are chosen here, so log axes get
//! decade ticks labelled `1e-5`, `1e-4`, … and linear axes get 1-2-2.5-5 steps.

use std::ops::Range;

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::coord::types::RangedCoordf64;

/// How values map to the axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    Linear,
    Log,
}

/// A numeric axis with its range and ticks, all in display coordinates.
#[derive(Clone, Debug)]
pub struct Axis {
    pub scale: Scale,
    /// Displayed range (display coordinates).
    pub range: Range<f64>,
    /// Labelled ticks with major grid lines (display coordinates).
    pub major: Vec<f64>,
    /// Unlabelled minor grid lines (display coordinates).
    pub minor: Vec<f64>,
    /// Label format, fixed for the whole axis so all labels look alike.
    format: Format,
}

#[derive(Clone, Copy, Debug)]
enum Format {
    /// Plain decimals with this many digits after the point.
    Fixed(usize),
    /// Scientific with one exponent for the whole axis (`0.5e-4`, `1.0e-4`, `1.5e-4`).
    Sci { digits: usize, exp: i32 },
    /// Log axis, plain decimals (`0.01`, `1`, `100`).
    LogPlain,
    /// Log axis, scientific (`2e-5`, `1e3`).
    LogSci,
}

/// Fraction of the data span added on each side of a linear axis.
const PAD: f64 = 0.05;
/// About this many labelled ticks on a linear axis.
const TARGET_TICKS: f64 = 7.0;
/// At most this many labelled decades on a log axis (more: every second one, …).
const MAX_DECADE_LABELS: usize = 10;

impl Scale {
    /// `Log` if `log`, else `Linear`.
    pub fn log_if(log: bool) -> Self {
        if log { Scale::Log } else { Scale::Linear }
    }
}

impl Axis {
    /// Whether `v` can be drawn on an axis of this scale: finite, and positive on a log axis.
    pub fn accepts(scale: Scale, v: f64) -> bool {
        v.is_finite() && (scale == Scale::Linear || v > 0.0)
    }

    /// `v` in display coordinates, or `None` if it cannot be drawn on this axis.
    pub fn to_display(&self, v: f64) -> Option<f64> {
        if !Self::accepts(self.scale, v) {
            return None;
        }
        Some(match self.scale {
            Scale::Linear => v,
            Scale::Log => v.log10(),
        })
    }

    /// An axis covering the drawable `values` (others are ignored). With `from_zero`, a linear
    /// axis includes 0 and gets no padding below it (bars grow from 0). With no drawable value,
    /// a default range (0..1, or 1..10 on a log axis) without ticks.
    pub fn fit(scale: Scale, values: impl IntoIterator<Item = f64>, from_zero: bool) -> Self {
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        for v in values.into_iter().filter(|&v| Self::accepts(scale, v)) {
            let d = if scale == Scale::Log { v.log10() } else { v };
            lo = lo.min(d);
            hi = hi.max(d);
        }
        let empty = lo > hi;
        let mut axis = match scale {
            Scale::Linear if empty => Self::linear(0.0, 1.0, false),
            Scale::Linear => Self::linear(lo, hi, from_zero),
            Scale::Log if empty => Self::log(0.0, 1.0),
            Scale::Log => Self::log(lo, hi),
        };
        if empty {
            // No numbers on an axis without data: they would describe nothing.
            axis.major.clear();
            axis.minor.clear();
        }
        axis
    }

    /// Linear axis over data `lo..=hi`.
    fn linear(mut lo: f64, mut hi: f64, from_zero: bool) -> Self {
        if from_zero {
            lo = lo.min(0.0);
            hi = hi.max(0.0);
        }
        if hi - lo <= f64::EPSILON * hi.abs().max(lo.abs()).max(f64::MIN_POSITIVE) {
            let half = if lo == 0.0 { 1.0 } else { 0.1 * lo.abs() };
            lo -= half;
            hi += half;
        }
        let span = hi - lo;
        let (lo, hi) = if from_zero {
            (
                if lo < 0.0 { lo - PAD * span } else { lo },
                if hi > 0.0 { hi + PAD * span } else { hi },
            )
        } else {
            (lo - PAD * span, hi + PAD * span)
        };
        let step = nice_step(hi - lo, TARGET_TICKS);
        let first = (lo / step).ceil() as i64;
        let last = (hi / step).floor() as i64;
        let major: Vec<f64> = (first..=last).map(|k| k as f64 * step).collect();
        let (mantissa, exp) = split(step);
        let extra = usize::from(mantissa == 2.5);
        let biggest = lo.abs().max(hi.abs());
        let format = if !(1e-3..1e5).contains(&biggest) {
            let top = biggest.log10().floor() as i32;
            Format::Sci {
                digits: (top - exp).max(0) as usize + extra,
                exp: top,
            }
        } else {
            Format::Fixed((-exp).max(0) as usize + extra)
        };
        Self {
            scale: Scale::Linear,
            range: lo..hi,
            major,
            minor: Vec::new(),
            format,
        }
    }

    /// Log axis over data `lo..=hi` given as `log10` of the values.
    ///
    /// The range snaps outward to whole decades; an end point that would then sit on the frame
    /// (where its marker would be cut in half) gets a small extra margin instead.
    fn log(lo: f64, hi: f64) -> Self {
        let mut a = lo.floor();
        let mut b = hi.ceil();
        if b - a < 1.0 {
            b = a + 1.0;
        }
        // Two decades or less: also label 2× and 5× so the axis has enough numbers.
        let label_twos_and_fives = b - a <= 2.0;
        let edge = 0.03 * (b - a);
        if lo - a < edge {
            a -= edge;
        }
        if b - hi < edge {
            b += edge;
        }
        let decades: Vec<i32> = ((a.ceil() as i32)..=(b.floor() as i32)).collect();
        let stride = decades.len().div_ceil(MAX_DECADE_LABELS).max(1);
        // Minor lines at 2×, 3×, …, 9× only while they stay sparse enough to read.
        let fine_minor = decades.len() <= 7;
        let mut major = Vec::new();
        let mut minor = Vec::new();
        for &e in &decades {
            let labelled = (e.rem_euclid(stride as i32)) == 0;
            if labelled {
                major.push(e as f64);
            } else {
                minor.push(e as f64);
            }
            if fine_minor {
                for k in 2..=9 {
                    let d = e as f64 + (k as f64).log10();
                    if label_twos_and_fives && (k == 2 || k == 5) {
                        major.push(d);
                    } else {
                        minor.push(d);
                    }
                }
            }
        }
        // The decade below the first labelled one contributes minor lines too.
        if fine_minor {
            let e = a.floor() as i32;
            minor.extend((2..=9).map(|k| e as f64 + (k as f64).log10()));
        }
        major.retain(|d| (a..=b).contains(d));
        minor.retain(|d| (a..=b).contains(d));
        let plain = a >= -3.0 - 1e-9 && b <= 4.0 + 1e-9;
        Self {
            scale: Scale::Log,
            range: a..b,
            major,
            minor,
            format: if plain {
                Format::LogPlain
            } else {
                Format::LogSci
            },
        }
    }

    /// The label of the tick at display coordinate `d`.
    pub fn label(&self, d: f64) -> String {
        match self.format {
            Format::Fixed(p) => {
                let s = format!("{d:.p$}");
                if s.trim_start_matches('-')
                    .chars()
                    .all(|c| c == '0' || c == '.')
                {
                    "0".into()
                } else {
                    s
                }
            }
            Format::Sci { digits: p, exp } => {
                let step = self.major.get(1).zip(self.major.first());
                let tiny = step.map_or(0.0, |(b, a)| (b - a) * 1e-6);
                if d.abs() <= tiny {
                    "0".into()
                } else {
                    format!("{:.p$}e{exp}", d / 10f64.powi(exp))
                }
            }
            Format::LogPlain | Format::LogSci => {
                let e = d.floor();
                let mut mantissa = 10f64.powf(d - e).round();
                let mut e = e as i32;
                if mantissa >= 10.0 {
                    mantissa = 1.0;
                    e += 1;
                }
                if matches!(self.format, Format::LogSci) {
                    format!("{mantissa}e{e}")
                } else if e >= 0 {
                    format!("{}", mantissa * 10f64.powi(e))
                } else {
                    let p = (-e) as usize;
                    format!("{:.p$}", mantissa * 10f64.powi(e))
                }
            }
        }
    }

    /// The plotters coordinate for this axis, with its ticks as key points.
    pub fn coord(&self) -> AxisCoord {
        AxisCoord {
            linear: self.range.clone().into(),
            major: self.major.clone(),
            minor: self.minor.clone(),
        }
    }

    /// A categorical axis for `n` slots centred at 0, 1, …, n-1, without ticks or labels.
    pub fn slots(n: usize) -> Self {
        Self {
            scale: Scale::Linear,
            range: -0.5..(n.max(1) as f64 - 0.5),
            major: Vec::new(),
            minor: Vec::new(),
            format: Format::Fixed(0),
        }
    }
}

/// A plotters coordinate in display space whose key points are the axis' ticks (majors for
/// labels and grid lines, minors for light grid lines).
pub struct AxisCoord {
    linear: RangedCoordf64,
    major: Vec<f64>,
    minor: Vec<f64>,
}

impl Ranged for AxisCoord {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.linear.map(value, limit)
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.minor.clone()
        } else {
            self.major.clone()
        }
    }

    fn range(&self) -> Range<f64> {
        self.linear.range()
    }
}

/// `step` split as mantissa × 10^exp with mantissa in [1, 10).
fn split(step: f64) -> (f64, i32) {
    let exp = step.log10().floor() as i32;
    ((step / 10f64.powi(exp) * 1e6).round() / 1e6, exp)
}

/// The 1-2-2.5-5 step that cuts `span` into the number of intervals closest to `target`.
fn nice_step(span: f64, target: f64) -> f64 {
    let base = 10f64.powf((span / target).log10().floor());
    let count = |m: f64| span / (m * base);
    [1.0, 2.0, 2.5, 5.0, 10.0]
        .into_iter()
        .min_by(|&m, &n| {
            let (dm, dn) = ((count(m) - target).abs(), (count(n) - target).abs());
            dm.total_cmp(&dn)
        })
        .expect("candidates")
        * base
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_axis_snaps_to_decades_and_labels_them_in_e_notation() {
        let axis = Axis::fit(Scale::Log, [2e-6, 3e-3, f64::NAN, -1.0, 0.0], false);
        assert_eq!(axis.range, -6.0..-2.0);
        let labels: Vec<String> = axis.major.iter().map(|&d| axis.label(d)).collect();
        assert_eq!(labels, ["1e-6", "1e-5", "1e-4", "1e-3", "1e-2"]);
    }

    #[test]
    fn log_axis_over_few_decades_labels_twos_and_fives_plainly() {
        let axis = Axis::fit(Scale::Log, [0.2, 3.0], false);
        let labels: Vec<String> = axis.major.iter().map(|&d| axis.label(d)).collect();
        assert_eq!(labels, ["0.1", "0.2", "0.5", "1", "2", "5", "10"]);
    }

    #[test]
    fn linear_axis_ticks_are_round_and_cover_the_data() {
        let axis = Axis::fit(Scale::Linear, [0.0, 0.93], true);
        assert_eq!(axis.range.start, 0.0);
        assert!(axis.range.end > 0.93);
        let labels: Vec<String> = axis.major.iter().map(|&d| axis.label(d)).collect();
        assert_eq!(labels, ["0", "0.2", "0.4", "0.6", "0.8"]);
    }

    #[test]
    fn tiny_linear_values_share_one_exponent() {
        let axis = Axis::fit(Scale::Linear, [0.0, 3.4e-4], false);
        let labels: Vec<String> = axis.major.iter().map(|&d| axis.label(d)).collect();
        assert_eq!(labels[..4], ["0", "0.5e-4", "1.0e-4", "1.5e-4"]);
    }
}
