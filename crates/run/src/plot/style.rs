//! The look shared by every chart: the embedded font, the colour-blind-friendly palette, the
//! marker shapes, the text sizes and the image size.

use std::sync::OnceLock;

use plotters::prelude::*;
use plotters::style::{FontDesc, FontFamily, FontStyle, RGBColor, register_font};

use super::PlotError;

/// Image width in pixels (PNG) and user units (SVG).
pub const WIDTH: u32 = 1000;
/// Image height in pixels (PNG) and user units (SVG).
pub const HEIGHT: u32 = 640;

/// The font family every text uses; the embedded DejaVu Sans is registered under this name.
const FAMILY: FontFamily<'static> = FontFamily::SansSerif;

/// Register DejaVu Sans (regular and bold) with plotters, once per process.
///
/// Must run before any text style is built: a plotters font description looks its font up when
/// it is created. The bytes are embedded, so no system font library is needed.
pub fn register_fonts() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        let name = FAMILY.as_str();
        register_font(name, FontStyle::Normal, dejavu::sans::regular()).is_ok()
            && register_font(name, FontStyle::Bold, dejavu::sans::bold()).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(PlotError::Draw(
            "the embedded DejaVu font was rejected".into(),
        ))
    }
}

/// Near-black for text and axes.
pub static INK: RGBColor = RGBColor(25, 25, 25);
/// Grey for secondary text (notes, "no data").
pub static MUTED: RGBColor = RGBColor(110, 110, 110);
/// Major grid lines.
pub static GRID: RGBColor = RGBColor(215, 215, 215);
/// Minor grid lines.
pub static GRID_MINOR: RGBColor = RGBColor(238, 238, 238);
/// Legend frame.
pub static FRAME: RGBColor = RGBColor(190, 190, 190);

/// Series colours: the Okabe–Ito palette, ordered for contrast on white (its yellow is left
/// out: too pale for thin lines). Distinguishable under the common colour-vision deficiencies.
pub static PALETTE: [RGBColor; 7] = [
    RGBColor(0, 114, 178),   // blue
    RGBColor(213, 94, 0),    // vermillion
    RGBColor(0, 158, 115),   // bluish green
    RGBColor(204, 121, 167), // reddish purple
    RGBColor(230, 159, 0),   // orange
    RGBColor(86, 180, 233),  // sky blue
    RGBColor(0, 0, 0),       // black
];

/// Marker shapes, so series stay apart in grey-scale print too.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Marker {
    Circle,
    Square,
    TriangleUp,
    Diamond,
    TriangleDown,
    Cross,
    Plus,
    /// An open circle.
    Ring,
}

const MARKERS: [Marker; 8] = [
    Marker::Circle,
    Marker::Square,
    Marker::TriangleUp,
    Marker::Diamond,
    Marker::TriangleDown,
    Marker::Cross,
    Marker::Plus,
    Marker::Ring,
];

/// Line dash patterns (on, off, on, off, ... in pixels; empty = solid).
pub type Dash = &'static [i32];

/// Solid for the first round of colours, then dashed, dotted and dash-dotted: series that
/// share a colour never share a line style (up to 28 series).
const DASHES: [Dash; 4] = [&[], &[10, 6], &[2, 5], &[12, 5, 2, 5]];

/// Colour, marker and line style of series `i`. Palette (7) and markers (8) cycle with coprime
/// periods, so the first 56 series all differ; the dash changes with each round of colours.
pub fn series_look(i: usize) -> (&'static RGBColor, Marker, Dash) {
    (
        &PALETTE[i % PALETTE.len()],
        MARKERS[i % MARKERS.len()],
        DASHES[(i / PALETTE.len()) % DASHES.len()],
    )
}

