//! Frames of a run: an [`Observer`] that passes rows on to another observer and, at step 0,
//! every `every` steps and the last step, writes the state as a numbered file
//! `frame_<step>.vtu` or `frame_<step>.obj` (the number is the step, zero-padded to at least
//! five digits), plus `series.pvd` listing the VTU frames with their times. Every file is
//! written atomically; `series.pvd` is rewritten after each VTU frame, so a killed run leaves
//! a collection of the frames it finished.
//!
//! Nothing is computed for frames unless a [`FrameWriter`] is built: surface extraction and
//! skinning happen in the [`FrameContent`] constructors.

use std::io;
use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use super::obj::write_obj;
use super::pvd::write_pvd;
use super::vtu::{VtuGrid, write_vtu};
use crate::io::write_atomic;
use crate::run::{Observer, Sample};
use softbench_core::integrate::State;
use softbench_core::mesh::Skinning;
use softbench_core::mesh::surface::boundary_faces;
use softbench_core::model::Model;

/// The name of the VTU collection in the frames folder.
pub const SERIES_FILE: &str = "series.pvd";

softbench_core::named_enum! {
    /// A frame file format (`--export`); the name is also the file extension.
    pub enum ExportFormat: "export format", UnknownExportFormat {
        /// VTK XML unstructured grid of the tets, with a `series.pvd`.
        Vtu = "vtu", "VTK XML unstructured grid of the tets per frame, with a series.pvd",
        /// Wavefront OBJ triangle surface (boundary surface or skinned display mesh).
        Obj = "obj", "Wavefront OBJ surface per frame (boundary surface or skinned [display] mesh)",
    }
}

impl ExportFormat {
    /// The format called `name`.
    pub fn from_name(name: &str) -> Result<Self, UnknownExportFormat> {
        name.parse()
    }
}

/// What each frame holds; build it once before the run.
#[derive(Debug)]
pub enum FrameContent {
    /// A VTU grid of tets.
    Tets(TetFrames),
    /// An OBJ triangle surface.
    Surface(SurfaceFrames),
}

/// VTU frames: the tets at the current positions, with point data `velocity` (m/s, zero at
/// fixed vertices) and `displacement` (m, from rest), and cell data `J` (det F), and when the
/// model has an elastic material `energy` (J, volume * psi) and `energy_density` (psi, J/m^3).
#[derive(Debug)]
pub struct TetFrames {
    tets: Vec<[usize; 4]>,
    /// Whether `tets` are the model's elastic tets (so it can give J and energies).
    from_model: bool,
    rest_volumes6: Vec<f64>,
    det_f: Vec<f64>,
    energy: Vec<f64>,
    energy_density: Vec<f64>,
    velocity: Vec<Vector3<f64>>,
    displacement: Vec<Vector3<f64>>,
}

/// OBJ frames: a triangle surface following the simulated vertices.
#[derive(Debug)]
pub struct SurfaceFrames {
    source: SurfaceSource,
    triangles: Vec<[usize; 3]>,
    positions: Vec<Vector3<f64>>,
    description: String,
}

#[derive(Debug)]
enum SurfaceSource {
    /// The listed simulation vertices (the boundary's, in increasing order).
    Vertices(Vec<usize>),
    /// A skinned display mesh.
    Skinned(Skinning),
}

impl FrameContent {
    /// VTU frames of `tets` (indices into the model's vertices). When `tets` are the model's
    /// elastic tets ([`Model::tets`]), `J` and the energies come from
    /// [`Model::element_measures`]; otherwise (a body without an elastic material) `J` is the
    /// ratio of current to rest volume and no energy arrays are written.
    pub fn tets(model: &Model, tets: Vec<[usize; 4]>) -> Self {
        let rest = model.rest_positions();
        let from_model = model.tets() == tets.as_slice();
        let rest_volumes6 = tets.iter().map(|t| volume6(rest, t)).collect();
        let m = tets.len();
        let energies = if from_model { m } else { 0 };
        Self::Tets(TetFrames {
            tets,
            from_model,
            rest_volumes6,
            det_f: vec![0.0; m],
            energy: vec![0.0; energies],
            energy_density: vec![0.0; energies],
            velocity: vec![Vector3::zeros(); rest.len()],
            displacement: vec![Vector3::zeros(); rest.len()],
        })
    }

    /// OBJ frames of the boundary surface of `tets` (wound outward), with only the vertices
    /// it uses.
    pub fn boundary_surface(tets: &[[usize; 4]]) -> Self {
        let faces = boundary_faces(tets);
        let mut vertices: Vec<usize> = faces.iter().flatten().copied().collect();
        vertices.sort_unstable();
        vertices.dedup();
        let local = |v: usize| vertices.binary_search(&v).expect("a boundary vertex");
        let triangles = faces.iter().map(|f| f.map(local)).collect();
        Self::Surface(SurfaceFrames {
            positions: vec![Vector3::zeros(); vertices.len()],
            source: SurfaceSource::Vertices(vertices),
            triangles,
            description: "boundary surface of the tet mesh".into(),
        })
    }

