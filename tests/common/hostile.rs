//! Checks for hostile mesh files: refused with a parse error naming the file and line, never a
//! panic; or accepted.

use softbench::mesh::{MeshError, TetMesh, read_tet_mesh};

use super::TempDir;

/// Reads `content` written as `name` and checks the error is a parse error at `line` (if
/// given) that names the file and says `needle`.
#[track_caller]
pub fn refused(name: &str, content: &[u8], line: Option<usize>, needle: &str) -> String {
    let dir = TempDir::new("hostile");
    let path = dir.path().join(name);
    std::fs::write(&path, content).unwrap();
    let err = match std::panic::catch_unwind(|| read_tet_mesh(&path)) {
        Err(_) => panic!("{name}: the reader panicked"),
        Ok(Ok(mesh)) => panic!("{name}: accepted, with {} tets", mesh.num_tets()),
        Ok(Err(e)) => e,
    };
    let message = err.to_string();
    let MeshError::Parse { line: at, .. } = err else {
        panic!("{name}: not a parse error with a line: {message}")
    };
    if let Some(line) = line {
        assert_eq!(at, line, "{name}: {message}");
    }
    let prefix = format!("{}:{at}: ", path.display());
    assert!(message.starts_with(&prefix), "{name}: {message}");
    assert!(
        message.contains(needle),
        "{name}: expected `{needle}` in: {message}"
    );
    message
}

/// Reads `content` written as `name`, which must load.
#[track_caller]
pub fn accepted(name: &str, content: &[u8]) -> TetMesh {
    let dir = TempDir::new("hostile-ok");
    let path = dir.path().join(name);
    std::fs::write(&path, content).unwrap();
    read_tet_mesh(&path).unwrap_or_else(|e| panic!("{name}: {e}"))
}
