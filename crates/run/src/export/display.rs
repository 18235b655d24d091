//! The `[display]` section of a scene: a triangle surface (a finer "display" or "skin" mesh)
//! that follows the simulated tet mesh through [`Skinning`], written by `--export obj`
//! instead of the tet mesh's boundary surface.
//!
//! ```toml
//! [display]
//! file = "armadillo.obj"   # next to the scene file, then in SOFTBENCH_DATA
//! ```
//!
//! The file is found and read only when OBJ frames are asked for.

use std::path::PathBuf;

use crate::data::{DataError, DataPaths};
pub use crate::scene::DisplayConfig;
use crate::scene::LoadedScene;
use softbench_core::mesh::{
    MeshError, Skinning, SkinningError, SurfaceMesh, TetMesh, read_surface_mesh,
};

/// Why the display mesh could not be set up (bad input: the scene names something unusable).
#[derive(Debug, thiserror::Error)]
pub enum DisplayError {
    #[error("{scene}: display.file: {error}")]
    Data { scene: PathBuf, error: DataError },
    #[error("{scene}: display.file: {error}")]
    Mesh { scene: PathBuf, error: MeshError },
    #[error("{scene}: display.file `{file}`: {error}")]
    Skinning {
        scene: PathBuf,
        file: String,
        error: SkinningError,
    },
}

impl softbench_core::error_class::Classify for DisplayError {
    fn class(&self) -> softbench_core::error_class::ErrorClass {
        softbench_core::error_class::ErrorClass::BadInput
    }
}

/// A display mesh bound to the tet mesh.
#[derive(Clone, Debug)]
pub struct Display {
    /// Where the display mesh was read from.
    pub path: PathBuf,
    /// The display mesh at rest.
    pub mesh: SurfaceMesh,
    /// Its binding to the tet mesh.
    pub skinning: Skinning,
}

/// Reads the scene's display mesh (if it names one) and skins it onto `rest` (the tet mesh at
/// rest, vertices in model order).
pub fn load_display(
    scene: &LoadedScene,
    data: &DataPaths,
    rest: &TetMesh,
) -> Result<Option<Display>, DisplayError> {
    let Some(config) = &scene.config.display else {
        return Ok(None);
    };
    let path = data
        .resolve(&config.file, Some(scene.base_dir()))
        .map_err(|error| DisplayError::Data {
            scene: scene.path.clone(),
            error,
        })?;
    let mesh = read_surface_mesh(&path).map_err(|error| DisplayError::Mesh {
        scene: scene.path.clone(),
        error,
    })?;
    let skinning =
        Skinning::new(rest, &mesh.positions).map_err(|error| DisplayError::Skinning {
            scene: scene.path.clone(),
            file: config.file.clone(),
            error,
        })?;
    Ok(Some(Display {
        path,
        mesh,
        skinning,
    }))
}
