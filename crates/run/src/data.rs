//! Where data files (reference meshes) are found: an absolute path as is; otherwise a config's
//! own folder first, then the folder named by the `SOFTBENCH_DATA` environment variable.
//!
//! The environment is read once, by [`DataPaths::from_env`], so tests can build a
//! [`DataPaths`] by hand instead of changing the process environment.

use std::fmt;
use std::path::{Path, PathBuf};

/// The environment variable naming the data folder.
pub const DATA_ENV: &str = "SOFTBENCH_DATA";

/// The folders a data file name is looked up in, besides the caller's own folder.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct DataPaths {
    /// The data folder (`SOFTBENCH_DATA`), if set.
    pub data_dir: Option<PathBuf>,
}

/// One place a data file was looked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Place {
    /// The name was an absolute path.
    Absolute,
    /// The current folder (the CLI's base for names on the command line).
    CurrentDir,
    /// The folder of the config that names the file.
    ConfigDir,
    /// The `SOFTBENCH_DATA` folder.
    DataDir,
}

impl fmt::Display for Place {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Place::Absolute => "absolute path",
            Place::CurrentDir => "current folder",
            Place::ConfigDir => "config folder",
            Place::DataDir => DATA_ENV,
        })
    }
}

/// A data file that is in none of the places looked, or that names a folder there.
#[derive(Debug, thiserror::Error)]
#[error("{}", describe(.name, .tried, *.data_dir_set, .folder.as_ref()))]
pub struct DataError {
    /// The name asked for.
    pub name: PathBuf,
    /// Every path tried, in order, with the place it stands for.
    pub tried: Vec<(PathBuf, Place)>,
    /// Whether `SOFTBENCH_DATA` was set.
    pub data_dir_set: bool,
    /// The first path tried that is a folder (directory), when no path is a file: the name is
    /// there, but it is not a file, which "not found" would hide.
    pub folder: Option<(PathBuf, Place)>,
}

impl softbench_core::error_class::Classify for DataError {
    /// A data file that cannot be found where the scene says.
    fn class(&self) -> softbench_core::error_class::ErrorClass {
        softbench_core::error_class::ErrorClass::BadInput
    }
}

fn describe(
    name: &Path,
    tried: &[(PathBuf, Place)],
    data_dir_set: bool,
    folder: Option<&(PathBuf, Place)>,
) -> String {
    if let Some((path, place)) = folder {
        return format!(
            "`{}` is a folder (directory), not a data file: {} ({place}); name a file inside it",
            name.display(),
            path.display(),
        );
    }
    let mut s = format!("data file `{}` not found; looked in:", name.display());
    for (path, place) in tried {
        s += &format!("\n  {} ({place})", path.display());
    }
    if tried.is_empty() {
        s += " nowhere (no base folder and no data folder)";
    }
    if !name.is_absolute() {
        if data_dir_set {
            s += &format!(
                "\n{DATA_ENV} is set; check that it names the folder holding the file \
                 (`scripts/fetch-meshes.sh DIR` downloads the reference meshes into DIR)"
            );
        } else {
            s += &format!(
                "\n{DATA_ENV} is not set; fetch the reference meshes with \
                 `scripts/fetch-meshes.sh meshes`, then `export {DATA_ENV}=$PWD/meshes`"
            );
        }
    }
    s
}

impl DataPaths {
    /// Reads `SOFTBENCH_DATA` (an empty value counts as unset).
    pub fn from_env() -> Self {
        let data_dir = std::env::var_os(DATA_ENV)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from);
        DataPaths { data_dir }
    }

    /// Search paths with the given data folder.
    pub fn new(data_dir: Option<PathBuf>) -> Self {
        DataPaths { data_dir }
    }

    /// Finds `name`: as is if absolute; else in `config_dir` (when given), then in the data
    /// folder. Returns the first existing file's path; a name that is only a folder is an error
    /// that says so.
    pub fn resolve(
        &self,
        name: impl AsRef<Path>,
        config_dir: Option<&Path>,
    ) -> Result<PathBuf, DataError> {
        self.search(name.as_ref(), config_dir.map(|d| (d, Place::ConfigDir)))
    }

    /// Finds `name` as given on a command line: as is if absolute; else in the current
    /// folder, then in the data folder.
    pub fn resolve_from_cwd(&self, name: impl AsRef<Path>) -> Result<PathBuf, DataError> {
        let name = name.as_ref();
        match std::env::current_dir() {
            Ok(cwd) => self.search(name, Some((&cwd, Place::CurrentDir))),
            Err(_) => self.search(name, Some((Path::new("."), Place::CurrentDir))),
        }
    }

    fn search(&self, name: &Path, base: Option<(&Path, Place)>) -> Result<PathBuf, DataError> {
        let mut tried = Vec::new();
        if name.is_absolute() {
            tried.push((name.to_path_buf(), Place::Absolute));
        } else {
            if let Some((dir, place)) = base {
                tried.push((dir.join(name), place));
            }
            if let Some(dir) = &self.data_dir {
                tried.push((dir.join(name), Place::DataDir));
            }
        }
        if let Some((path, _)) = tried.iter().find(|(p, _)| p.is_file()) {
            return Ok(path.clone());
        }
        let folder = tried.iter().find(|(p, _)| p.is_dir()).cloned();
        Err(DataError {
            name: name.to_path_buf(),
            tried,
            data_dir_set: self.data_dir.is_some(),
            folder,
        })
    }
}
