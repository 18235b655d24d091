//! Stacked bar charts: one bar per category, one coloured segment per part, the legend in a
//! column to the right listed top to bottom in stacking order. On a log axis the parts of a
//! category stand side by side (grouped bars), since stacked lengths mean nothing there.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::axis::{Axis, Scale};
use super::category;
use super::legend::{Column, Entry, Glyph};
use super::style::PALETTE;
use super::{PlotError, StackedBarChart, draw_err, no_data};

/// Bar width as a fraction of its slot.
const BAR: f64 = 0.7;

/// Height of part `k` in category `i`, or 0 when missing, not finite or negative (a stack
/// cannot show those).
fn height(chart: &StackedBarChart, k: usize, i: usize) -> f64 {
    match chart.parts[k].1.get(i) {
        Some(&v) if v.is_finite() && v > 0.0 => v,
        _ => 0.0,
    }
}

/// Draw `chart` into `body` (the image below the title); `root` is the whole image, used for
/// drawing in absolute pixels.
pub fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    body: &DrawingArea<DB, Shift>,
    chart: &StackedBarChart,
) -> Result<(), PlotError> {
    let n = chart.categories.len();
    if n == 0 || chart.parts.is_empty() {
        return no_data(body);
    }
    let totals: Vec<f64> = (0..n)
        .map(|i| (0..chart.parts.len()).map(|k| height(chart, k, i)).sum())
        .collect();
    let y = if chart.y_log {
        let parts = (0..n).flat_map(|i| (0..chart.parts.len()).map(move |k| (k, i)));
        Axis::fit(Scale::Log, parts.map(|(k, i)| height(chart, k, i)), true)
    } else {
        Axis::fit(Scale::Linear, totals.iter().copied(), true)
    };

    // Listed top to bottom as stacked, so the legend reads like the bars.
    let entries: Vec<Entry> = chart
        .parts
        .iter()
        .enumerate()
        .rev()
        .map(|(k, (label, _))| Entry {
            label: label.clone(),
            glyph: Glyph::Swatch(&PALETTE[k % PALETTE.len()]),
        })
        .collect();
    // Room under the legend's top (the frame's top) to the image's bottom edge.
    let legend = Column::fitted(&entries, body.dim_in_pixel().1.saturating_sub(12))?;
    let (w, _) = body.dim_in_pixel();
    let (frame_area, _) = body.split_horizontally(w.saturating_sub(legend.width + 16));

    let names: Vec<&str> = chart.categories.iter().map(String::as_str).collect();
    let (frame, labels, layout) = category::slot_frame(&frame_area, &names, y, &chart.y_label)?;
    let (_, top, right, _) = frame.rect();
    legend.draw(root, (right + layout.right as i32 + 6, top))?;
    labels.draw(root, &frame)?;

    if chart.y_log {
        return draw_grouped(root, &frame, chart);
    }
    for i in 0..n {
        let at = i as f64;
        let mut level = 0.0;
        for k in 0..chart.parts.len() {
            let h = height(chart, k, i);
            if h == 0.0 {
                continue;
            }
            let a = frame.px(at - BAR / 2.0, level + h);
            let b = frame.px(at + BAR / 2.0, level);
            let color = &PALETTE[k % PALETTE.len()];
            root.draw(&Rectangle::new([a, b], color.filled()))
                .map_err(draw_err)?;
            // A white seam keeps neighbouring segments apart.
            root.draw(&Rectangle::new([a, b], WHITE.stroke_width(1)))
                .map_err(draw_err)?;
            level += h;
        }
    }
    Ok(())
}

/// The parts of each category side by side on a log axis, each from the bottom of the frame;
/// parts of height 0 (or missing) leave their place empty.
fn draw_grouped<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    frame: &super::frame::Frame<DB>,
    chart: &StackedBarChart,
) -> Result<(), PlotError> {
    let parts = chart.parts.len();
    let width = BAR / parts as f64;
    let base = frame.y.range.start;
    for i in 0..chart.categories.len() {
        for k in 0..parts {
            let Some(top) = frame.y.to_display(height(chart, k, i)) else {
                continue;
            };
            let left = i as f64 - BAR / 2.0 + k as f64 * width;
            let a = frame.px(left, top);
            let b = frame.px(left + width, base);
            let color = &PALETTE[k % PALETTE.len()];
            root.draw(&Rectangle::new([a, b], color.filled()))
                .map_err(draw_err)?;
        }
    }
    Ok(())
}
