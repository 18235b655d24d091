//! A small software rasterizer: an orthographic camera and flat-shaded triangles into an RGB
//! image with a z-buffer. Pure Rust, no GPU; deterministic (the same triangles give the same
//! bytes).

use super::snapshots::P3;

/// An RGB colour.
pub type Rgb = [u8; 3];

/// Background of every picture.
pub const BACKGROUND: Rgb = [255, 255, 255];
/// The body's colour when it is not coloured by a field.
pub const BODY: Rgb = [90, 140, 200];
/// Obstacles.
pub const OBSTACLE: Rgb = [175, 175, 170];

/// An orthographic camera looking at a box from a fixed direction: 35° around the up axis
/// from the front (+z when up is +y) towards the right (+x) and 25° above the horizon.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    center: [f64; 3],
    right: [f64; 3],
    up: [f64; 3],
    /// From the eye into the scene.
    forward: [f64; 3],
    /// Pixels per metre.
    scale: f64,
    width: u32,
    height: u32,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn normalized(a: [f64; 3]) -> Option<[f64; 3]> {
    let n = dot(a, a).sqrt();
    (n > 0.0 && n.is_finite()).then(|| a.map(|x| x / n))
}
fn f64s(p: &P3) -> [f64; 3] {
    p.map(f64::from)
}

/// An axis-aligned box (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

impl Bounds {
    /// The box around the finite points of `points`; `None` when there are none.
    pub fn of<'a>(points: impl IntoIterator<Item = &'a P3>) -> Option<Self> {
        let mut b: Option<Self> = None;
        for p in points {
            let p = f64s(p);
            if !p.iter().all(|x| x.is_finite()) {
                continue;
            }
            b = Some(match b {
                None => Self { min: p, max: p },
                Some(b) => Self {
                    min: [0, 1, 2].map(|k| b.min[k].min(p[k])),
                    max: [0, 1, 2].map(|k| b.max[k].max(p[k])),
                },
            });
        }
        b
    }

    /// The smallest box holding both.
    pub fn union(self, o: Self) -> Self {
        Self {
            min: [0, 1, 2].map(|k| self.min[k].min(o.min[k])),
            max: [0, 1, 2].map(|k| self.max[k].max(o.max[k])),
        }
    }

    pub fn center(&self) -> [f64; 3] {
        [0, 1, 2].map(|k| 0.5 * (self.min[k] + self.max[k]))
    }

    /// Length of the diagonal (m).
    pub fn diagonal(&self) -> f64 {
        dot(sub(self.max, self.min), sub(self.max, self.min)).sqrt()
    }

    /// The eight corners.
    pub fn corners(&self) -> [[f64; 3]; 8] {
        std::array::from_fn(|i| {
            [0, 1, 2].map(|k| {
                if i >> k & 1 == 0 {
                    self.min[k]
                } else {
                    self.max[k]
                }
            })
        })
    }
}

