//! Bad input gives a `MeshError` naming the file and the 1-based line, never a panic. One test
//! per kind of mistake, each on a small file written to a private temporary folder.

mod common;

use std::path::Path;

use common::TempDir;
use softbench::mesh::{MeshError, read_mesh};

/// Writes `content` to `name`, reads it, and checks the error names `name:line:` and says
/// `needle`.
#[track_caller]
fn assert_error_at(name: &str, content: &str, line: usize, needle: &str) {
    let dir = TempDir::new("bad-input");
    let path = dir.write(name, content);
    assert_error_in(&path, line, needle);
}

#[track_caller]
fn assert_error_in(path: &Path, line: usize, needle: &str) {
    let err = match read_mesh(path) {
        Ok(_) => panic!("{} was read without error", path.display()),
        Err(err) => err,
    };
    let message = err.to_string();
    assert!(
        matches!(err, MeshError::Parse { line: l, .. } if l == line),
        "expected a parse error at line {line}, got: {message}"
    );
    let at = format!("{}:{line}:", path.display());
    assert!(message.contains(&at), "`{message}` does not contain `{at}`");
    assert!(
        message.contains(needle),
        "`{message}` does not say `{needle}`"
    );
}

const MEDIT_HEAD: &str = "MeshVersionFormatted 1\nDimension 3\n";
const FOUR_VERTICES: &str = "0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n";

fn medit(body: &str) -> String {
    format!("{MEDIT_HEAD}{body}")
}

// --- MEDIT ---

#[test]
fn medit_truncated_vertices_section_names_the_last_line() {
    let text = medit("Vertices\n4\n0 0 0 0\n1 0 0 0\n");
    assert_error_at(
        "truncated.mesh",
        &text,
        6,
        "file ends inside the `Vertices` section",
    );
}

#[test]
fn medit_count_larger_than_the_entries_points_at_the_next_keyword() {
    let text = medit(&format!(
        "Vertices\n5\n{FOUR_VERTICES}Tetrahedra\n1\n1 2 3 4 0\nEnd\n"
    ));
    assert_error_at("count.mesh", &text, 9, "found `Tetrahedra`");
}

#[test]
fn medit_count_smaller_than_the_entries_points_at_the_extra_entry() {
    let text = medit(&format!(
        "Vertices\n3\n{FOUR_VERTICES}Tetrahedra\n1\n1 2 3 4 0\nEnd\n"
    ));
    assert_error_at("count.mesh", &text, 8, "expected a section keyword");
}

#[test]
fn medit_non_number_coordinate() {
    let text = medit("Vertices\n4\n0 0 0 0\n1 x 0 0\n0 1 0 0\n0 0 1 0\nTetrahedra 1\n1 2 3 4 0\n");
    assert_error_at("nan.mesh", &text, 6, "expected a number, found `x`");
}

#[test]
fn medit_index_past_the_vertex_count() {
    let text = medit(&format!(
        "Vertices\n4\n{FOUR_VERTICES}Tetrahedra\n1\n1 2 3 5 0\nEnd\n"
    ));
    assert_error_at("range.mesh", &text, 11, "vertex index 5 is out of range");
}

#[test]
fn medit_index_zero_is_out_of_range_because_medit_is_one_based() {
    let text = medit(&format!(
        "Vertices\n4\n{FOUR_VERTICES}Tetrahedra\n1\n0 1 2 3 0\nEnd\n"
    ));
    assert_error_at("zero.mesh", &text, 11, "1-based");
}

#[test]
fn medit_repeated_index_within_a_tet() {
    let text = medit(&format!(
        "Vertices\n4\n{FOUR_VERTICES}Tetrahedra\n1\n1 2 2 4 0\nEnd\n"
    ));
    assert_error_at("repeat.mesh", &text, 11, "repeats vertex index 2");
}

#[test]
fn medit_without_tets_is_an_empty_mesh() {
    let text = medit(&format!("Vertices\n4\n{FOUR_VERTICES}Tetrahedra\n0\nEnd\n"));
    assert_error_at("empty.mesh", &text, 9, "empty mesh");
}

