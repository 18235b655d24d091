//! Line charts: one line with markers per series, the legend in a column to the right.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::axis::{Axis, Scale};
use super::frame::{Frame, Layout};
use super::legend::{Column, Entry, Glyph};
use super::style::{self, LINE_WIDTH};
use super::{LineChart, PlotError, draw_err, no_data};

/// Most markers drawn on one series.
const MAX_MARKERS: usize = 24;

/// Draw `chart` into `body` (the image below the title); `root` is the whole image, used for
/// drawing in absolute pixels.
pub fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    body: &DrawingArea<DB, Shift>,
    chart: &LineChart,
) -> Result<(), PlotError> {
    let (xs, ys) = (Scale::log_if(chart.x_log), Scale::log_if(chart.y_log));
    let drawable = |&(x, y): &(f64, f64)| Axis::accepts(xs, x) && Axis::accepts(ys, y);
    let all = || {
        chart
            .series
            .iter()
            .flat_map(|s| s.points.iter().filter(|p| drawable(p)))
    };
    if all().next().is_none() {
        return no_data(body);
    }
    let x = Axis::fit(xs, all().map(|p| p.0), false);
    let y = Axis::fit(ys, all().map(|p| p.1), false);

    let entries: Vec<Entry> = chart
        .series
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let (color, marker, dash) = style::series_look(i);
            let empty = !s.points.iter().any(drawable);
            Entry {
                label: if empty {
                    format!("{} (no data)", s.label)
                } else if s.ended {
                    format!("{} (ended early: X)", s.label)
                } else {
                    s.label.clone()
                },
                glyph: Glyph::Series(color, marker, dash),
            }
        })
        .collect();
    // Room under the legend's top (the frame's top) to the image's bottom edge.
    let legend = Column::fitted(&entries, body.dim_in_pixel().1.saturating_sub(12))?;
    let (w, _) = body.dim_in_pixel();
    let legend_w = if entries.is_empty() {
        0
    } else {
        legend.width + 16
    };
    let (plot_area, _) = body.split_horizontally(w.saturating_sub(legend_w));

    let layout = Layout::numeric(&y, Some(&x), &chart.x_label)?;
    let frame = Frame::draw(
        &plot_area,
        x,
        y,
        (&chart.x_label, &chart.y_label),
        layout,
        true,
    )?;
    let (_, top, right, _) = frame.rect();
    legend.draw(root, (right + layout.right as i32 + 6, top))?;

    let count = chart.series.len().max(1);
    for (i, s) in chart.series.iter().enumerate() {
        let (color, marker, dash) = style::series_look(i);
        // Non-drawable points break the line: a gap shows where the data is missing.
        let mut runs: Vec<Vec<(i32, i32)>> = vec![Vec::new()];
        for p in &s.points {
            match (frame.x.to_display(p.0), frame.y.to_display(p.1)) {
                (Some(xd), Some(yd)) => runs.last_mut().expect("a run").push(frame.px(xd, yd)),
                _ => runs.push(Vec::new()),
            }
        }
        for run in runs.iter().filter(|r| r.len() > 1) {
            for piece in style::dashed(run, dash) {
                root.draw(&PathElement::new(piece, color.stroke_width(LINE_WIDTH)))
                    .map_err(draw_err)?;
            }
        }
        // Dense series (time histories) get a marker on every k-th point only, so the markers
        // identify the line without burying it.
        let n = runs.iter().map(Vec::len).sum::<usize>();
        let every = n.div_ceil(MAX_MARKERS).max(1);
        // Each series starts its markers at its own phase, so lines that coincide still show
        // every series' markers side by side.
        let phase = i * every / count;
        for (k, &c) in runs.iter().flatten().enumerate() {
            if (k + every - phase % every).is_multiple_of(every) || k + 1 == n {
                style::draw_marker(root, c, marker, color)?;
            }
        }
        if s.ended
            && let Some(&(x, y)) = runs.iter().flatten().last()
        {
            // A large X where a run that ended early stops.
            for d in [(-9, -9, 9, 9), (-9, 9, 9, -9)] {
                root.draw(&PathElement::new(
                    vec![(x + d.0, y + d.1), (x + d.2, y + d.3)],
                    color.stroke_width(3),
                ))
                .map_err(draw_err)?;
            }
        }
    }
    Ok(())
}
