//! Where a chart puts its text: a drawing backend that draws nothing and records the box of
//! every text it is given, placed exactly as the bitmap backend places it (plotters' default
//! text drawing: layout box, anchor, then rotation). Used to check that no label leaves the
//! image.

use plotters::prelude::*;
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingErrorKind, text_anchor,
};
use std::cell::RefCell;
use std::rc::Rc;

/// A text and the pixels it covers: `[left, top, right, bottom]` (right and bottom exclusive).
#[derive(Clone, Debug, PartialEq)]
pub struct TextBox {
    pub text: String,
    pub rect: [i32; 4],
}

/// The recording backend.
pub(super) struct TextRecorder {
    size: (u32, u32),
    /// Shared with the caller: the drawing area owns the backend.
    boxes: Rc<RefCell<Vec<TextBox>>>,
}

impl TextRecorder {
    pub fn new(size: (u32, u32), boxes: Rc<RefCell<Vec<TextBox>>>) -> Self {
        Self { size, boxes }
    }
}

#[derive(Debug)]
pub(super) struct NoError;

impl std::fmt::Display for NoError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("no error")
    }
}

impl std::error::Error for NoError {}

impl DrawingBackend for TextRecorder {
    type ErrorType = NoError;

    fn get_size(&self) -> (u32, u32) {
        self.size
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<NoError>> {
        Ok(())
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<NoError>> {
        Ok(())
    }

    fn draw_pixel(
        &mut self,
        _: BackendCoord,
        _: BackendColor,
    ) -> Result<(), DrawingErrorKind<NoError>> {
        Ok(())
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        _: BackendCoord,
        _: BackendCoord,
        _: &S,
    ) -> Result<(), DrawingErrorKind<NoError>> {
        Ok(())
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        _: BackendCoord,
        _: BackendCoord,
        _: &S,
        _: bool,
    ) -> Result<(), DrawingErrorKind<NoError>> {
        Ok(())
    }

    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<NoError>> {
        if text.trim().is_empty() || style.color().alpha == 0.0 {
            return Ok(());
        }
        let ((min_x, min_y), (max_x, max_y)) = style
            .layout_box(text)
            .map_err(|e| DrawingErrorKind::FontError(Box::new(e)))?;
        let (width, height) = (max_x - min_x, max_y - min_y);
        let dx = match style.anchor().h_pos {
            text_anchor::HPos::Left => 0,
            text_anchor::HPos::Right => -width,
            text_anchor::HPos::Center => -width / 2,
        };
        let dy = match style.anchor().v_pos {
            text_anchor::VPos::Top => 0,
            text_anchor::VPos::Center => -height / 2,
            text_anchor::VPos::Bottom => -height,
        };
        let t = style.transform();
        let corners = [(0, 0), (width, 0), (0, height), (width, height)]
            .map(|(x, y)| t.transform(x + dx, y + dy))
            .map(|(x, y)| (pos.0 + x, pos.1 + y));
        let xs = corners.map(|c| c.0);
        let ys = corners.map(|c| c.1);
        self.boxes.borrow_mut().push(TextBox {
            text: text.to_owned(),
            rect: [
                *xs.iter().min().expect("four corners"),
                *ys.iter().min().expect("four corners"),
                *xs.iter().max().expect("four corners"),
                *ys.iter().max().expect("four corners"),
            ],
        });
        Ok(())
    }
}