#[test]
fn medit_unknown_keyword() {
    let text = medit(&format!("Vertices\n4\n{FOUR_VERTICES}Prisms\n1\n"));
    assert_error_at("keyword.mesh", &text, 9, "unknown MEDIT keyword `Prisms`");
}

#[test]
fn medit_two_dimensional_mesh_is_refused() {
    let text = "MeshVersionFormatted 1\nDimension\n2\nVertices\n0\nEnd\n";
    assert_error_at("flat.mesh", text, 3, "only `Dimension 3`");
}

// --- plain (Brown) ---

#[test]
fn plain_vertex_line_with_two_coordinates() {
    let text = "v 0 0 0\nv 1 0\nv 0 1 0\nv 0 0 1\nt 0 1 2 3\n";
    assert_error_at(
        "short.mesh",
        text,
        2,
        "expected `v x y z` (3 numbers), found 2",
    );
}

#[test]
fn plain_tet_line_with_five_indices() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nt 0 1 2 3 0\n";
    assert_error_at(
        "long.mesh",
        text,
        5,
        "expected `t i j k l` (4 numbers), found 5",
    );
}

#[test]
fn plain_unknown_record() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n";
    assert_error_at("record.mesh", text, 4, "found `f`");
}

#[test]
fn plain_index_past_the_vertex_count_is_reported_at_its_line() {
    let text = "v 0 0 0\nv 1 0 0\nt 0 1 2 3\nv 0 1 0\n";
    assert_error_at("range.mesh", text, 3, "vertex index 3 is out of range");
}

#[test]
fn plain_non_integer_index() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nt 0 1 2 3.0\n";
    assert_error_at(
        "float-index.mesh",
        text,
        5,
        "expected an integer vertex index",
    );
}

#[test]
fn plain_without_tets_is_an_empty_mesh() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    assert_error_at("no-tets.mesh", text, 3, "empty mesh");
}

// --- TetGen ---

#[test]
fn tetgen_node_without_ele_names_both_files() {
    let dir = TempDir::new("tetgen-missing");
    let node = dir.write(
        "lonely.node",
        "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n",
    );
    let err = read_mesh(&node).unwrap_err();
    assert!(matches!(err, MeshError::MissingCompanion { .. }), "{err}");
    let message = err.to_string();
    assert!(
        message.contains("lonely.node") && message.contains("lonely.ele"),
        "{message}"
    );
}

#[test]
fn tetgen_node_file_shorter_than_its_header() {
    let dir = TempDir::new("tetgen-truncated");
    let node = dir.write(
        "short.node",
        "5 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n",
    );
    dir.write("short.ele", "1 4 0\n0 0 1 2 3\n");
    assert_error_in(
        &node,
        5,
        "file ends after 4 points, but the header announces 5",
    );
}

#[test]
fn tetgen_point_ids_must_be_consecutive() {
    let dir = TempDir::new("tetgen-ids");
    let node = dir.write("gap.node", "4 3 0 0\n0 0 0 0\n1 1 0 0\n3 0 1 0\n4 0 0 1\n");
    dir.write("gap.ele", "1 4 0\n0 0 1 2 3\n");
    assert_error_in(
        &node,
        4,
        "point ids must be consecutive: expected 2, found 3",
    );
}

#[test]
fn tetgen_point_line_with_a_missing_marker_column() {
    let dir = TempDir::new("tetgen-columns");
    let node = dir.write(
        "cols.node",
        "4 3 0 1\n0 0 0 0 1\n1 1 0 0\n2 0 1 0 1\n3 0 0 1 1\n",
    );
    dir.write("cols.ele", "1 4 0\n0 0 1 2 3\n");
    assert_error_in(&node, 3, "expected 5 fields");
}