/// The pieces of the polyline `points` to stroke with `dash` (the whole line when solid).
pub fn dashed(points: &[(i32, i32)], dash: Dash) -> Vec<Vec<(i32, i32)>> {
    if dash.is_empty() || points.len() < 2 {
        return vec![points.to_vec()];
    }
    let mut out: Vec<Vec<(i32, i32)>> = Vec::new();
    let (mut k, mut left, mut on) = (0usize, f64::from(dash[0]), true);
    let mut current = vec![points[0]];
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (dx, dy) = (f64::from(b.0 - a.0), f64::from(b.1 - a.1));
        let len = dx.hypot(dy);
        let mut done = 0.0;
        while len - done > left {
            done += left;
            let p = (
                a.0 + (dx * done / len).round() as i32,
                a.1 + (dy * done / len).round() as i32,
            );
            if on {
                current.push(p);
                out.push(std::mem::take(&mut current));
            } else {
                current = vec![p];
            }
            on = !on;
            k = (k + 1) % dash.len();
            left = f64::from(dash[k]);
        }
        left -= len - done;
        if on {
            current.push(b);
        }
    }
    if on && current.len() > 1 {
        out.push(current);
    }
    out
}

/// Marker radius in pixels.
pub const MARKER_RADIUS: i32 = 5;
/// Series line width in pixels.
pub const LINE_WIDTH: u32 = 2;

/// Draw marker `shape` centred at pixel `c` of `area` (an area in plain pixel coordinates).
pub fn draw_marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    c: (i32, i32),
    shape: Marker,
    color: &RGBColor,
) -> Result<(), PlotError> {
    let r = MARKER_RADIUS;
    let fill = color.filled();
    let at = |pts: &[(f64, f64)]| -> Vec<(i32, i32)> {
        pts.iter()
            .map(|&(x, y)| {
                (
                    c.0 + (x * r as f64).round() as i32,
                    c.1 + (y * r as f64).round() as i32,
                )
            })
            .collect()
    };
    let stroke = color.stroke_width(3);
    let result = match shape {
        Marker::Circle => area.draw(&Circle::new(c, r, fill)),
        Marker::Square => {
            let s = r - 1;
            area.draw(&Rectangle::new(
                [(c.0 - s, c.1 - s), (c.0 + s, c.1 + s)],
                fill,
            ))
        }
        Marker::TriangleUp => area.draw(&Polygon::new(
            at(&[(0.0, -1.25), (1.15, 0.85), (-1.15, 0.85)]),
            fill,
        )),
        Marker::TriangleDown => area.draw(&Polygon::new(
            at(&[(0.0, 1.25), (1.15, -0.85), (-1.15, -0.85)]),
            fill,
        )),
        Marker::Diamond => area.draw(&Polygon::new(
            at(&[(0.0, -1.35), (1.1, 0.0), (0.0, 1.35), (-1.1, 0.0)]),
            fill,
        )),
        Marker::Ring => area
            .draw(&Circle::new(c, r, WHITE.filled()))
            .and_then(|_| area.draw(&Circle::new(c, r, color.stroke_width(2)))),
        Marker::Cross => area
            .draw(&PathElement::new(at(&[(-1.0, -1.0), (1.0, 1.0)]), stroke))
            .and_then(|_| area.draw(&PathElement::new(at(&[(-1.0, 1.0), (1.0, -1.0)]), stroke))),
        Marker::Plus => area
            .draw(&PathElement::new(at(&[(-1.25, 0.0), (1.25, 0.0)]), stroke))
            .and_then(|_| area.draw(&PathElement::new(at(&[(0.0, -1.25), (0.0, 1.25)]), stroke))),
    };
    result.map_err(super::draw_err)
}

/// Text sizes in plotters units (the em box is about size / 1.24 pixels).
pub mod size {
    pub const TITLE: f64 = 26.0;
    pub const AXIS_DESC: f64 = 19.0;
    pub const TICK: f64 = 16.0;
    pub const LEGEND: f64 = 16.0;
    pub const CATEGORY: f64 = 15.0;
    pub const NOTE: f64 = 14.0;
    pub const NO_DATA: f64 = 24.0;
}

/// A regular text style of `size` in `color`.
pub fn text(size: f64, color: &'static RGBColor) -> TextStyle<'static> {
    TextStyle::from(FontDesc::new(FAMILY, size, FontStyle::Normal)).color(color)
}

/// The bold title style.
pub fn title() -> TextStyle<'static> {
    TextStyle::from(FontDesc::new(FAMILY, size::TITLE, FontStyle::Bold)).color(&INK)
}
