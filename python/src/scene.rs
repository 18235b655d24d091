//! A scene from Python: a TOML file or a dict (passed as JSON), with overrides as `key=value`
//! strings (the command line's `--set`) or a dict of dotted keys (passed as JSON).

use std::path::PathBuf;

use softbench::data::DataPaths;
use softbench::error::Context;
use softbench::scene::{self, LoadedScene};

/// Where a scene comes from and what changes it.
pub struct SceneSource {
    /// A scene file; relative paths in it are found beside it.
    pub path: Option<PathBuf>,
    /// Or a scene as a JSON object (a Python dict); relative paths in it are found in
    /// `base_dir`.
    pub table_json: Option<String>,
    pub base_dir: Option<PathBuf>,
    /// `key=value` overrides, applied in order.
    pub set: Vec<String>,
    /// `{dotted key: value}` overrides as a JSON object, applied after `set`.
    pub set_json: Option<String>,
}

impl SceneSource {
    /// Read, override and validate the scene (nothing is built yet).
    pub fn load(&self) -> Result<LoadedScene, softbench::error::Error> {
        let (mut table, text, path) = match (&self.path, &self.table_json) {
            (Some(path), None) => {
                let text =
                    scene::read_config_text(path).map_err(|error| scene::SceneError::Io {
                        path: path.clone(),
                        error,
                    })?;
                (scene::parse_text(&text, path)?, Some(text), path.clone())
            }
            (None, Some(json)) => {
                let base = match &self.base_dir {
                    Some(b) => b.clone(),
                    None => std::env::current_dir().context("cannot find the current folder")?,
                };
                let path = base.join("<dict>");
                let table: toml::Table =
                    serde_json::from_str(json).map_err(|e| scene::SceneError::Parse {
                        path: path.clone(),
                        message: format!("the scene dict is not a TOML table: {e}"),
                    })?;
                (table, None, path)
            }
            _ => unreachable!("the Python side passes a path or a dict"),
        };
        for o in &self.set {
            scene::apply_override(&mut table, o).map_err(scene::SceneError::Override)?;
        }
        if let Some(json) = &self.set_json {
            let sets: toml::Table =
                serde_json::from_str(json).map_err(|e| scene::SceneError::Parse {
                    path: path.clone(),
                    message: format!("overrides: {e}"),
                })?;
            for (key, value) in sets {
                scene::set_value(&mut table, &key, value).map_err(scene::SceneError::Override)?;
            }
        }
        let config = scene::from_table(table, text.as_deref(), &path)?;
        Ok(LoadedScene { path, config })
    }
}

/// Where data files are found: `dir` if given, else the SOFTBENCH_DATA folder.
pub fn data_paths(dir: Option<PathBuf>) -> DataPaths {
    dir.map_or_else(DataPaths::from_env, |d| DataPaths::new(Some(d)))
}