    /// OBJ frames of a display mesh (`triangles` over the skinning's display vertices) that
    /// follows the simulation through `skinning`; `name` describes it in the file header.
    pub fn skinned(skinning: Skinning, triangles: Vec<[usize; 3]>, name: &str) -> Self {
        let n = skinning.num_display_vertices();
        assert!(
            triangles.iter().flatten().all(|&v| v < n),
            "display triangles out of range"
        );
        Self::Surface(SurfaceFrames {
            positions: vec![Vector3::zeros(); n],
            source: SurfaceSource::Skinned(skinning),
            triangles,
            description: format!("display mesh {name}, skinned onto the tet mesh"),
        })
    }

    /// The file format of these frames.
    pub fn format(&self) -> ExportFormat {
        match self {
            Self::Tets(_) => ExportFormat::Vtu,
            Self::Surface(_) => ExportFormat::Obj,
        }
    }
}

/// Six times the signed volume of tet `t` at positions `x`.
fn volume6(x: &[Vector3<f64>], t: &[usize; 4]) -> f64 {
    let [a, b, c, d] = t.map(|v| x[v]);
    (b - a).dot(&(c - a).cross(&(d - a)))
}

/// One written frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// The step it shows (0 is the initial state).
    pub step: usize,
    /// Its simulated time (s).
    pub t: f64,
    /// Its file name in the frames folder.
    pub file: String,
}

/// Writes frames while passing rows on to `inner` (see the module docs).
pub struct FrameWriter<'a> {
    inner: &'a mut dyn Observer,
    dir: PathBuf,
    every: usize,
    last_step: usize,
    digits: usize,
    content: FrameContent,
    frames: Vec<Frame>,
}

impl<'a> FrameWriter<'a> {
    /// Frames of `content` into `dir` (created if needed; frame files and `series.pvd` of a
    /// previous run there are removed) at step 0, every `every` steps and `last_step`.
    ///
    /// # Panics
    /// When `every` is 0.
    pub fn new(
        dir: &Path,
        every: usize,
        last_step: usize,
        content: FrameContent,
        inner: &'a mut dyn Observer,
    ) -> io::Result<Self> {
        assert!(every >= 1, "frames every 0 steps");
        // Never through a link: it could point anywhere, and old frames are deleted here.
        if std::fs::symlink_metadata(dir).is_ok_and(|m| m.file_type().is_symlink()) {
            return Err(with_path(
                io::Error::new(
                    io::ErrorKind::InvalidInput,
                    "is a symbolic link; frames are written only into a real folder",
                ),
                dir,
            ));
        }
        std::fs::create_dir_all(dir).map_err(|e| with_path(e, dir))?;
        remove_previous_frames(dir)?;
        Ok(Self {
            inner,
            dir: dir.to_owned(),
            every,
            last_step,
            digits: last_step.to_string().len().max(5),
            content,
            frames: Vec::new(),
        })
    }

    /// The frames written so far.
    pub fn frames(&self) -> &[Frame] {
        &self.frames
    }

    /// Ends the series: writes the state at `step` if it is not the last frame already (a run
    /// that stopped early ends with its last valid state). Returns every frame written.
    pub fn finish(mut self, model: &Model, state: &State, step: usize) -> io::Result<Vec<Frame>> {
        if self.frames.last().is_none_or(|f| f.step != step) {
            self.write_frame(step, model, state)?;
        }
        Ok(self.frames)
    }

    fn write_frame(&mut self, step: usize, model: &Model, state: &State) -> io::Result<()> {
        let format = self.content.format();
        let file = format!(
            "frame_{step:0width$}.{}",
            format.name(),
            width = self.digits
        );
        let path = self.dir.join(&file);
        let x = model.full_positions(&state.q);
        let header = format!("softbench frame: step {step}, t = {:?} s", state.t);
        match &mut self.content {
            FrameContent::Tets(frames) => frames.write(&path, model, state, &x)?,
            FrameContent::Surface(frames) => {
                match &frames.source {
                    SurfaceSource::Vertices(vs) => {
                        for (p, &v) in frames.positions.iter_mut().zip(vs) {
                            *p = x[v];
                        }
                    }
                    SurfaceSource::Skinned(skin) => skin.apply_into(&x, &mut frames.positions),
                }
                let comment = format!("{header}\n{}", frames.description);
                write_atomic(&path, |w| {
                    write_obj(w, &comment, &frames.positions, &frames.triangles)
                })
                .map_err(|e| with_path(e, &path))?;
            }
        }
        self.frames.push(Frame {
            step,
            t: state.t,
            file,
        });
        if format == ExportFormat::Vtu {
            let series = self.dir.join(SERIES_FILE);
            let entries: Vec<(f64, &str)> =
                self.frames.iter().map(|f| (f.t, f.file.as_str())).collect();
            write_atomic(&series, |w| write_pvd(w, &entries)).map_err(|e| with_path(e, &series))?;
        }
        Ok(())
    }
}

