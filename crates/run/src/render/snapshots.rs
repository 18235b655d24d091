//! Snapshots of a run: the body's surface at a few simulated times, compact on disk, so
//! pictures can be drawn (and redrawn) after the run without the scene.
//!
//! On disk (`<run>.snapshots`, written atomically) a snapshot file is gzip-compressed
//! little-endian binary:
//!
//! ```text
//! "SBSNAP01"                                  magic, 8 bytes
//! u32 vertices V, u32 triangles T, u32 frames F
//! f32 x3 up                                   the scene's up direction (against gravity)
//! f64 end time                                the requested horizon's end (s)
//! u32 x3 per triangle                         surface triangles, wound outward
//! per frame:
//!   f64 t, u64 step, u8 flags                 flags bit 0: J present; bit 1: last valid state;
//!                                             bit 2: energy density present
//!   f32 x3 per vertex                         surface positions (m)
//!   f32 per triangle (if J present)           det F of the tet that owns the triangle
//!   f32 per triangle (if flags bit 2)         its elastic energy density (J/m³)
//!   u32 obstacle triangles O, f32 x9 each     the obstacles at time t, tessellated
//! u32 length, UTF-8 bytes                     why the run ended early ("" if it completed)
//! ```
//!
//! f32 is enough for a picture and halves the file; a 31-frame run of a 1,000-vertex surface
//! takes about 200 kB before compression.

use std::io::{self, Read, Write};
use std::path::Path;

use flate2::Compression;
use flate2::read::GzDecoder;
use flate2::write::GzEncoder;

use super::RenderError;
use crate::io::write_atomic;

const MAGIC: &[u8; 8] = b"SBSNAP01";
const HAS_J: u8 = 1;
const LAST_VALID: u8 = 2;
const HAS_ENERGY: u8 = 4;

/// A point in f32 (m): enough precision for drawing.
pub type P3 = [f32; 3];

/// The body at one simulated time.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SnapshotFrame {
    /// Simulated time (s).
    pub t: f64,
    /// Steps taken.
    pub step: u64,
    /// Surface vertex positions (m).
    pub positions: Vec<P3>,
    /// det F of the tet owning each surface triangle (empty when not known: a skinned display
    /// mesh, a spring body, or the last valid state of a failed run).
    pub j: Vec<f32>,
    /// Elastic energy density ψ (J/m³: the tet's energy over its rest volume) of the tet
    /// owning each triangle; empty when not known, as `j`.
    pub energy_density: Vec<f32>,
    /// The obstacles at `t`, as triangles (m).
    pub obstacles: Vec<[P3; 3]>,
    /// This frame is the last valid state of a run that ended early.
    pub last_valid: bool,
}

/// A run's snapshots: one surface, several frames, and why the run ended early (if it did).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Snapshots {
    /// The scene's up direction (unit; against gravity, +y without gravity).
    pub up: P3,
    /// When the run was to end: its start plus the requested steps times dt (s). Pictures
    /// are taken at fractions of the horizon, so runs of one scene line up.
    pub end_time: f64,
    /// Surface triangles over the frame's vertices, wound outward.
    pub triangles: Vec<[u32; 3]>,
    /// Frames in time order.
    pub frames: Vec<SnapshotFrame>,
    /// Why the run ended early (outcome and cause), empty when it completed.
    pub failure: String,
}

impl Snapshots {
    /// Number of surface vertices.
    pub fn num_vertices(&self) -> usize {
        self.frames.first().map_or(0, |f| f.positions.len())
    }

    /// Writes the file atomically (see the module docs for the layout).
    pub fn write(&self, path: &Path) -> Result<(), RenderError> {
        write_atomic(path, |w| {
            let mut gz = GzEncoder::new(w, Compression::fast());
            self.encode(&mut gz)?;
            gz.finish()?.flush()
        })
        .map_err(|error| RenderError::Io {
            path: path.to_owned(),
            error,
        })
    }

    fn encode(&self, w: &mut dyn Write) -> io::Result<()> {
        let nv = self.num_vertices();
        w.write_all(MAGIC)?;
        for n in [nv, self.triangles.len(), self.frames.len()] {
            w.write_all(&u32::try_from(n).map_err(io::Error::other)?.to_le_bytes())?;
        }
        write_f32s(w, &self.up)?;
        w.write_all(&self.end_time.to_le_bytes())?;
        for t in &self.triangles {
            for i in t {
                w.write_all(&i.to_le_bytes())?;
            }
        }
        for f in &self.frames {
            let sized = |v: &Vec<f32>| v.is_empty() || v.len() == self.triangles.len();
            if f.positions.len() != nv || !sized(&f.j) || !sized(&f.energy_density) {
                return Err(io::Error::other("snapshot frames of different sizes"));
            }
            w.write_all(&f.t.to_le_bytes())?;
            w.write_all(&f.step.to_le_bytes())?;
            let flags = if f.j.is_empty() { 0 } else { HAS_J }
                | if f.last_valid { LAST_VALID } else { 0 }
                | if f.energy_density.is_empty() {
                    0
                } else {
                    HAS_ENERGY
                };
            w.write_all(&[flags])?;
            for p in &f.positions {
                write_f32s(w, p)?;
            }
            write_f32s(w, &f.j)?;
            write_f32s(w, &f.energy_density)?;
            let o = u32::try_from(f.obstacles.len()).map_err(io::Error::other)?;
            w.write_all(&o.to_le_bytes())?;
            for tri in &f.obstacles {
                for p in tri {
                    write_f32s(w, p)?;
                }
            }
        }
        let note = self.failure.as_bytes();
        w.write_all(
            &u32::try_from(note.len())
                .map_err(io::Error::other)?
                .to_le_bytes(),
        )?;
        w.write_all(note)
    }

