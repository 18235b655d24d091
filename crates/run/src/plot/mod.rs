//! Charts of the experiment runner, drawn as PNG and SVG with plotters.
//!
//! A caller describes a chart ([`LineChart`], [`BarChart`], [`StackedBarChart`]) with its title,
//! axis labels (units included) and data; [`draw`] writes `<stem>.png` and `<stem>.svg`.
//! The look is fixed here: embedded DejaVu font (no system fonts), Okabe–Ito colours plus
//! marker shapes, legends outside the plotting area, log axes labelled `1e-5`, `1e-4`, ….
//! Values that cannot be drawn (not finite, or not positive on a log axis) are skipped, never a
//! panic; an empty chart still gets its files, with a "no data" message. Output is
//! deterministic: the same chart gives the same bytes.

mod axis;
mod bar;
mod category;
mod extents;
mod frame;
mod legend;
mod line;
mod stacked;
mod style;
mod text;

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::io::write_atomic;

pub use extents::TextBox;
pub use style::{Dash, HEIGHT, Marker, WIDTH, register_fonts, series_look};
pub use text::width as text_width;

/// A line with markers.
#[derive(Clone, Debug, Default)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// `(x, y)` points, joined in the given order; a point that cannot be drawn breaks the line.
    pub points: Vec<(f64, f64)>,
    /// The run behind the line ended early (a blow-up, a failure): its last point gets a large
    /// end marker and the legend says so.
    pub ended: bool,
}

/// A horizontal reference line across a chart (e.g. a theoretical limit).
#[derive(Clone, Debug, Default)]
pub struct ReferenceLine {
    /// Legend label.
    pub label: String,
    /// Height of the line, in the units of the y axis.
    pub value: f64,
}

/// Lines with markers over two numeric axes; the legend is a column right of the chart.
#[derive(Clone, Debug, Default)]
pub struct LineChart {
    pub title: String,
    /// x axis description, with its unit (e.g. "time step dt \[s\]").
    pub x_label: String,
    /// y axis description, with its unit.
    pub y_label: String,
    pub x_log: bool,
    pub y_log: bool,
    pub series: Vec<Series>,
}

/// One bar per entry; `marker` draws a short horizontal tick over that bar (e.g. its own
/// 2/omega limit).
#[derive(Clone, Debug, Default)]
pub struct Bar {
    /// Category label under the bar (long labels are wrapped or rotated).
    pub label: String,
    /// Bar height; `None` (or a value the axis cannot show) draws `note` instead of a bar.
    pub value: Option<f64>,
    /// Height of this bar's tick, if any.
    pub marker: Option<f64>,
    /// Text shown in place of a missing bar (e.g. "no stable dt in range"); "no data" if none.
    pub note: Option<String>,
}

/// Bars over a numeric y axis; the legend (tick and reference line) is a row above the chart.
#[derive(Clone, Debug, Default)]
pub struct BarChart {
    pub title: String,
    /// y axis description, with its unit.
    pub y_label: String,
    pub y_log: bool,
    pub bars: Vec<Bar>,
    /// Legend label of the per-bar ticks ("marker" if `None`).
    pub marker_label: Option<String>,
    pub reference: Option<ReferenceLine>,
}

/// Stacked bars: one bar per category, one segment per part (side by side on a log axis).
#[derive(Clone, Debug, Default)]
pub struct StackedBarChart {
    pub title: String,
    /// y axis description, with its unit.
    pub y_label: String,
    pub categories: Vec<String>,
    /// `parts[k].1[i]` = height of part `k` in category `i`; parts stack bottom-up in order.
    /// Missing, non-finite or negative heights count as 0.
    pub parts: Vec<(String, Vec<f64>)>,
    /// A log y axis. Stacking has no meaning there (a segment's length would depend on what
    /// lies under it), so the parts of a category stand side by side instead, each from the
    /// bottom of the axis; a part of height 0 draws no bar.
    pub y_log: bool,
}

/// Any chart [`draw`] can render.
#[derive(Clone, Debug)]
pub enum Chart {
    Line(LineChart),
    Bar(BarChart),
    Stacked(StackedBarChart),
}

