//! Pictures from snapshots: a filmstrip PNG (the body at [`FILM_TIMES`] simulated times) and
//! an animated GIF per run; for several runs of one scene, a panel PNG (one row per run, the
//! same simulated times in every column, one camera) and a GIF of the runs side by side.
//!
//! Times are fractions of the requested horizon, so columns of different runs show the same
//! simulated time. A run that ended early shows its last valid state from then on, framed in
//! red with the cause written under it, and painted [`FAILED_BODY`] where it has no values to
//! colour by.

use std::path::Path;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::RenderError;
use super::raster::{BODY, Bounds, Camera, Canvas, OBSTACLE, Rgb, j_color};
use super::snapshots::{SnapshotFrame, Snapshots};
use crate::io::write_atomic;

/// Simulated times of a filmstrip: 0, 1/5, ..., 5/5 of the horizon.
pub const FILM_TIMES: usize = 6;
/// Size of one picture of the body (pixels).
pub const CELL: (u32, u32) = (240, 200);
/// Height of the caption band under each picture.
const CAPTION: u32 = 34;
/// Width of the run labels left of a panel's rows.
const LABEL: u32 = 230;
/// Frame colour of a run's last valid state.
const FAILED: Rgb = [200, 30, 30];
/// Body colour of a failed run's last valid state when it has no per-face values to colour
/// by (its det F and energies are not recorded): magenta, which neither the det F scale
/// (blue, white, red, black) nor the energy scale (white, orange, dark red) uses, and which
/// the GIF palette holds exactly. It used to be the plain body colour, a blue that read as
/// "compressed".
pub const FAILED_BODY: Rgb = [204, 51, 204];

/// How the body is coloured.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Coloring {
    /// One colour, flat-shaded.
    #[default]
    Plain,
    /// By det F of the tet under each triangle (blue compressed, red stretched).
    VolumeRatio,
    /// By the elastic energy density of the tet under each triangle: white at 0, dark red at
    /// the largest density over the frames drawn together (a panel or animation shares one
    /// scale: see [`shared_energy_max`]).
    EnergyDensity,
}

/// A labelled run to draw.
pub struct RunPictures<'a> {
    pub label: String,
    pub snapshots: &'a Snapshots,
}

/// The frame of `s` to show at fraction `f` of the horizon: the nearest in time, or the last
/// valid state when the run ended before.
pub fn frame_at(s: &Snapshots, f: f64) -> Option<&SnapshotFrame> {
    let (first, last) = (s.frames.first()?, s.frames.last()?);
    let t = first.t + f * (s.end_time - first.t);
    if last.last_valid && t > last.t {
        return Some(last);
    }
    s.frames
        .iter()
        .min_by(|a, b| (a.t - t).abs().total_cmp(&(b.t - t).abs()))
}

/// A camera framing every state of `runs` that is not a failed run's last state (which may
/// have flown apart), or every state when that leaves none.
pub fn camera_for(runs: &[&Snapshots], width: u32, height: u32) -> Camera {
    let pick = |valid_only: bool| {
        runs.iter()
            .flat_map(|s| s.frames.iter())
            .filter(|f| !(valid_only && f.last_valid))
            .filter_map(|f| Bounds::of(&f.positions))
            .reduce(Bounds::union)
    };
    let bounds = pick(true).or_else(|| pick(false)).unwrap_or(Bounds {
        min: [-1.0; 3],
        max: [1.0; 3],
    });
    let up = runs.first().map_or([0.0, 1.0, 0.0], |s| s.up);
    Camera::framing(&bounds, up, width, height)
}

/// Draws `frame` of `s` (obstacles, then the body) into `canvas`; energy density is scaled
/// to the largest of `s`'s own frames.
pub fn draw_frame(
    canvas: &mut Canvas,
    camera: &Camera,
    s: &Snapshots,
    frame: &SnapshotFrame,
    coloring: Coloring,
) {
    let max_energy = if coloring == Coloring::EnergyDensity {
        max_energy_density(s)
    } else {
        0.0
    };
    draw_frame_scaled(canvas, camera, s, frame, coloring, max_energy);
}

