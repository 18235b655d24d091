//! Recording snapshots during a run: an [`Observer`] that keeps the body's surface at
//! [`SAMPLES`] evenly spaced steps of the requested horizon, and the last valid state of a
//! run that ends early.
//!
//! Per step it copies only the surface vertices (f32) into a preallocated buffer, so the
//! last valid state is at hand whatever step fails; `det F` and the obstacles are computed
//! only at the sampled steps.

use std::io;
use std::sync::Arc;

use nalgebra::Vector3;

use super::obstacles::tessellate;
use super::snapshots::{P3, SnapshotFrame, Snapshots};
use crate::run::{Observer, Outcome, OutcomeKind, Sample};
use softbench_core::contact::Obstacles;
use softbench_core::integrate::State;
use softbench_core::mesh::Skinning;
use softbench_core::mesh::surface::classify_faces;
use softbench_core::model::FIXED;
use softbench_core::model::Model;

/// Snapshots per run: step 0 and 30 equal parts of the horizon (a filmstrip uses every
/// sixth, the animation all of them).
pub const SAMPLES: usize = 31;

/// Which surface is drawn.
#[derive(Clone, Debug)]
pub enum Surface {
    /// The boundary of the tet mesh: the listed simulation vertices, triangles over them, and
    /// the tet owning each triangle (its index in the model's elastic tets, if it is one).
    Boundary {
        vertices: Vec<usize>,
        triangles: Vec<[u32; 3]>,
        owners: Option<Vec<usize>>,
    },
    /// A display mesh skinned onto the tets.
    Skinned {
        skinning: Skinning,
        triangles: Vec<[u32; 3]>,
    },
}

impl Surface {
    /// The boundary surface of `tets`; when `tets` are the model's elastic tets, each
    /// triangle can be coloured by its tet's det F.
    pub fn boundary(model: &Model, tets: &[[usize; 4]]) -> Self {
        let faces = classify_faces(tets);
        let mut vertices: Vec<usize> = faces.boundary.iter().flatten().copied().collect();
        vertices.sort_unstable();
        vertices.dedup();
        let local = |v: usize| vertices.binary_search(&v).expect("a boundary vertex") as u32;
        let triangles = faces.boundary.iter().map(|f| f.map(local)).collect();
        let owners = (model.tets() == tets).then_some(faces.boundary_tets);
        Self::Boundary {
            vertices,
            triangles,
            owners,
        }
    }

    /// A display mesh (`triangles` over the skinning's display vertices).
    pub fn skinned(skinning: Skinning, triangles: &[[usize; 3]]) -> Self {
        let triangles = triangles.iter().map(|t| t.map(|v| v as u32)).collect();
        Self::Skinned {
            skinning,
            triangles,
        }
    }

    fn num_vertices(&self) -> usize {
        match self {
            Self::Boundary { vertices, .. } => vertices.len(),
            Self::Skinned { skinning, .. } => skinning.num_display_vertices(),
        }
    }

    fn triangles(&self) -> &[[u32; 3]] {
        match self {
            Self::Boundary { triangles, .. } | Self::Skinned { triangles, .. } => triangles,
        }
    }
}

/// Records [`Snapshots`] while passing rows on to `inner`.
pub struct SnapshotRecorder<'a> {
    inner: &'a mut dyn Observer,
    surface: Surface,
    obstacles: Option<Arc<Obstacles>>,
    /// Steps to sample, increasing; `next` indexes the first not yet reached.
    targets: Vec<usize>,
    next: usize,
    /// Every vertex's position (m): fixed ones from the model, free ones per step.
    full: Vec<Vector3<f64>>,
    /// The surface after the last step (f32), and that step and time.
    last: Vec<P3>,
    last_step: usize,
    last_t: f64,
    /// Scratch for det F and element energies (model tets), allocated once.
    det_f: Vec<f64>,
    energy: Vec<f64>,
    /// Rest volume of each model tet (m³), for energy densities.
    rest_volume: Vec<f64>,
    snapshots: Snapshots,
}

impl<'a> SnapshotRecorder<'a> {
    /// Records `surface` (and `obstacles`) over a run of `steps` steps of `dt` from `state`.
    pub fn new(
        model: &Model,
        state: &State,
        surface: Surface,
        obstacles: Option<Arc<Obstacles>>,
        (steps, dt): (usize, f64),
        inner: &'a mut dyn Observer,
    ) -> Self {
        let mut targets: Vec<usize> = (0..SAMPLES)
            .map(|k| ((k * steps) as f64 / (SAMPLES - 1) as f64).round() as usize)
            .collect();
        targets.dedup();
        let up = model
            .gravity()
            .and_then(|g| (-g).try_normalize(0.0))
            .unwrap_or(Vector3::y());
        let n = surface.num_vertices();
        let m = model.tets().len();
        let with_j = matches!(
            &surface,
            Surface::Boundary {
                owners: Some(_),
                ..
            }
        );
        Self {
            inner,
            targets,
            next: 0,
            full: model.full_positions(&vec![0.0; model.num_dofs()]),
            last: vec![[0.0; 3]; n],
            last_step: 0,
            last_t: 0.0,
            det_f: vec![0.0; if with_j { m } else { 0 }],
            energy: vec![0.0; if with_j { m } else { 0 }],
            rest_volume: if with_j {
                rest_volumes(model)
            } else {
                Vec::new()
            },
            snapshots: Snapshots {
                up: [up.x as f32, up.y as f32, up.z as f32],
                end_time: state.t + steps as f64 * dt,
                triangles: surface.triangles().to_vec(),
                frames: Vec::new(),
                failure: String::new(),
            },
            surface,
            obstacles,
        }
    }