    /// Reads a snapshot file. A truncated or foreign file is an error naming the file.
    pub fn read(path: &Path) -> Result<Self, RenderError> {
        let file = std::fs::File::open(path).map_err(|error| RenderError::Io {
            path: path.to_owned(),
            error,
        })?;
        let len = file.metadata().map(|m| m.len()).unwrap_or(0);
        let mut r = Reader {
            inner: GzDecoder::new(io::BufReader::new(file)),
            // A gzip stream of floats rarely compresses below 1/50; the cap only keeps a
            // corrupt count from allocating without bound.
            budget: len.saturating_mul(64).max(1 << 20),
        };
        let bad = |why: String| RenderError::Snapshot {
            path: path.to_owned(),
            why,
        };
        Self::decode(&mut r).map_err(|e| bad(e.to_string()))
    }

    fn decode(r: &mut Reader<impl Read>) -> io::Result<Self> {
        let mut magic = [0u8; 8];
        r.inner.read_exact(&mut magic)?;
        if &magic != MAGIC {
            return Err(io::Error::other(
                "not a softbench snapshot file (bad magic)",
            ));
        }
        let nv = r.u32()? as usize;
        let nt = r.u32()? as usize;
        let nf = r.u32()? as usize;
        r.charge((nv * 12 + nt * 4).saturating_mul(nf.max(1)) + nt * 12)?;
        let up = r.p3()?;
        let end_time = f64::from_le_bytes(r.bytes()?);
        let mut triangles = Vec::with_capacity(nt);
        for _ in 0..nt {
            let t = [r.u32()?, r.u32()?, r.u32()?];
            if t.iter().any(|&i| i as usize >= nv) {
                return Err(io::Error::other(format!(
                    "triangle {t:?} refers past the {nv} vertices"
                )));
            }
            triangles.push(t);
        }
        let mut frames = Vec::with_capacity(nf);
        for _ in 0..nf {
            let t = f64::from_le_bytes(r.bytes()?);
            let step = u64::from_le_bytes(r.bytes()?);
            let [flags] = r.bytes::<1>()?;
            let positions = (0..nv).map(|_| r.p3()).collect::<io::Result<_>>()?;
            let j = if flags & HAS_J != 0 {
                (0..nt).map(|_| r.f32()).collect::<io::Result<_>>()?
            } else {
                Vec::new()
            };
            let energy_density = if flags & HAS_ENERGY != 0 {
                (0..nt).map(|_| r.f32()).collect::<io::Result<_>>()?
            } else {
                Vec::new()
            };
            let no = r.u32()? as usize;
            r.charge(no * 36)?;
            let mut obstacles = Vec::with_capacity(no);
            for _ in 0..no {
                obstacles.push([r.p3()?, r.p3()?, r.p3()?]);
            }
            frames.push(SnapshotFrame {
                t,
                step,
                positions,
                j,
                energy_density,
                obstacles,
                last_valid: flags & LAST_VALID != 0,
            });
        }
        let n = r.u32()? as usize;
        r.charge(n)?;
        let mut note = vec![0u8; n];
        r.inner.read_exact(&mut note)?;
        let failure = String::from_utf8(note).map_err(io::Error::other)?;
        Ok(Self {
            up,
            end_time,
            triangles,
            frames,
            failure,
        })
    }
}

fn write_f32s(w: &mut dyn Write, v: &[f32]) -> io::Result<()> {
    for x in v {
        w.write_all(&x.to_le_bytes())?;
    }
    Ok(())
}

/// A byte reader that refuses counts larger than the file could hold.
struct Reader<R> {
    inner: R,
    budget: u64,
}

impl<R: Read> Reader<R> {
    fn charge(&mut self, n: usize) -> io::Result<()> {
        if n as u64 > self.budget {
            return Err(io::Error::other("counts larger than the file can hold"));
        }
        self.budget -= n as u64;
        Ok(())
    }
    fn bytes<const N: usize>(&mut self) -> io::Result<[u8; N]> {
        let mut b = [0u8; N];
        self.inner.read_exact(&mut b)?;
        Ok(b)
    }
    fn u32(&mut self) -> io::Result<u32> {
        Ok(u32::from_le_bytes(self.bytes()?))
    }
    fn f32(&mut self) -> io::Result<f32> {
        Ok(f32::from_le_bytes(self.bytes()?))
    }
    fn p3(&mut self) -> io::Result<P3> {
        Ok([self.f32()?, self.f32()?, self.f32()?])
    }
}