/// [`draw_frame`] with energy density coloured on a scale ending at `max_energy` (J/m³),
/// so that several runs drawn side by side share one scale.
pub fn draw_frame_scaled(
    canvas: &mut Canvas,
    camera: &Camera,
    s: &Snapshots,
    frame: &SnapshotFrame,
    coloring: Coloring,
    max_energy: f32,
) {
    canvas.clear();
    let p = |v: &[f32; 3]| v.map(f64::from);
    for tri in &frame.obstacles {
        canvas.triangle(camera, tri.map(|v| p(&v)), OBSTACLE);
    }
    let n = s.triangles.len();
    let by_j = coloring == Coloring::VolumeRatio && frame.j.len() == n;
    let by_energy = coloring == Coloring::EnergyDensity && frame.energy_density.len() == n;
    for (i, t) in s.triangles.iter().enumerate() {
        let color = if by_j {
            j_color(frame.j[i])
        } else if by_energy {
            super::raster::energy_color(frame.energy_density[i], max_energy)
        } else if frame.last_valid {
            FAILED_BODY
        } else {
            BODY
        };
        canvas.triangle(camera, t.map(|v| p(&frame.positions[v as usize])), color);
    }
    if frame.last_valid {
        canvas.outline(FAILED, 3);
    }
}

/// An RGB picture being composed.
struct Sheet {
    width: u32,
    height: u32,
    rgb: Vec<u8>,
}

impl Sheet {
    fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            rgb: vec![255; 3 * width as usize * height as usize],
        }
    }

    fn paste(&mut self, canvas: &Canvas, x0: u32, y0: u32) {
        let w = canvas.width() as usize;
        for y in 0..canvas.height() as usize {
            let src = &canvas.rgb[3 * y * w..3 * (y + 1) * w];
            let start = 3 * ((y0 as usize + y) * self.width as usize + x0 as usize);
            self.rgb[start..start + 3 * w].copy_from_slice(src);
        }
    }

    /// Writes `lines` (each with its colour) left-aligned or centred in the box at (x, y) of
    /// width `w`; text that does not fit is shortened with an ellipsis.
    fn text(
        &mut self,
        lines: &[(String, Rgb)],
        x: u32,
        y: u32,
        w: u32,
        size: f64,
        centered: bool,
    ) -> Result<(), RenderError> {
        crate::plot::register_fonts().map_err(|e| RenderError::Draw(e.to_string()))?;
        let (width, height) = (self.width, self.height);
        let area = BitMapBackend::with_buffer(&mut self.rgb, (width, height)).into_drawing_area();
        let draw = |e: &dyn std::fmt::Display| RenderError::Draw(e.to_string());
        let mut yy = y as i32;
        for (line, color) in lines {
            let rgb = RGBColor(color[0], color[1], color[2]);
            let style = TextStyle::from(("sans-serif", size).into_font()).color(&rgb);
            let style = if centered {
                style.pos(Pos::new(HPos::Center, VPos::Top))
            } else {
                style.pos(Pos::new(HPos::Left, VPos::Top))
            };
            let fitted = fit(line, w, &style);
            let xx = if centered {
                (x + w / 2) as i32
            } else {
                x as i32
            };
            area.draw_text(&fitted, &style, (xx, yy))
                .map_err(|e| draw(&e))?;
            yy += (size * 1.25).ceil() as i32;
        }
        area.present().map_err(|e| draw(&e))?;
        Ok(())
    }

    fn png(&self, path: &Path) -> Result<(), RenderError> {
        write_png(path, self.width, self.height, &self.rgb)
    }
}

/// `text` shortened with "…" until it fits `w` pixels in `style`.
fn fit(text: &str, w: u32, style: &TextStyle) -> String {
    let fits = |s: &str| crate::plot::text_width(s, style).is_ok_and(|x| x <= w);
    if fits(text) {
        return text.to_owned();
    }
    let chars: Vec<char> = text.chars().collect();
    for n in (1..chars.len()).rev() {
        let s: String = chars[..n].iter().collect::<String>() + "…";
        if fits(&s) {
            return s;
        }
    }
    String::new()
}

/// Writes an RGB image as PNG, atomically.
pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<(), RenderError> {
    use image::ImageEncoder;
    write_atomic(path, |w| {
        image::codecs::png::PngEncoder::new(w)
            .write_image(rgb, width, height, image::ColorType::Rgb8)
            .map_err(std::io::Error::other)
    })
    .map_err(|error| RenderError::Io {
        path: path.to_owned(),
        error,
    })
}

fn caption(frame: &SnapshotFrame) -> (String, Rgb) {
    let text = format!("t = {:.3} s", frame.t);
    if frame.last_valid {
        (format!("{text} (last valid)"), FAILED)
    } else {
        (text, [25, 25, 25])
    }
}

/// The filmstrip of one run: its body at [`FILM_TIMES`] times in a row, each captioned
/// with its simulated time; a failed run's cause is written under the strip.
pub fn filmstrip(path: &Path, s: &Snapshots, coloring: Coloring) -> Result<(), RenderError> {
    panel(
        path,
        &[RunPictures {
            label: String::new(),
            snapshots: s,
        }],
        coloring,
    )
}