    /// Copies the surface of `state` into `self.last`.
    fn capture(&mut self, model: &Model, state: &State) {
        let dofs = model.dofs();
        let at = |v: usize, full: &[Vector3<f64>]| -> Vector3<f64> {
            match dofs.free_index(v) {
                FIXED => full[v],
                f => {
                    let f = 3 * f as usize;
                    Vector3::new(state.q[f], state.q[f + 1], state.q[f + 2])
                }
            }
        };
        match &self.surface {
            Surface::Boundary { vertices, .. } => {
                for (p, &v) in self.last.iter_mut().zip(vertices) {
                    let x = at(v, &self.full);
                    *p = [x.x as f32, x.y as f32, x.z as f32];
                }
            }
            Surface::Skinned { skinning, .. } => {
                for v in 0..self.full.len() {
                    if dofs.free_index(v) != FIXED {
                        self.full[v] = at(v, &self.full);
                    }
                }
                for (i, p) in self.last.iter_mut().enumerate() {
                    let (vs, ws) = (skinning.vertices(i), skinning.weights(i));
                    let x: Vector3<f64> = (0..4).map(|k| self.full[vs[k]] * ws[k]).sum();
                    *p = [x.x as f32, x.y as f32, x.z as f32];
                }
            }
        }
    }

    fn push_frame(&mut self, model: &Model, state: Option<&State>, last_valid: bool) {
        let mut j = Vec::new();
        let mut energy_density = Vec::new();
        if let (
            Some(state),
            Surface::Boundary {
                owners: Some(owners),
                ..
            },
        ) = (state, &self.surface)
            && model
                .element_measures(&state.q, &mut self.det_f, &mut self.energy)
                .is_ok()
        {
            j = owners.iter().map(|&e| self.det_f[e] as f32).collect();
            energy_density = owners
                .iter()
                .map(|&e| (self.energy[e] / self.rest_volume[e]) as f32)
                .collect();
        }
        let obstacles = match &self.obstacles {
            Some(o) => {
                let b = super::raster::Bounds::of(&self.last);
                let (c, size) = b.map_or((Vector3::zeros(), 1.0), |b| {
                    (Vector3::from(b.center()), b.diagonal().max(1e-3))
                });
                tessellate(o, self.last_t, c, size)
            }
            None => Vec::new(),
        };
        self.snapshots.frames.push(SnapshotFrame {
            t: self.last_t,
            step: self.last_step as u64,
            positions: self.last.clone(),
            j,
            energy_density,
            obstacles,
            last_valid,
        });
    }

    /// Ends the recording: a run that ended early gets its last valid state as a final frame,
    /// marked with `outcome`.
    pub fn finish(mut self, model: &Model, outcome: &Outcome) -> Snapshots {
        if outcome.status != OutcomeKind::Completed {
            self.snapshots.failure = match outcome.t {
                Some(t) => format!(
                    "{} ({}) at t = {t:.4} s",
                    outcome.status.name(),
                    outcome.cause
                ),
                None => format!("{} ({})", outcome.status.name(), outcome.cause),
            };
            if self
                .snapshots
                .frames
                .last()
                .is_none_or(|f| f.step as usize != self.last_step)
            {
                self.push_frame(model, None, true);
            } else if let Some(f) = self.snapshots.frames.last_mut() {
                f.last_valid = true;
            }
        }
        self.snapshots
    }
}

impl Observer for SnapshotRecorder<'_> {
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
        if state.q.iter().all(|x| x.is_finite()) {
            self.capture(model, state);
            self.last_step = step;
            self.last_t = state.t;
            if self.targets.get(self.next) == Some(&step) {
                self.next += 1;
                self.push_frame(model, Some(state), false);
            }
        }
        Ok(())
    }
}

/// The rest volume of every tet of `model` (m³).
fn rest_volumes(model: &Model) -> Vec<f64> {
    let x = model.rest_positions();
    model
        .tets()
        .iter()
        .map(|t| {
            let [a, b, c, d] = t.map(|v| x[v]);
            ((b - a).cross(&(c - a)).dot(&(d - a)) / 6.0).abs()
        })
        .collect()
}
