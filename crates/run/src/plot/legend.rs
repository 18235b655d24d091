//! Legends, drawn outside the plotting area so they never hide data: a framed column (to the
//! right of a chart) or centred rows (between the title and a chart).

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::style::{self, FRAME, INK, Marker};
use super::{PlotError, draw_err, text};

/// What stands in front of a legend label.
#[derive(Clone, Copy, Debug)]
pub enum Glyph {
    /// A line with a marker (a line-chart series), in its dash pattern.
    Series(&'static RGBColor, Marker, style::Dash),
    /// A filled square (a bar or a stacked part).
    Swatch(&'static RGBColor),
    /// A short thick horizontal tick (a per-bar marker).
    Tick(&'static RGBColor),
    /// A dashed line (a reference line).
    Dashed(&'static RGBColor),
}

/// One legend line.
#[derive(Clone, Debug)]
pub struct Entry {
    pub label: String,
    pub glyph: Glyph,
}

/// Width of the glyph column in pixels.
const GLYPH_W: i32 = 34;
/// Gap between glyph and label.
const GAP: i32 = 8;
/// Inner padding of the column frame.
const PAD: i32 = 10;
/// Widest label line in a column before it wraps.
const MAX_LABEL_W: u32 = 230;

/// Most side-by-side columns a tall legend is split into.
const MAX_COLUMNS: usize = 4;
/// Widest a split legend may get, in percent of the image width.
const MAX_SPLIT_WIDTH: u32 = 45;

/// A legend laid out as a framed block of columns (one column unless the entries would run
/// past `max_height`: then as few side-by-side columns, with narrower labels, as fit; if even
/// `MAX_COLUMNS` do not, each label keeps one line ending in "…"). Entries read down the first
/// column, then the next.
pub struct Column {
    columns: Vec<Vec<(Glyph, Vec<String>)>>,
    line_h: i32,
    column_w: u32,
    /// Total width and height in pixels.
    pub width: u32,
    pub height: u32,
}

impl Column {
    /// Lay out `entries` to fit `max_height` pixels if they can (see the type).
    pub fn fitted(entries: &[Entry], max_height: u32) -> Result<Self, PlotError> {
        let style = style::text(style::size::LEGEND, &INK);
        let line_h = text::line_height(&style)? as i32;
        let fixed = (2 * PAD + GLYPH_W + GAP) as u32;
        let mut last = None;
        for k in 1..=MAX_COLUMNS.min(entries.len().max(1)) {
            let label_w = if k == 1 {
                MAX_LABEL_W
            } else {
                (style::WIDTH * MAX_SPLIT_WIDTH / 100 / k as u32)
                    .saturating_sub(fixed)
                    .clamp(60, MAX_LABEL_W)
            };
            let layout = Self::layout(entries, k, label_w, None, line_h, &style)?;
            if layout.height <= max_height {
                return Ok(layout);
            }
            last = Some(label_w);
        }
        let label_w = last.unwrap_or(MAX_LABEL_W);
        Self::layout(entries, MAX_COLUMNS, label_w, Some(1), line_h, &style)
    }

    fn layout(
        entries: &[Entry],
        k: usize,
        label_w: u32,
        max_lines: Option<usize>,
        line_h: i32,
        style: &TextStyle,
    ) -> Result<Self, PlotError> {
        let mut rows = Vec::new();
        let mut widest = 0;
        for e in entries {
            let mut lines = text::wrap(&e.label, label_w, style)?;
            if let Some(n) = max_lines {
                lines = text::clamp_lines(lines, n, label_w, style)?;
            }
            for l in &lines {
                widest = widest.max(text::width(l, style)?);
            }
            rows.push((e.glyph, lines));
        }
        let per_column = rows.len().div_ceil(k.max(1)).max(1);
        let mut columns: Vec<Vec<(Glyph, Vec<String>)>> = Vec::new();
        for chunk in rows.chunks(per_column) {
            columns.push(chunk.to_vec());
        }
        let column_height = |c: &Vec<(Glyph, Vec<String>)>| {
            let n_lines: usize = c.iter().map(|(_, l)| l.len()).sum();
            let gaps = c.len().saturating_sub(1) as i32 * (line_h / 3);
            (2 * PAD + n_lines as i32 * line_h + gaps) as u32
        };
        let height = columns.iter().map(column_height).max().unwrap_or(0);
        let column_w = (2 * PAD + GLYPH_W + GAP) as u32 + widest;
        Ok(Self {
            width: column_w * columns.len().max(1) as u32,
            columns,
            line_h,
            column_w,
            height,
        })
    }

    /// Draw the legend with its top-left corner at `at` (absolute pixels of `area`).
    pub fn draw<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        at: (i32, i32),
    ) -> Result<(), PlotError> {
        if self.columns.is_empty() {
            return Ok(());
        }
        let (x0, y0) = at;
        let frame = [
            (x0, y0),
            (x0 + self.width as i32 - 1, y0 + self.height as i32 - 1),
        ];
        area.draw(&Rectangle::new(frame, WHITE.filled()))
            .map_err(draw_err)?;
        area.draw(&Rectangle::new(frame, FRAME.stroke_width(1)))
            .map_err(draw_err)?;
        let style = style::text(style::size::LEGEND, &INK).pos(Pos::new(HPos::Left, VPos::Center));
        for (c, rows) in self.columns.iter().enumerate() {
            let x = x0 + c as i32 * self.column_w as i32;
            let mut y = y0 + PAD + self.line_h / 2;
            for (glyph, lines) in rows {
                draw_glyph(area, *glyph, (x + PAD, y))?;
                for line in lines {
                    area.draw_text(line, &style, (x + PAD + GLYPH_W + GAP, y))
                        .map_err(draw_err)?;
                    y += self.line_h;
                }
                y += self.line_h / 3;
            }
        }
        Ok(())
    }
}

/// Space between entries on one row.
const ROW_SPACING: i32 = 28;

/// A legend laid out as centred rows, packed greedily into a given width.
pub struct Rows {
    rows: Vec<Vec<(Entry, i32)>>,
    line_h: i32,
    width: i32,
    /// Total height in pixels.
    pub height: u32,
}

impl Rows {
    /// Lay out `entries` in rows at most `width` pixels wide.
    pub fn new(entries: &[Entry], width: u32) -> Result<Self, PlotError> {
        let style = style::text(style::size::LEGEND, &INK);
        let line_h = text::line_height(&style)? as i32;
        let width = width as i32;
        let mut rows: Vec<Vec<(Entry, i32)>> = Vec::new();
        let mut used = 0;
        for e in entries {
            let w = GLYPH_W + GAP + text::width(&e.label, &style)? as i32;
            if rows.is_empty() || used + ROW_SPACING + w > width {
                rows.push(Vec::new());
                used = w;
            } else {
                used += ROW_SPACING + w;
            }
            rows.last_mut().expect("a row").push((e.clone(), w));
        }
        let height = (rows.len() as i32 * line_h) as u32;
        Ok(Self {
            rows,
            line_h,
            width,
            height,
        })
    }

    /// Draw the rows centred in the band that starts at pixel (`left`, `top`) of `area`.
    pub fn draw<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        (left, top): (i32, i32),
    ) -> Result<(), PlotError> {
        let style = style::text(style::size::LEGEND, &INK).pos(Pos::new(HPos::Left, VPos::Center));
        for (r, row) in self.rows.iter().enumerate() {
            let total: i32 =
                row.iter().map(|(_, w)| w).sum::<i32>() + ROW_SPACING * (row.len() as i32 - 1);
            let mut x = left + (self.width - total) / 2;
            let y = top + r as i32 * self.line_h + self.line_h / 2;
            for (e, w) in row {
                draw_glyph(area, e.glyph, (x, y))?;
                area.draw_text(&e.label, &style, (x + GLYPH_W + GAP, y))
                    .map_err(draw_err)?;
                x += w + ROW_SPACING;
            }
        }
        Ok(())
    }
}

/// Draw `glyph` in the box `GLYPH_W` wide whose left end is at pixel `left` (vertically
/// centred on it).
fn draw_glyph<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    glyph: Glyph,
    left: (i32, i32),
) -> Result<(), PlotError> {
    let (x, y) = left;
    let mid = x + GLYPH_W / 2;
    match glyph {
        Glyph::Series(color, marker, dash) => {
            for piece in style::dashed(&[(x + 2, y), (x + GLYPH_W - 2, y)], dash) {
                area.draw(&PathElement::new(
                    piece,
                    color.stroke_width(style::LINE_WIDTH),
                ))
                .map_err(draw_err)?;
            }
            style::draw_marker(area, (mid, y), marker, color)?;
        }
        Glyph::Swatch(color) => {
            area.draw(&Rectangle::new(
                [(mid - 8, y - 8), (mid + 8, y + 8)],
                color.filled(),
            ))
            .map_err(draw_err)?;
        }
        Glyph::Tick(color) => {
            area.draw(&Rectangle::new(
                [(x + 6, y - 2), (x + GLYPH_W - 6, y + 1)],
                color.filled(),
            ))
            .map_err(draw_err)?;
        }
        Glyph::Dashed(color) => {
            for k in 0..3 {
                let x0 = x + 2 + k * 11;
                area.draw(&PathElement::new(
                    vec![(x0, y), (x0 + 7, y)],
                    color.stroke_width(2),
                ))
                .map_err(draw_err)?;
            }
        }
    }
    Ok(())
}
