//! The surface a run's frames and pictures show, built once per run: the boundary of the
//! body's tets, or the scene's `[display]` mesh skinned onto them. OBJ frames and pictures
//! of the same run share the one skinning.

use crate::data::DataPaths;
use crate::export::{Display, DisplayError, ExportFormat, FrameContent, load_display};
use crate::render::Surface;
use crate::scene::{LoadedScene, Scene};
use softbench_core::mesh::TetMesh;

/// The body's surface at rest: its tets ([`Scene::surface_tets`]) and, when the scene names
/// one and it was asked for, the display mesh skinned onto them.
#[derive(Debug)]
pub struct BodySurface {
    tets: Vec<[usize; 4]>,
    display: Option<Display>,
}

impl BodySurface {
    /// The surface of `scene` (built from `loaded`). With `skin`, the scene's `[display]`
    /// mesh, if it names one, is found through `data`, read and skinned onto the rest tets
    /// here, the only place a run does so; without it, the display mesh is not read.
    pub fn new(
        loaded: &LoadedScene,
        data: &DataPaths,
        scene: &Scene,
        skin: bool,
    ) -> Result<Self, DisplayError> {
        let mut tets = scene.surface_tets().to_vec();
        let mut display = None;
        if skin && loaded.config.display.is_some() {
            let rest = TetMesh {
                positions: scene.model.rest_positions().to_vec(),
                tets,
            };
            display = load_display(loaded, data, &rest)?;
            tets = rest.tets;
        }
        Ok(Self { tets, display })
    }

    /// The skinned display mesh, if there is one.
    pub fn display(&self) -> Option<&Display> {
        self.display.as_ref()
    }

    /// The surface pictures are drawn of: the display mesh, else the boundary of the tets;
    /// `None` when the body has no tets.
    pub fn picture_surface(&self, scene: &Scene) -> Option<Surface> {
        if let Some(d) = &self.display {
            return Some(Surface::skinned(d.skinning.clone(), &d.mesh.triangles));
        }
        (!self.tets.is_empty()).then(|| Surface::boundary(&scene.model, &self.tets))
    }

    /// What `--export` frames hold: VTU frames of the tets; OBJ frames of the display mesh,
    /// else of the tets' boundary surface.
    pub fn frame_content(&self, format: ExportFormat, scene: &Scene) -> FrameContent {
        match (format, &self.display) {
            (ExportFormat::Vtu, _) => FrameContent::tets(&scene.model, self.tets.clone()),
            (ExportFormat::Obj, Some(d)) => {
                let name = d.path.file_name().map_or_else(
                    || d.path.display().to_string(),
                    |n| n.to_string_lossy().into_owned(),
                );
                FrameContent::skinned(d.skinning.clone(), d.mesh.triangles.clone(), &name)
            }
            (ExportFormat::Obj, None) => FrameContent::boundary_surface(&self.tets),
        }
    }
}