#[test]
fn tetgen_ele_index_out_of_range_is_reported_in_the_ele_file() {
    let dir = TempDir::new("tetgen-range");
    let node = dir.write(
        "range.node",
        "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n",
    );
    let ele = dir.write("range.ele", "1 4 0\n0 0 1 2 4\n");
    assert_error_in(&ele, 2, "vertex index 4 is out of range");
    // Reading through the .node path reports the same place, in the .ele file.
    let message = read_mesh(&node).unwrap_err().to_string();
    assert!(
        message.contains(&format!("{}:2:", ele.display())),
        "{message}"
    );
}

#[test]
fn tetgen_ele_with_more_entries_than_its_header() {
    let dir = TempDir::new("tetgen-extra");
    dir.write(
        "extra.node",
        "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n",
    );
    let ele = dir.write("extra.ele", "1 4 0\n0 0 1 2 3\n1 0 1 2 3\n");
    assert_error_in(&ele, 3, "more entries than the header's count 1");
}

// --- OBJ ---

const OBJ_TRIANGLE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

#[test]
fn obj_face_index_past_the_vertex_count() {
    let text = format!("{OBJ_TRIANGLE}f 1 2 3\nf 1 2 4\n");
    assert_error_at("range.obj", &text, 5, "vertex index 4 is out of range");
}

#[test]
fn obj_negative_index_reaching_before_the_first_vertex() {
    let text = format!("{OBJ_TRIANGLE}f -1 -2 -4\n");
    assert_error_at("negative.obj", &text, 4, "vertex index -4");
}

#[test]
fn obj_index_zero() {
    let text = format!("{OBJ_TRIANGLE}f 0 1 2\n");
    assert_error_at("zero.obj", &text, 4, "vertex index 0");
}

#[test]
fn obj_normal_index_past_the_normal_count() {
    let text = format!("{OBJ_TRIANGLE}vn 0 0 1\nf 1//1 2//1 3//2\n");
    assert_error_at("normal.obj", &text, 5, "normal index 2 is out of range");
}

#[test]
fn obj_malformed_face_vertex() {
    let text = format!("{OBJ_TRIANGLE}f 1/1/1/1 2 3\n");
    assert_error_at("slashes.obj", &text, 4, "found `1/1/1/1`");
}

#[test]
fn obj_face_with_two_vertices() {
    let text = format!("{OBJ_TRIANGLE}f 1 2\n");
    assert_error_at("two.obj", &text, 4, "at least 3 vertices, found 2");
}

#[test]
fn obj_non_number_coordinate() {
    let text = "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n";
    assert_error_at("nan.obj", text, 2, "expected a number, found `zero`");
}

#[test]
fn obj_without_faces_is_an_empty_mesh() {
    assert_error_at("no-faces.obj", OBJ_TRIANGLE, 3, "empty mesh");
}

// --- any format ---

#[test]
fn empty_file_is_an_empty_mesh_at_line_1() {
    assert_error_at("empty.mesh", "", 1, "empty mesh");
}

#[test]
fn non_utf8_file_names_the_line_of_the_bad_byte() {
    let dir = TempDir::new("binary");
    let path = dir.path().join("binary.mesh");
    std::fs::write(&path, b"v 0 0 0\nv 1 0 \xff\n").unwrap();
    assert_error_in(&path, 2, "not UTF-8");
}

#[test]
fn unrecognised_content_is_an_unknown_format() {
    let dir = TempDir::new("unknown");
    let path = dir.write("what.mesh", "# a comment\nsolid cube\n");
    let err = read_mesh(&path).unwrap_err();
    assert!(matches!(err, MeshError::UnknownFormat { .. }), "{err}");
    let message = err.to_string();
    assert!(
        message.contains("what.mesh") && message.contains("line 2"),
        "{message}"
    );
}

#[test]
fn missing_file_names_the_path() {
    let dir = TempDir::new("missing");
    let path = dir.path().join("nowhere.mesh");
    let err = read_mesh(&path).unwrap_err();
    assert!(matches!(err, MeshError::Io { .. }), "{err}");
    assert!(err.to_string().contains("nowhere.mesh"));
}