impl Camera {
    /// A camera whose `width` x `height` image shows all of `bounds` with a margin of 6 %
    /// on each side, `up` pointing up on screen.
    pub fn framing(bounds: &Bounds, up: P3, width: u32, height: u32) -> Self {
        let up = normalized(f64s(&up)).unwrap_or([0.0, 1.0, 0.0]);
        // Any direction not parallel to up gives the horizontal reference.
        // (With up = +y the front is +z and the side +x: the eye is in front, to the right.)
        let seed = if up[2].abs() < 0.9 {
            [0.0, 0.0, 1.0]
        } else {
            [1.0, 0.0, 0.0]
        };
        let side = normalized(cross(up, seed)).expect("seed not parallel to up");
        let front = cross(side, up);
        let (az, el) = (35f64.to_radians(), 25f64.to_radians());
        // The eye sits at `eye_dir` from the centre; the camera looks along its opposite.
        let horizontal = [0, 1, 2].map(|k| az.cos() * front[k] + az.sin() * side[k]);
        let eye_dir = [0, 1, 2].map(|k| el.cos() * horizontal[k] + el.sin() * up[k]);
        let forward = eye_dir.map(|x| -x);
        let right = normalized(cross(forward, up)).expect("elevation below 90 degrees");
        let screen_up = cross(right, forward);
        let center = bounds.center();
        let (mut w, mut h) = (0f64, 0f64);
        for c in bounds.corners() {
            let d = sub(c, center);
            w = w.max(dot(d, right).abs());
            h = h.max(dot(d, screen_up).abs());
        }
        let usable = |pixels: u32| f64::from(pixels) * 0.5 * 0.88;
        let scale = [usable(width) / w, usable(height) / h]
            .into_iter()
            .filter(|s| s.is_finite() && *s > 0.0)
            .fold(f64::INFINITY, f64::min);
        let scale = if scale.is_finite() { scale } else { 1.0 };
        Self {
            center,
            right,
            up: screen_up,
            forward,
            scale,
            width,
            height,
        }
    }

    /// The pixel position (x right, y down, pixel centres at +0.5) and depth of `p`.
    pub fn project(&self, p: [f64; 3]) -> [f64; 3] {
        let d = sub(p, self.center);
        [
            f64::from(self.width) * 0.5 + self.scale * dot(d, self.right),
            f64::from(self.height) * 0.5 - self.scale * dot(d, self.up),
            dot(d, self.forward),
        ]
    }

    /// Unit vector towards the light: from behind the eye's left shoulder and above, so
    /// faces turned up and left read brighter.
    pub fn toward_light(&self) -> [f64; 3] {
        let d = [0, 1, 2].map(|k| -self.forward[k] + 0.5 * self.up[k] - 0.3 * self.right[k]);
        normalized(d).expect("a non-zero light direction")
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }
}

/// An RGB image with a depth buffer.
#[derive(Clone, Debug)]
pub struct Canvas {
    width: u32,
    height: u32,
    /// RGB bytes, row-major from the top-left.
    pub rgb: Vec<u8>,
    depth: Vec<f32>,
}

impl Canvas {
    /// A blank canvas of `BACKGROUND`.
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Self {
            width,
            height,
            rgb: BACKGROUND.repeat(n),
            depth: vec![f32::INFINITY; n],
        }
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    /// Clears colour and depth.
    pub fn clear(&mut self) {
        for px in self.rgb.chunks_exact_mut(3) {
            px.copy_from_slice(&BACKGROUND);
        }
        self.depth.fill(f32::INFINITY);
    }

    /// The colour at pixel (x, y).
    pub fn pixel(&self, x: u32, y: u32) -> Rgb {
        let i = 3 * (y as usize * self.width as usize + x as usize);
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }

    /// Draws triangle `[a, b, c]` flat-shaded in `color`, lit from behind the eye (two-sided, so an
    /// inverted or open surface still reads). Triangles with a non-finite corner are skipped.
    pub fn triangle(&mut self, camera: &Camera, corners: [[f64; 3]; 3], color: Rgb) {
        let [a, b, c] = corners;
        let Some(n) = normalized(cross(sub(b, a), sub(c, a))) else {
            return;
        };
        let light = dot(n, camera.toward_light()).abs();
        let shade = 0.45 + 0.55 * light;
        let rgb = color.map(|c| (f64::from(c) * shade).round().clamp(0.0, 255.0) as u8);
        let p = corners.map(|q| camera.project(q));
        if p.iter().flatten().any(|x| !x.is_finite()) {
            return;
        }
        self.fill(p, rgb);
    }

