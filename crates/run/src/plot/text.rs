//! Measuring, wrapping and shortening text so long labels fit where they are drawn.
//!
//! Sizes come from the embedded font's metrics, the same for the PNG and the SVG, so both
//! images get the same layout.

use plotters::style::TextStyle;

use super::PlotError;

/// Width and height in pixels of `text` drawn in `style` (unrotated).
pub fn size(text: &str, style: &TextStyle) -> Result<(u32, u32), PlotError> {
    let ((x0, y0), (x1, y1)) = style
        .font
        .layout_box(text)
        .map_err(|e| PlotError::Draw(format!("cannot lay out {text:?}: {e}")))?;
    Ok(((x1 - x0).unsigned_abs(), (y1 - y0).unsigned_abs()))
}

/// Width in pixels of `text` drawn in `style`.
pub fn width(text: &str, style: &TextStyle) -> Result<u32, PlotError> {
    Ok(size(text, style)?.0)
}

/// Line height in pixels for `style`, with a little leading.
pub fn line_height(style: &TextStyle) -> Result<u32, PlotError> {
    let (_, h) = size("Ag", style)?;
    Ok(h + h / 4 + 1)
}

/// Split `text` into pieces that each end at a break opportunity: after a space, `/` or `-`.
/// Not after `_`: it joins the parts of one name (`dt_max`), which a break would cut in two.
/// Concatenated, the pieces give back `text`.
fn pieces(text: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut start = 0;
    for (i, ch) in text.char_indices() {
        if matches!(ch, ' ' | '/' | '-') {
            let end = i + ch.len_utf8();
            out.push(&text[start..end]);
            start = end;
        }
    }
    if start < text.len() {
        out.push(&text[start..]);
    }
    out
}

/// Width in pixels of the widest word of `text` (the pieces between break opportunities).
pub fn longest_word(text: &str, style: &TextStyle) -> Result<u32, PlotError> {
    let mut widest = 0;
    for piece in pieces(text) {
        widest = widest.max(width(piece.trim(), style)?);
    }
    Ok(widest)
}

/// Whether every word of `text` (the pieces between break opportunities) fits `max_width`,
/// so [`wrap`] need not cut inside a word.
pub fn words_fit(text: &str, max_width: u32, style: &TextStyle) -> Result<bool, PlotError> {
    for piece in pieces(text) {
        if width(piece.trim(), style)? > max_width {
            return Ok(false);
        }
    }
    Ok(true)
}

/// Greedy line wrapping of `text` at break opportunities so each line is at most `max_width`
/// pixels wide. A piece wider than `max_width` on its own is cut between characters.
pub fn wrap(text: &str, max_width: u32, style: &TextStyle) -> Result<Vec<String>, PlotError> {
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for piece in pieces(text) {
        let candidate = format!("{line}{piece}");
        if width(candidate.trim_end(), style)? <= max_width {
            line = candidate;
            continue;
        }
        if !line.trim().is_empty() {
            lines.push(line.trim_end().to_owned());
        }
        line = String::new();
        for ch in piece.chars() {
            let mut candidate = line.clone();
            candidate.push(ch);
            if !line.is_empty() && width(candidate.trim_end(), style)? > max_width {
                lines.push(line.trim_end().to_owned());
                line = ch.to_string();
            } else {
                line = candidate;
            }
        }
    }
    if !line.trim().is_empty() || lines.is_empty() {
        lines.push(line.trim_end().to_owned());
    }
    Ok(lines
        .into_iter()
        .map(|l| l.trim_start().to_owned())
        .collect())
}

/// Keep at most `max_lines` of `lines`; if some were dropped, the last kept line ends in "…"
/// and still fits `max_width`.
pub fn clamp_lines(
    mut lines: Vec<String>,
    max_lines: usize,
    max_width: u32,
    style: &TextStyle,
) -> Result<Vec<String>, PlotError> {
    let max_lines = max_lines.max(1);
    if lines.len() <= max_lines {
        return Ok(lines);
    }
    lines.truncate(max_lines);
    let last = lines.last_mut().expect("at least one line");
    loop {
        let candidate = format!("{}…", last.trim_end());
        if width(&candidate, style)? <= max_width || last.is_empty() {
            *last = candidate;
            break;
        }
        last.pop();
    }
    Ok(lines)
}

#[cfg(test)]
mod tests {
    use super::pieces;

    #[test]
    fn pieces_rebuild_the_text_and_break_after_separators() {
        let text = "linearly-implicit-euler / cholesky";
        let p = pieces(text);
        assert_eq!(p.concat(), text);
        assert_eq!(
            p,
            ["linearly-", "implicit-", "euler ", "/", " ", "cholesky"]
        );
    }
}