impl Chart {
    /// The chart's title.
    pub fn title(&self) -> &str {
        match self {
            Chart::Line(c) => &c.title,
            Chart::Bar(c) => &c.title,
            Chart::Stacked(c) => &c.title,
        }
    }
}

/// Why a chart could not be drawn or written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error("cannot write {}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot draw the chart: {0}")]
    Draw(String),
}

impl softbench_core::error_class::Classify for PlotError {
    fn class(&self) -> softbench_core::error_class::ErrorClass {
        softbench_core::error_class::ErrorClass::Failure
    }
}

/// Wrap a plotters (or encoder) error as [`PlotError::Draw`].
fn draw_err(e: impl std::fmt::Display) -> PlotError {
    PlotError::Draw(e.to_string())
}

/// Draw `chart` to `<stem>.png` (`WIDTH`×`HEIGHT` pixels) and `<stem>.svg`, each written
/// atomically (temporary file, then rename). Returns the two paths, PNG first.
///
/// The extension is appended, so a stem such as `dt_limit.v2` keeps its dot.
pub fn draw(chart: &Chart, stem: &Path) -> Result<[PathBuf; 2], PlotError> {
    style::register_fonts()?;
    let with_ext = |ext: &str| {
        let mut name = stem.as_os_str().to_owned();
        name.push(ext);
        PathBuf::from(name)
    };
    let png_path = with_ext(".png");
    let svg_path = with_ext(".svg");

    let mut pixels = vec![0u8; (WIDTH * HEIGHT * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (WIDTH, HEIGHT)).into_drawing_area();
        render(chart, &root)?;
        root.present().map_err(draw_err)?;
    }
    let png = encode_png(&pixels)?;
    write_file(&png_path, &png)?;

    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT)).into_drawing_area();
        render(chart, &root)?;
        root.present().map_err(draw_err)?;
    }
    write_file(&svg_path, svg.as_bytes())?;
    Ok([png_path, svg_path])
}

/// The box of every text `chart` draws (title, ticks, axis and category labels, legend,
/// notes), in pixels of the `WIDTH`×`HEIGHT` image, placed as the PNG places them: for
/// checking that nothing is drawn outside the image.
pub fn text_boxes(chart: &Chart) -> Result<Vec<TextBox>, PlotError> {
    style::register_fonts()?;
    let boxes = std::rc::Rc::new(std::cell::RefCell::new(Vec::new()));
    {
        let root = extents::TextRecorder::new((WIDTH, HEIGHT), boxes.clone()).into_drawing_area();
        render(chart, &root)?;
        root.present().map_err(draw_err)?;
    }
    Ok(boxes.take())
}

/// Encode an RGB buffer of `WIDTH`×`HEIGHT` as PNG.
fn encode_png(pixels: &[u8]) -> Result<Vec<u8>, PlotError> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(pixels, WIDTH, HEIGHT, image::ColorType::Rgb8)
        .map_err(|e| PlotError::Draw(format!("PNG encoding failed: {e}")))?;
    Ok(out)
}

/// Write `bytes` to `path` atomically.
fn write_file(path: &Path, bytes: &[u8]) -> Result<(), PlotError> {
    write_atomic(path, |w| w.write_all(bytes)).map_err(|source| PlotError::Io {
        path: path.to_owned(),
        source,
    })
}

/// Draw `chart` on `root` (the whole image): white background, title, then the chart body.
fn render<DB: DrawingBackend>(
    chart: &Chart,
    root: &DrawingArea<DB, Shift>,
) -> Result<(), PlotError> {
    root.fill(&WHITE).map_err(draw_err)?;
    let titled = root.margin(8, 0, 0, 0);
    let body = titled
        .titled(chart.title(), style::title())
        .map_err(draw_err)?;
    match chart {
        Chart::Line(c) => line::draw(root, &body, c),
        Chart::Bar(c) => bar::draw(root, &body, c),
        Chart::Stacked(c) => stacked::draw(root, &body, c),
    }
}

/// A centred "no data" message in `area`, for a chart with nothing to draw.
fn no_data<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
    let (w, h) = area.dim_in_pixel();
    let style =
        style::text(style::size::NO_DATA, &style::MUTED).pos(Pos::new(HPos::Center, VPos::Center));
    area.draw_text("no data", &style, (w as i32 / 2, h as i32 / 2))
        .map_err(draw_err)
}