    /// Scan-converts the projected triangle `p` (pixel x, y, depth) with a depth test:
    /// a pixel is covered when its centre lies inside (top-left rule not needed for flat
    /// colours; shared edges are drawn by both triangles).
    fn fill(&mut self, p: [[f64; 3]; 3], rgb: Rgb) {
        let area =
            (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]);
        if area == 0.0 {
            return;
        }
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        let lo = |k: usize, max: f64| {
            p.iter()
                .map(|q| q[k])
                .fold(f64::INFINITY, f64::min)
                .floor()
                .clamp(0.0, max) as u32
        };
        let hi = |k: usize, max: f64| {
            p.iter()
                .map(|q| q[k])
                .fold(f64::NEG_INFINITY, f64::max)
                .ceil()
                .clamp(0.0, max) as u32
        };
        let (x0, x1, y0, y1) = (lo(0, w), hi(0, w), lo(1, h), hi(1, h));
        let edge = |a: [f64; 3], b: [f64; 3], x: f64, y: f64| {
            (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0])
        };
        let inv = 1.0 / area;
        for y in y0..y1 {
            let py = f64::from(y) + 0.5;
            let row = y as usize * self.width as usize;
            for x in x0..x1 {
                let px = f64::from(x) + 0.5;
                let w0 = edge(p[1], p[2], px, py) * inv;
                let w1 = edge(p[2], p[0], px, py) * inv;
                let w2 = 1.0 - w0 - w1;
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let z = (w0 * p[0][2] + w1 * p[1][2] + w2 * p[2][2]) as f32;
                let i = row + x as usize;
                if z < self.depth[i] {
                    self.depth[i] = z;
                    self.rgb[3 * i..3 * i + 3].copy_from_slice(&rgb);
                }
            }
        }
    }

    /// Draws a rectangle outline `thickness` pixels wide (clipped to the canvas).
    pub fn outline(&mut self, color: Rgb, thickness: u32) {
        let (w, h) = (self.width, self.height);
        for y in 0..h {
            for x in 0..w {
                if x < thickness || y < thickness || x + thickness >= w || y + thickness >= h {
                    let i = 3 * (y as usize * w as usize + x as usize);
                    self.rgb[i..i + 3].copy_from_slice(&color);
                }
            }
        }
    }
}

/// Colour of a volume ratio `j` = det F: blue when compressed, white at rest volume, red
/// when stretched, saturating at J = 0.7 and 1.3; inverted elements (J <= 0) are black.
pub fn j_color(j: f32) -> Rgb {
    j_color_of(j)
}

/// The colour of elastic energy density `psi` on a scale that ends at `max` (J/m³): white at
/// 0 through orange to dark red at `max`; black where it is undefined (NaN: an inverted tet
/// of a material without a value there). Every face is white when `max` is 0 (a body at rest).
pub fn energy_color(psi: f32, max: f32) -> Rgb {
    if !psi.is_finite() {
        return [20, 20, 20];
    }
    let s = if max > 0.0 {
        (psi / max).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let mix = |a: Rgb, b: Rgb, t: f32| -> Rgb {
        [0, 1, 2].map(|k| (f32::from(a[k]) + (f32::from(b[k]) - f32::from(a[k])) * t).round() as u8)
    };
    let (white, orange, red) = ([235, 235, 235], [240, 150, 40], [150, 20, 20]);
    if s < 0.5 {
        mix(white, orange, 2.0 * s)
    } else {
        mix(orange, red, 2.0 * s - 1.0)
    }
}

fn j_color_of(j: f32) -> Rgb {
    if !j.is_finite() || j <= 0.0 {
        return [20, 20, 20];
    }
    let s = ((j - 1.0) / 0.3).clamp(-1.0, 1.0);
    let mix = |a: Rgb, b: Rgb, t: f32| -> Rgb {
        [0, 1, 2].map(|k| (f32::from(a[k]) + (f32::from(b[k]) - f32::from(a[k])) * t).round() as u8)
    };
    let white = [235, 235, 235];
    if s < 0.0 {
        mix(white, [40, 90, 200], -s)
    } else {
        mix(white, [200, 50, 40], s)
    }
}
