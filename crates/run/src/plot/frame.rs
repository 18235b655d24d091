//! The frame of a chart: plotting area, axes, grid, tick labels and axis descriptions, drawn
//! with plotters' mesh; data is then drawn in pixels through [`Frame::px`].

use plotters::chart::{ChartBuilder, ChartContext};
use plotters::coord::Shift;
use plotters::coord::cartesian::Cartesian2d;
use plotters::prelude::*;

use super::axis::{Axis, AxisCoord};
use super::style::{self, GRID, GRID_MINOR, INK};
use super::{PlotError, draw_err, text};

type Coord = Cartesian2d<AxisCoord, AxisCoord>;

/// Tick mark length in pixels; plotters leaves twice this between axis and labels.
const TICK: i32 = 5;
/// Blank border around the frame, in pixels.
const MARGIN: u32 = 10;

/// Sizes of the label areas around the plotting area, in pixels.
#[derive(Clone, Copy, Debug)]
pub struct Layout {
    /// Left of the plotting area: y tick labels and the y description.
    pub left: u32,
    /// Below the plotting area: x tick labels (or category labels) and the x description.
    pub bottom: u32,
    /// Right of the plotting area, so the last x tick label is not clipped.
    pub right: u32,
}

impl Layout {
    /// Room for a numeric y axis with description `y_desc`, a numeric x axis (if `x` is
    /// given) with description `x_desc`.
    pub fn numeric(y: &Axis, x: Option<&Axis>, x_desc: &str) -> Result<Self, PlotError> {
        let tick_style = style::text(style::size::TICK, &INK);
        let desc_h = text::line_height(&style::text(style::size::AXIS_DESC, &INK))?;
        let tick_h = text::line_height(&tick_style)?;
        let mut widest = 0;
        for &d in &y.major {
            widest = widest.max(text::width(&y.label(d), &tick_style)?);
        }
        let left = 2 * TICK as u32 + widest + 8 + desc_h;
        let (bottom, right) = match x {
            Some(x) => {
                let last = x.major.last().map(|&d| x.label(d)).unwrap_or_default();
                let half_last = text::width(&last, &tick_style)? / 2;
                let desc = if x_desc.is_empty() { 0 } else { desc_h };
                (2 * TICK as u32 + tick_h + 6 + desc, (half_last + 6).max(24))
            }
            None => (0, 24),
        };
        Ok(Self {
            left,
            bottom,
            right,
        })
    }

    /// Width of the plotting area inside an area `width` pixels wide.
    pub fn plot_width(&self, width: u32) -> u32 {
        width.saturating_sub(self.left + self.right + MARGIN)
    }
}

/// A drawn frame: the plotters chart (for the pixel mapping) and its two axes.
pub struct Frame<'a, DB: DrawingBackend> {
    chart: ChartContext<'a, DB, Coord>,
    pub x: Axis,
    pub y: Axis,
}

impl<'a, DB: DrawingBackend> Frame<'a, DB> {
    /// Draw the frame into `area`: grid lines at the axes' ticks (vertical ones only if
    /// `x_grid`), tick labels, and the descriptions `x_desc` (may be empty) and `y_desc`.
    pub fn draw(
        area: &'a DrawingArea<DB, Shift>,
        x: Axis,
        y: Axis,
        (x_desc, y_desc): (&str, &str),
        layout: Layout,
        x_grid: bool,
    ) -> Result<Self, PlotError> {
        let mut chart = ChartBuilder::on(area)
            .margin_top(MARGIN)
            .margin_left(MARGIN)
            .margin_bottom(MARGIN / 2)
            .margin_right(layout.right)
            .x_label_area_size(layout.bottom)
            .y_label_area_size(layout.left)
            .build_cartesian_2d(x.coord(), y.coord())
            .map_err(draw_err)?;
        let (xf, yf) = (|d: &f64| x.label(*d), |d: &f64| y.label(*d));
        let mut mesh = chart.configure_mesh();
        mesh.x_label_formatter(&xf)
            .y_label_formatter(&yf)
            .label_style(style::text(style::size::TICK, &INK))
            .axis_desc_style(style::text(style::size::AXIS_DESC, &INK))
            .axis_style(INK.stroke_width(1))
            .bold_line_style(GRID.stroke_width(1))
            .light_line_style(GRID_MINOR.stroke_width(1))
            .set_all_tick_mark_size(TICK)
            .y_desc(y_desc);
        if !x_desc.is_empty() {
            mesh.x_desc(x_desc);
        }
        if !x_grid {
            mesh.disable_x_mesh();
        }
        mesh.draw().map_err(draw_err)?;
        Ok(Self { chart, x, y })
    }

    /// Pixel (absolute, in the whole image) of display coordinates `(xd, yd)`.
    pub fn px(&self, xd: f64, yd: f64) -> (i32, i32) {
        self.chart.backend_coord(&(xd, yd))
    }

    /// The plotting area in absolute pixels: `(left, top, right, bottom)`.
    pub fn rect(&self) -> (i32, i32, i32, i32) {
        let (xs, ys) = self.chart.plotting_area().get_pixel_range();
        (xs.start, ys.start, xs.end, ys.end)
    }
}