impl Observer for FrameWriter<'_> {
    fn sample(&mut self, sample: &Sample) -> io::Result<()> {
        self.inner.sample(sample)
    }

    fn newton_iterations(
        &mut self,
        step: usize,
        records: &[softbench_core::integrate::newton::IterationRecord],
    ) -> std::io::Result<()> {
        self.inner.newton_iterations(step, records)
    }

    fn after_step(&mut self, step: usize, model: &Model, state: &State) -> io::Result<()> {
        self.inner.after_step(step, model, state)?;
        if step.is_multiple_of(self.every) || step == self.last_step {
            self.write_frame(step, model, state)?;
        }
        Ok(())
    }
}

impl TetFrames {
    /// Fills velocity, displacement, J and energies for `state` (positions `x`).
    fn update(&mut self, model: &Model, state: &State, x: &[Vector3<f64>]) -> io::Result<()> {
        for (f, &v) in model.dofs().free_vertices().iter().enumerate() {
            self.velocity[v] = Vector3::new(state.v[3 * f], state.v[3 * f + 1], state.v[3 * f + 2]);
        }
        for ((d, p), r) in self
            .displacement
            .iter_mut()
            .zip(x)
            .zip(model.rest_positions())
        {
            *d = p - r;
        }
        if self.from_model {
            model
                .element_measures(&state.q, &mut self.det_f, &mut self.energy)
                .map_err(io::Error::other)?;
            for ((rho, e), v6) in self
                .energy_density
                .iter_mut()
                .zip(&self.energy)
                .zip(&self.rest_volumes6)
            {
                *rho = 6.0 * e / v6;
            }
        } else {
            for ((j, t), v6) in self
                .det_f
                .iter_mut()
                .zip(&self.tets)
                .zip(&self.rest_volumes6)
            {
                *j = volume6(x, t) / v6;
            }
        }
        Ok(())
    }

    /// Writes the frame for `state` (positions `x`) to `path`.
    fn write(
        &mut self,
        path: &Path,
        model: &Model,
        state: &State,
        x: &[Vector3<f64>],
    ) -> io::Result<()> {
        self.update(model, state, x)?;
        let point_vectors: [(&str, &[Vector3<f64>]); 2] = [
            ("velocity", &self.velocity),
            ("displacement", &self.displacement),
        ];
        let mut cell_scalars: Vec<(&str, &[f64])> = vec![("J", &self.det_f)];
        if self.from_model {
            cell_scalars.push(("energy", &self.energy));
            cell_scalars.push(("energy_density", &self.energy_density));
        }
        let grid = VtuGrid {
            points: x,
            tets: &self.tets,
            point_vectors: &point_vectors,
            cell_scalars: &cell_scalars,
            time: Some(state.t),
        };
        write_atomic(path, |w| write_vtu(w, &grid)).map_err(|e| with_path(e, path))
    }
}

/// An I/O error that names the file.
fn with_path(e: io::Error, path: &Path) -> io::Error {
    io::Error::new(e.kind(), format!("{}: {e}", path.display()))
}

/// Removes `frame_*.vtu`, `frame_*.obj`, `series.pvd` (and their temporary leftovers,
/// `.<name>.<random>.partial` or the older `<name>.partial`) from
/// `dir`, so a shorter run does not leave a longer run's frames behind.
fn remove_previous_frames(dir: &Path) -> io::Result<()> {
    for entry in std::fs::read_dir(dir).map_err(|e| with_path(e, dir))? {
        let entry = entry?;
        let name = entry.file_name();
        let Some(name) = name.to_str() else { continue };
        let base = name.strip_suffix(".partial").map_or(name, |b| {
            b.strip_prefix('.')
                .and_then(|b| b.rsplit_once('.'))
                .map_or(b, |(stem, _)| stem)
        });
        let is_frame = base.strip_prefix("frame_").is_some_and(|rest| {
            let stem = rest
                .strip_suffix(".vtu")
                .or_else(|| rest.strip_suffix(".obj"));
            stem.is_some_and(|s| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()))
        });
        if (is_frame || base == SERIES_FILE) && entry.file_type()?.is_file() {
            std::fs::remove_file(entry.path()).map_err(|e| with_path(e, &entry.path()))?;
        }
    }
    Ok(())
}
