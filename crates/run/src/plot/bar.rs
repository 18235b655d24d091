//! Bar charts: one bar per entry, an optional tick over each bar (its own limit), an optional
//! dashed reference line, and a note in place of a bar that has no value. The legend (for the
//! tick and the reference line) sits in a row between the title and the chart.

use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

use super::axis::{Axis, Scale};
use super::category;
use super::legend::{Entry, Glyph, Rows};
use super::style::{INK, PALETTE};
use super::{BarChart, PlotError, draw_err, no_data};

/// Bar width as a fraction of its slot.
const BAR: f64 = 0.7;
/// Marker tick width as a fraction of the slot (a little wider than the bar).
const TICK: f64 = 0.84;
/// Shown in place of a bar whose value is missing and has no note.
const DEFAULT_NOTE: &str = "no data";

/// Draw `chart` into `body` (the image below the title); `root` is the whole image, used for
/// drawing in absolute pixels.
pub fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    body: &DrawingArea<DB, Shift>,
    chart: &BarChart,
) -> Result<(), PlotError> {
    let n = chart.bars.len();
    if n == 0 {
        return no_data(body);
    }
    let scale = Scale::log_if(chart.y_log);
    let ok = |v: &f64| Axis::accepts(scale, *v);
    let values = chart.bars.iter().filter_map(|b| b.value);
    let markers = chart.bars.iter().filter_map(|b| b.marker);
    let reference = chart.reference.iter().map(|r| r.value);
    let y = Axis::fit(scale, values.chain(markers).chain(reference), true);

    let bar_color = &PALETTE[0];
    let tick_color = &PALETTE[1];
    let mut entries = Vec::new();
    if chart.bars.iter().filter_map(|b| b.marker).any(|m| ok(&m)) {
        entries.push(Entry {
            label: chart
                .marker_label
                .clone()
                .unwrap_or_else(|| "marker".into()),
            glyph: Glyph::Tick(tick_color),
        });
    }
    if let Some(r) = chart.reference.as_ref().filter(|r| ok(&r.value)) {
        entries.push(Entry {
            label: r.label.clone(),
            glyph: Glyph::Dashed(&INK),
        });
    }
    let (w, _) = body.dim_in_pixel();
    let legend = Rows::new(&entries, w.saturating_sub(40))?;
    let band = if entries.is_empty() {
        0
    } else {
        legend.height + 6
    };
    let (legend_area, frame_area) = body.split_vertically(band);

    let names: Vec<&str> = chart.bars.iter().map(|b| b.label.as_str()).collect();
    let (frame, labels, _) = category::slot_frame(&frame_area, &names, y, &chart.y_label)?;
    let (left, _, right, _) = frame.rect();
    let (lx, ly) = legend_area.get_base_pixel();
    legend.draw(root, (lx + 20, ly + 2))?;
    labels.draw(root, &frame)?;

    // Bars grow from 0 on a linear axis, from the bottom of the frame on a log axis.
    let base = match scale {
        Scale::Linear => 0.0,
        Scale::Log => frame.y.range.start,
    };
    for (i, bar) in chart.bars.iter().enumerate() {
        let at = i as f64;
        match bar.value.and_then(|v| frame.y.to_display(v)) {
            Some(top) => {
                let a = frame.px(at - BAR / 2.0, top);
                let b = frame.px(at + BAR / 2.0, base);
                root.draw(&Rectangle::new([a, b], bar_color.filled()))
                    .map_err(draw_err)?;
            }
            None => {
                let note = bar.note.as_deref().unwrap_or(DEFAULT_NOTE);
                category::draw_note(root, &frame, i, labels.slot_w, note)?;
            }
        }
    }
    for (i, bar) in chart.bars.iter().enumerate() {
        if let Some(m) = bar.marker.and_then(|v| frame.y.to_display(v)) {
            let (x0, y0) = frame.px(i as f64 - TICK / 2.0, m);
            let (x1, _) = frame.px(i as f64 + TICK / 2.0, m);
            root.draw(&Rectangle::new(
                [(x0, y0 - 2), (x1, y0 + 1)],
                tick_color.filled(),
            ))
            .map_err(draw_err)?;
        }
    }
    if let Some(r) = chart
        .reference
        .as_ref()
        .and_then(|r| frame.y.to_display(r.value))
    {
        let (_, yr) = frame.px(0.0, r);
        root.draw(&DashedPathElement::new(
            [(left, yr), (right, yr)],
            9,
            6,
            INK.stroke_width(2),
        ))
        .map_err(draw_err)?;
    }
    Ok(())
}
