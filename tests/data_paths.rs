//! The data search path: absolute paths as is, then the config folder, then SOFTBENCH_DATA.
//! The environment is injected through `DataPaths::new`, so these tests never touch it.

mod common;

use common::TempDir;
use softbench::data::{DataPaths, Place};

#[test]
fn config_folder_is_searched_before_the_data_folder() {
    let config = TempDir::new("data-config");
    let data = TempDir::new("data-data");
    let in_config = config.write("bunny.mesh", "config");
    let in_data = data.write("bunny.mesh", "data");
    let paths = DataPaths::new(Some(data.path().to_path_buf()));
    assert_eq!(
        paths.resolve("bunny.mesh", Some(config.path())).unwrap(),
        in_config
    );
    assert_eq!(paths.resolve("bunny.mesh", None).unwrap(), in_data);
}

#[test]
fn data_folder_is_used_when_the_config_folder_lacks_the_file() {
    let config = TempDir::new("data-config-empty");
    let data = TempDir::new("data-data-full");
    let in_data = data.write("arma_6.node", "");
    let paths = DataPaths::new(Some(data.path().to_path_buf()));
    assert_eq!(
        paths.resolve("arma_6.node", Some(config.path())).unwrap(),
        in_data
    );
}

#[test]
fn absolute_path_is_used_as_is() {
    let dir = TempDir::new("data-absolute");
    let file = dir.write("cube.mesh", "");
    let elsewhere = TempDir::new("data-elsewhere");
    let paths = DataPaths::new(Some(elsewhere.path().to_path_buf()));
    assert_eq!(paths.resolve(&file, Some(elsewhere.path())).unwrap(), file);
    let missing = dir.path().join("missing.mesh");
    let err = paths.resolve(&missing, Some(elsewhere.path())).unwrap_err();
    assert_eq!(err.tried, vec![(missing, Place::Absolute)]);
}

#[test]
fn missing_file_error_lists_every_place_looked() {
    let config = TempDir::new("data-miss-config");
    let data = TempDir::new("data-miss-data");
    let paths = DataPaths::new(Some(data.path().to_path_buf()));
    let err = paths.resolve("nope.mesh", Some(config.path())).unwrap_err();
    assert_eq!(
        err.tried,
        vec![
            (config.path().join("nope.mesh"), Place::ConfigDir),
            (data.path().join("nope.mesh"), Place::DataDir),
        ]
    );
    let message = err.to_string();
    assert!(message.contains(&config.path().join("nope.mesh").display().to_string()));
    assert!(message.contains(&data.path().join("nope.mesh").display().to_string()));
    assert!(message.contains("SOFTBENCH_DATA is set"), "{message}");
}

#[test]
fn missing_file_error_says_how_to_set_softbench_data_when_unset() {
    let config = TempDir::new("data-unset");
    let err = DataPaths::new(None)
        .resolve("nope.mesh", Some(config.path()))
        .unwrap_err();
    assert_eq!(err.tried.len(), 1);
    let message = err.to_string();
    assert!(message.contains("SOFTBENCH_DATA is not set"), "{message}");
    assert!(message.contains("export SOFTBENCH_DATA="), "{message}");
}

/// A folder with the name is not a file, and the error says it is a folder rather than
/// "not found"; a file of that name further along the search path is still found.
#[test]
fn a_folder_with_the_name_is_not_a_file() {
    let config = TempDir::new("data-folder");
    let folder = config.path().join("meshes");
    std::fs::create_dir(&folder).unwrap();
    let err = DataPaths::new(None)
        .resolve("meshes", Some(config.path()))
        .unwrap_err();
    assert_eq!(err.folder, Some((folder.clone(), Place::ConfigDir)));
    let message = err.to_string();
    assert!(
        message.contains("is a folder (directory), not a data file")
            && message.contains(&folder.display().to_string())
            && !message.contains("not found"),
        "{message}"
    );
    let data = TempDir::new("data-folder-file");
    let file = data.write("meshes", "");
    let paths = DataPaths::new(Some(data.path().to_path_buf()));
    assert_eq!(paths.resolve("meshes", Some(config.path())).unwrap(), file);
}

#[test]
fn command_line_names_are_looked_up_in_the_current_folder_first() {
    // Cargo runs integration tests in the package root.
    let data = TempDir::new("data-cwd");
    data.write("Cargo.toml", "");
    let paths = DataPaths::new(Some(data.path().to_path_buf()));
    let found = paths.resolve_from_cwd("Cargo.toml").unwrap();
    assert_eq!(found, std::env::current_dir().unwrap().join("Cargo.toml"));
    let err = paths.resolve_from_cwd("no-such-file.mesh").unwrap_err();
    assert_eq!(err.tried[0].1, Place::CurrentDir);
    assert!(err.to_string().contains("(current folder)"));
}

#[test]
fn a_missing_mesh_names_the_fetch_script() {
    for data_dir in [None, Some(std::env::temp_dir())] {
        let err = DataPaths::new(data_dir)
            .resolve("no-such-mesh-here.mesh", None)
            .unwrap_err()
            .to_string();
        assert!(err.contains("scripts/fetch-meshes.sh"), "{err}");
    }
}
