//! Category labels under a bar chart: wrapped horizontally when every word fits its slot,
//! otherwise rotated to read bottom-to-top (up to as many lines as the slot is wide).

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::frame::Frame;
use super::style::{self, INK, MUTED};
use super::{PlotError, draw_err, text};

/// Gap between the axis and the labels, in pixels.
const GAP: i32 = 10;
/// Most lines of a horizontal label.
const MAX_LINES: usize = 3;
/// Longest rotated label line, in percent of the image height.
const MAX_ROTATED: u32 = 45;

/// The frame of a chart with one slot per category: the y axis, `names.len()` slots, and the
/// category labels laid out (not yet drawn) under them.
pub fn slot_frame<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    names: &[&str],
    y: super::axis::Axis,
    y_label: &str,
) -> Result<(Frame<'a, DB>, Labels, super::frame::Layout), PlotError> {
    let mut layout = super::frame::Layout::numeric(&y, None, "")?;
    let slot_w = layout.plot_width(area.dim_in_pixel().0) / names.len().max(1) as u32;
    let labels = Labels::new(names, slot_w, style::HEIGHT * 3 / 10)?;
    layout.bottom = labels.height;
    let frame = Frame::draw(
        area,
        super::axis::Axis::slots(names.len()),
        y,
        ("", y_label),
        layout,
        false,
    )?;
    Ok((frame, labels, layout))
}

/// Category labels laid out for slots of a given width.
pub struct Labels {
    lines: Vec<Vec<String>>,
    rotated: bool,
    line_h: i32,
    /// Height in pixels the labels need under the axis.
    pub height: u32,
    /// Width of a slot in pixels.
    pub slot_w: u32,
}

impl Labels {
    /// Lay out `labels` for slots `slot_w` pixels wide, rotated labels at most `max_len` long.
    pub fn new(labels: &[&str], slot_w: u32, max_len: u32) -> Result<Self, PlotError> {
        let style = style::text(style::size::CATEGORY, &INK);
        let line_h = text::line_height(&style)?;
        let room = slot_w.saturating_sub(8).max(1);
        let mut horizontal = Vec::new();
        let mut fits = true;
        for &l in labels {
            let lines = text::wrap(l, room, &style)?;
            fits &= lines.len() <= MAX_LINES && text::words_fit(l, room, &style)?;
            horizontal.push(lines);
        }
        if fits {
            let n = horizontal.iter().map(Vec::len).max().unwrap_or(1) as u32;
            return Ok(Self {
                lines: horizontal,
                rotated: false,
                line_h: line_h as i32,
                slot_w,
                height: GAP as u32 + n * line_h,
            });
        }
        let per_slot = ((slot_w * 9 / 10) / line_h).max(1) as usize;
        // Rotated lines are as long as the longest word, up to `MAX_ROTATED` of the image
        // height, so a word is cut between characters only when even that cannot hold it.
        let mut max_len = max_len;
        for &l in labels {
            max_len = max_len.max(text::longest_word(l, &style)?);
        }
        let max_len = max_len.min(style::HEIGHT * MAX_ROTATED / 100);
        let mut lines = Vec::new();
        let mut longest = 0;
        for &l in labels {
            let wrapped = text::wrap(l, max_len, &style)?;
            let kept = text::clamp_lines(wrapped, per_slot, max_len, &style)?;
            for k in &kept {
                longest = longest.max(text::width(k, &style)?);
            }
            lines.push(kept);
        }
        Ok(Self {
            lines,
            rotated: true,
            line_h: line_h as i32,
            slot_w,
            height: GAP as u32 + longest + 4,
        })
    }

    /// Draw the labels under the plotting area of `frame`, label `i` centred on slot `i`.
    pub fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        frame: &Frame<DB>,
    ) -> Result<(), PlotError> {
        let (_, _, _, bottom) = frame.rect();
        let base = style::text(style::size::CATEGORY, &INK);
        for (i, lines) in self.lines.iter().enumerate() {
            let (cx, _) = frame.px(i as f64, frame.y.range.start);
            let k = lines.len() as i32;
            for (j, line) in lines.iter().enumerate() {
                let j = j as i32;
                if self.rotated {
                    let style = base
                        .transform(FontTransform::Rotate270)
                        .pos(Pos::new(HPos::Right, VPos::Center));
                    let x = cx + (2 * j - (k - 1)) * self.line_h / 2;
                    root.draw_text(line, &style, (x, bottom + GAP))
                        .map_err(draw_err)?;
                } else {
                    let style = base.pos(Pos::new(HPos::Center, VPos::Top));
                    root.draw_text(line, &style, (cx, bottom + GAP + j * self.line_h))
                        .map_err(draw_err)?;
                }
            }
        }
        Ok(())
    }
}

/// Draw `note` in slot `i` of `frame` in place of a missing bar: horizontal just above the
/// axis if it fits the slot, otherwise rotated, reading upward from the axis.
pub fn draw_note<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    frame: &Frame<DB>,
    i: usize,
    slot_w: u32,
    note: &str,
) -> Result<(), PlotError> {
    let style = style::text(style::size::NOTE, &MUTED);
    let line_h = text::line_height(&style)? as i32;
    let (_, top, _, bottom) = frame.rect();
    let (cx, _) = frame.px(i as f64, frame.y.range.start);
    let room = slot_w.saturating_sub(6);
    if text::width(note, &style)? <= room {
        let s = style.pos(Pos::new(HPos::Center, VPos::Bottom));
        return root.draw_text(note, &s, (cx, bottom - 6)).map_err(draw_err);
    }
    let max_len = ((bottom - top) as u32 * 2 / 3).max(20);
    let per_slot = ((slot_w * 9 / 10) as i32 / line_h).max(1) as usize;
    let lines = text::clamp_lines(
        text::wrap(note, max_len, &style)?,
        per_slot,
        max_len,
        &style,
    )?;
    let k = lines.len() as i32;
    let s = style
        .transform(FontTransform::Rotate270)
        .pos(Pos::new(HPos::Left, VPos::Center));
    for (j, line) in lines.iter().enumerate() {
        let x = cx + (2 * j as i32 - (k - 1)) * line_h / 2;
        root.draw_text(line, &s, (x, bottom - 6))
            .map_err(draw_err)?;
    }
    Ok(())
}