/// One row per run, the same simulated times in every column, one camera for all; each row
/// is labelled (left) and a failed run's cause written under its row. With a single unlabelled
/// run this is a filmstrip.
pub fn panel(path: &Path, runs: &[RunPictures], coloring: Coloring) -> Result<(), RenderError> {
    let label_w = if runs.iter().all(|r| r.label.is_empty()) {
        0
    } else {
        LABEL
    };
    let (cw, ch) = CELL;
    let row_h = ch + CAPTION;
    let width = label_w + FILM_TIMES as u32 * cw;
    let height = (runs.len() as u32 * row_h).max(1);
    let mut sheet = Sheet::new(width, height);
    let all: Vec<&Snapshots> = runs.iter().map(|r| r.snapshots).collect();
    let camera = camera_for(&all, cw, ch);
    let max_energy = if coloring == Coloring::EnergyDensity {
        shared_energy_max(runs)
    } else {
        0.0
    };
    let mut canvas = Canvas::new(cw, ch);
    for (r, run) in runs.iter().enumerate() {
        let y0 = r as u32 * row_h;
        for k in 0..FILM_TIMES {
            let f = k as f64 / (FILM_TIMES - 1) as f64;
            let x0 = label_w + k as u32 * cw;
            match frame_at(run.snapshots, f) {
                Some(frame) => {
                    draw_frame_scaled(
                        &mut canvas,
                        &camera,
                        run.snapshots,
                        frame,
                        coloring,
                        max_energy,
                    );
                    sheet.paste(&canvas, x0, y0);
                    sheet.text(&[caption(frame)], x0, y0 + ch, cw, 13.0, true)?;
                }
                None => sheet.text(
                    &[("no snapshots".into(), [110, 110, 110])],
                    x0,
                    y0 + ch / 2,
                    cw,
                    13.0,
                    true,
                )?,
            }
        }
        let mut lines = Vec::new();
        if !run.label.is_empty() {
            lines.push((run.label.clone(), [25, 25, 25]));
        }
        if !run.snapshots.failure.is_empty() {
            lines.push((run.snapshots.failure.clone(), FAILED));
        }
        if label_w > 0 {
            let wrapped: Vec<(String, Rgb)> = lines
                .iter()
                .flat_map(|(l, c)| wrap_words(l, 30).into_iter().map(move |w| (w, *c)))
                .collect();
            sheet.text(&wrapped, 8, y0 + ch / 3, label_w - 12, 14.0, false)?;
        } else if !run.snapshots.failure.is_empty() {
            // A filmstrip has no label column: the cause goes over the last picture's top.
            sheet.text(
                &[(run.snapshots.failure.clone(), FAILED)],
                label_w,
                y0 + 6,
                width,
                13.0,
                true,
            )?;
        }
    }
    sheet.png(path)
}

/// Splits `text` into lines of at most about `n` characters at spaces (or `_`, kept).
fn wrap_words(text: &str, n: usize) -> Vec<String> {
    let mut lines = vec![String::new()];
    for word in text.split_inclusive([' ', '_']) {
        let cur = lines.last_mut().expect("one line");
        if !cur.is_empty() && cur.chars().count() + word.chars().count() > n {
            lines.push(word.to_owned());
        } else {
            cur.push_str(word);
        }
    }
    lines.into_iter().map(|l| l.trim_end().to_owned()).collect()
}

/// Animated GIF of the runs side by side (one run: its animation), one frame per snapshot
/// time ([`super::SAMPLES`]), 1/10 s each, looping; each tile is labelled, and a failed run's
/// tile holds its last valid state in red from its failure on.
pub fn animation(path: &Path, runs: &[RunPictures], coloring: Coloring) -> Result<(), RenderError> {
    let (cw, ch) = CELL;
    let n = runs.len().max(1);
    let cols = (n as f64).sqrt().ceil() as u32;
    let rows = (n as u32).div_ceil(cols);
    let label_h = 20;
    let (tw, th) = (cw, ch + label_h);
    let (width, height) = (cols * tw, rows * th);
    let all: Vec<&Snapshots> = runs.iter().map(|r| r.snapshots).collect();
    let camera = camera_for(&all, cw, ch);
    let max_energy = if coloring == Coloring::EnergyDensity {
        shared_energy_max(runs)
    } else {
        0.0
    };
    let frames = super::SAMPLES;
    let mut canvas = Canvas::new(cw, ch);
    let mut gif_frames = Vec::with_capacity(frames);
    for k in 0..frames {
        let mut sheet = Sheet::new(width, height);
        let f = k as f64 / (frames - 1) as f64;
        let mut time = None;
        for (i, run) in runs.iter().enumerate() {
            let (x0, y0) = ((i as u32 % cols) * tw, (i as u32 / cols) * th);
            if let Some(frame) = frame_at(run.snapshots, f) {
                draw_frame_scaled(
                    &mut canvas,
                    &camera,
                    run.snapshots,
                    frame,
                    coloring,
                    max_energy,
                );
                sheet.paste(&canvas, x0, y0 + label_h);
                if !frame.last_valid {
                    time.get_or_insert(frame.t);
                }
            }
            let mut label = run.label.clone();
            if let Some(t) = frame_at(run.snapshots, f).map(|fr| fr.t) {
                label = if label.is_empty() {
                    format!("t = {t:.3} s")
                } else {
                    format!("{label}  t = {t:.3} s")
                };
            }
            sheet.text(
                &[(label, [25, 25, 25])],
                x0 + 2,
                y0 + 2,
                tw - 4,
                12.0,
                false,
            )?;
        }
        gif_frames.push(sheet.rgb);
    }
    write_gif(path, width, height, &gif_frames, 10)
}

/// The fixed GIF palette: a 6x6x6 colour cube (216) and 40 greys. A fixed palette keeps the
/// encoding fast and deterministic (no per-frame quantization).
fn palette() -> Vec<u8> {
    let mut p = Vec::with_capacity(768);
    for r in 0..6u8 {
        for g in 0..6u8 {
            for b in 0..6u8 {
                p.extend([r * 51, g * 51, b * 51]);
            }
        }
    }
    for i in 0..40u32 {
        let v = (i * 255 / 39) as u8;
        p.extend([v, v, v]);
    }
    p
}

/// The palette index nearest to `rgb`: a grey when the channels are close, else the cube.
fn palette_index(rgb: &[u8]) -> u8 {
    let (r, g, b) = (rgb[0], rgb[1], rgb[2]);
    let (lo, hi) = (r.min(g).min(b), r.max(g).max(b));
    if hi - lo < 12 {
        let v = (u32::from(r) + u32::from(g) + u32::from(b)) / 3;
        216 + ((v * 39 + 127) / 255) as u8
    } else {
        let q = |c: u8| (u32::from(c) * 5 + 127) / 255;
        (36 * q(r) + 6 * q(g) + q(b)) as u8
    }
}

/// Writes an animated, looping GIF of RGB frames (`delay` in 1/100 s), atomically.
pub fn write_gif(
    path: &Path,
    width: u32,
    height: u32,
    frames: &[Vec<u8>],
    delay: u16,
) -> Result<(), RenderError> {
    let too_big = || {
        RenderError::Draw(format!(
            "a GIF is at most 65535 pixels wide and high, not {width}x{height}"
        ))
    };
    let w = u16::try_from(width).map_err(|_| too_big())?;
    let h = u16::try_from(height).map_err(|_| too_big())?;
    let pal = palette();
    write_atomic(path, |out| {
        let mut enc = gif::Encoder::new(out, w, h, &pal).map_err(std::io::Error::other)?;
        enc.set_repeat(gif::Repeat::Infinite)
            .map_err(std::io::Error::other)?;
        for rgb in frames {
            let indices: Vec<u8> = rgb.chunks_exact(3).map(palette_index).collect();
            let mut frame = gif::Frame::from_indexed_pixels(w, h, indices, None);
            frame.delay = delay;
            enc.write_frame(&frame).map_err(std::io::Error::other)?;
        }
        std::io::Write::flush(enc.into_inner().map_err(std::io::Error::other)?)
    })
    .map_err(|error| RenderError::Io {
        path: path.to_owned(),
        error,
    })
}

/// The energy-density scale shared by runs drawn together (J/m³): the largest density of the
/// runs that completed, so one that blew up does not wash out the others (its faces beyond
/// the scale are drawn at its end); of all runs when none completed.
pub fn shared_energy_max(runs: &[RunPictures]) -> f32 {
    let of = |completed: bool| {
        runs.iter()
            .filter(|r| !completed || r.snapshots.failure.is_empty())
            .map(|r| max_energy_density(r.snapshots))
            .fold(0.0, f32::max)
    };
    if runs.iter().any(|r| r.snapshots.failure.is_empty()) {
        of(true)
    } else {
        of(false)
    }
}

/// The largest finite energy density of any frame of `s` (J/m³; 0 without any).
pub fn max_energy_density(s: &Snapshots) -> f32 {
    s.frames
        .iter()
        .flat_map(|f| f.energy_density.iter())
        .copied()
        .filter(|e| e.is_finite())
        .fold(0.0, f32::max)
}
