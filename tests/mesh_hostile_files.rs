//! The malformed VTK and Gmsh files of issue 25, each generated here: refused with a
//! `MeshError` naming the file, the line and what is valid — never a panic, a dropped cell, a
//! silently replaced section or a decompression bomb inflated before its sizes are checked.

mod common;

use std::io::Write;
use std::path::Path;
use std::process::Command;

use common::TempDir;
use common::hostile::{accepted, refused};
use softbench::mesh::{MeshError, read_tet_mesh};

// --- legacy VTK ---

/// Two tets on five points; lines 12 and 13 hold the cell list, 15 and 16 the cell types.
const VTK42: &str = "# vtk DataFile Version 4.2\ntwo tets\nASCII\nDATASET UNSTRUCTURED_GRID\n\
POINTS 5 double\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\nCELLS 2 10\n4 0 1 2 3\n4 1 2 3 4\n\
CELL_TYPES 2\n10\n10\n";

/// The same in the 5.1 layout: offsets on line 13, connectivity on line 15, types on 17.
const VTK51: &str = "# vtk DataFile Version 5.1\ntwo tets\nASCII\nDATASET UNSTRUCTURED_GRID\n\
POINTS 5 double\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\nCELLS 3 8\nOFFSETS vtktypeint64\n0 4 8\n\
CONNECTIVITY vtktypeint64\n0 1 2 3 1 2 3 4\nCELL_TYPES 2\n10\n10\n";

#[test]
fn the_legacy_seeds_read() {
    for (name, text) in [("a.vtk", VTK42), ("b.vtk", VTK51)] {
        assert_eq!(
            accepted(name, text.as_bytes()).tets,
            vec![[0, 1, 2, 3], [1, 2, 3, 4]]
        );
    }
}

#[test]
fn a_huge_per_cell_count_is_refused_not_a_panic() {
    for count in [
        "1e300",
        "18446744073709551615",
        "1.8e19",
        "-1",
        "4.5",
        "nan",
        "inf",
    ] {
        let text = VTK42.replace(
            "CELLS 2 10\n4 0 1 2 3",
            &format!("CELLS 2 10\n{count} 0 1 2 3"),
        );
        refused(
            "count.vtk",
            text.as_bytes(),
            Some(12),
            "is not a count that fits",
        );
    }
    // A count that runs past the list.
    let text = VTK42.replace("4 1 2 3 4", "9 1 2 3 4");
    refused("past.vtk", text.as_bytes(), Some(12), "`9` is not a count");
}

#[test]
fn a_cell_type_that_is_not_an_exact_vtk_type_is_refused() {
    for kind in [
        "nan",
        "1e300",
        "-10",
        "9.99",
        "10.5",
        "inf",
        "256",
        "10.000001",
    ] {
        let text = VTK42.replace("10\n10\n", &format!("10\n{kind}\n"));
        let message = refused(
            "type.vtk",
            text.as_bytes(),
            Some(15),
            "is not a VTK cell type",
        );
        assert!(message.contains("a linear tet is 10"), "{message}");
    }
    // The same in a .vtu.
    let vtu = vtu_ascii("0 0 0 1 0 0 0 1 0 0 0 1", "0 1 2 3", "4", "10.5");
    refused("type.vtu", vtu.as_bytes(), None, "is not a VTK cell type");
}

#[test]
fn a_second_points_cells_or_cell_types_section_is_refused() {
    let points = VTK42.replace(
        "CELLS 2 10",
        "POINTS 5 double\n9 9 9\n1 0 0\n0 1 0\n0 0 1\n1 1 1\nCELLS 2 10",
    );
    refused(
        "points.vtk",
        points.as_bytes(),
        Some(11),
        "a second `POINTS`",
    );
    let cells = VTK42.replace("CELL_TYPES 2", "CELLS 1 5\n4 0 1 2 4\nCELL_TYPES 2");
    refused("cells.vtk", cells.as_bytes(), Some(14), "a second `CELLS`");
    let types = format!("{VTK42}CELL_TYPES 2\n10\n3\n");
    refused(
        "types.vtk",
        types.as_bytes(),
        Some(17),
        "a second `CELL_TYPES`",
    );
}

#[test]
fn legacy_offsets_not_starting_at_zero_are_refused() {
    let text = VTK51.replace("0 4 8\n", "1 4 8\n");
    refused(
        "offsets.vtk",
        text.as_bytes(),
        Some(13),
        "OFFSETS starts at 1",
    );
}

#[test]
fn a_wrong_cells_size_is_refused() {
    // 4.2: a size larger than the cells use (the extra entries are numbers).
    let text = VTK42.replace(
        "CELLS 2 10\n4 0 1 2 3\n4 1 2 3 4",
        "CELLS 2 11\n4 0 1 2 3\n4 1 2 3 4 7",
    );
    refused(
        "size.vtk",
        text.as_bytes(),
        Some(11),
        "announces a list of 11 entries",
    );
    // 4.2: smaller.
    let text = VTK42.replace("CELLS 2 10", "CELLS 2 9");
    refused(
        "small.vtk",
        text.as_bytes(),
        Some(12),
        "is not a count that fits",
    );
    // 5.1: a connectivity longer than the offsets say.
    let text = VTK51
        .replace("CELLS 3 8", "CELLS 3 9")
        .replace("2 3 4\n", "2 3 4 0\n");
    refused(
        "conn.vtk",
        text.as_bytes(),
        Some(13),
        "the connectivity holds 9 entries",
    );
}

#[test]
fn the_cli_exits_2_on_the_panicking_reproducer() {
    let dir = TempDir::new("hostile-cli");
    let text = VTK42.replace("CELLS 2 10\n4 0 1 2 3", "CELLS 2 10\n1e300 0 1 2 3");
    let path = dir.write("panic.vtk", &text);
    let out = Command::new(env!("CARGO_BIN_EXE_softbench"))
        .arg("mesh-info")
        .arg(&path)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("panic.vtk:12:"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

// --- VTU ---

fn vtu(encoding: &str, piece: (usize, usize), points: &str, cells: &str) -> String {
    format!(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\"{encoding}>\n\
         <UnstructuredGrid>\n<Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">\n\
         {points}{cells}</Piece>\n</UnstructuredGrid>\n</VTKFile>\n",
        piece.0, piece.1
    )
}

fn points_ascii(xyz: &str) -> String {
    format!(
        "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">{xyz}\
         </DataArray>\n</Points>\n"
    )
}

fn cells_ascii(conn: &str, offsets: &str, types: &str) -> String {
    format!(
        "<Cells>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">{conn}\
         </DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">{offsets}\
         </DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">{types}\
         </DataArray>\n</Cells>\n"
    )
}

fn vtu_ascii(xyz: &str, conn: &str, offsets: &str, types: &str) -> String {
    let n = xyz.split_whitespace().count() / 3;
    let m = types.split_whitespace().count();
    vtu(
        "",
        (n, m),
        &points_ascii(xyz),
        &cells_ascii(conn, offsets, types),
    )
}

const XYZ: &str = "0 0 0 1 0 0 0 1 0 0 0 1";

#[test]
fn a_second_points_or_cells_element_is_refused() {
    let points = points_ascii(XYZ);
    let cells = cells_ascii("0 1 2 3", "4", "10");
    assert_eq!(
        accepted("ok.vtu", vtu("", (4, 1), &points, &cells).as_bytes()).tets,
        vec![[0, 1, 2, 3]]
    );
    let twice = format!("{points}{}", points_ascii("9 9 9 1 0 0 0 1 0 0 0 1"));
    refused(
        "points.vtu",
        vtu("", (4, 1), &twice, &cells).as_bytes(),
        Some(8),
        "a second `<Points>`",
    );
    let twice = format!("{cells}{}", cells_ascii("0 1 2 3", "4", "3"));
    refused(
        "cells.vtu",
        vtu("", (4, 1), &points, &twice).as_bytes(),
        Some(13),
        "a second `<Cells>`",
    );
    // A second connectivity array inside one `<Cells>`.
    let doubled = cells.replace(
        "</Cells>",
        "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">0 1 2 3</DataArray>\n\
         </Cells>",
    );
    refused(
        "conn.vtu",
        vtu("", (4, 1), &points, &doubled).as_bytes(),
        Some(12),
        "a second `connectivity`",
    );
}

#[test]
fn an_ascii_array_longer_than_its_counts_allow_is_refused() {
    // Two types for one cell: the error comes at the extra value, not after reading them all.
    let text = vtu_ascii(XYZ, "0 1 2 3", "4", "10");
    let text = text.replace(">10</DataArray>", ">10 10</DataArray>");
    refused(
        "types.vtu",
        text.as_bytes(),
        Some(11),
        "more than the 1 values",
    );
}

/// Standard base64 with padding.
fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let x = u32::from(b[0]) << 16 | u32::from(b[1]) << 8 | u32::from(b[2]);
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(A[(x >> (18 - 6 * i)) as usize & 63] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

fn zlib(data: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    e.write_all(data).unwrap();
    e.finish().unwrap()
}

/// A zlib-compressed array as VTK writes it (UInt32 headers): one block table, then the
/// blocks; `declared` overrides the sizes in the table (blocks, block size, last size).
fn zlib_array(kind: &str, name: &str, data: &[u8], declared: Option<[u32; 3]>) -> String {
    let block = zlib(data);
    let [blocks, size, last] = declared.unwrap_or([1, data.len() as u32, data.len() as u32]);
    let mut header = Vec::new();
    for v in [blocks, size, last, block.len() as u32] {
        header.extend(v.to_le_bytes());
    }
    format!(
        "<DataArray type=\"{kind}\" Name=\"{name}\" NumberOfComponents=\"{}\" format=\"binary\">\
         {}{}</DataArray>\n",
        if name.is_empty() { 3 } else { 1 },
        base64(&header),
        base64(&block)
    )
}

fn zlib_grid(n: usize, m: usize, points: &str, cells: &str) -> String {
    vtu(
        " compressor=\"vtkZLibDataCompressor\"",
        (n, m),
        &format!("<Points>\n{points}</Points>\n"),
        &format!("<Cells>\n{cells}</Cells>\n"),
    )
}

fn f64_bytes(values: &[f64]) -> Vec<u8> {
    values.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn zlib_cells() -> String {
    let conn: Vec<u8> = [0i64, 1, 2, 3]
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    format!(
        "{}{}{}",
        zlib_array("Int64", "connectivity", &conn, None),
        zlib_array("Int64", "offsets", &4i64.to_le_bytes(), None),
        zlib_array("UInt8", "types", &[10], None)
    )
}

#[test]
fn a_zlib_vtu_reads() {
    let xyz = f64_bytes(&[0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1.]);
    let text = zlib_grid(4, 1, &zlib_array("Float64", "", &xyz, None), &zlib_cells());
    assert_eq!(accepted("ok.vtu", text.as_bytes()).tets, vec![[0, 1, 2, 3]]);
}

#[test]
fn a_decompression_bomb_is_refused_before_it_is_inflated() {
    // 8 MB of zeros compress to a few kB; four points need 96 bytes.
    let zeros = vec![0u8; 8 << 20];
    let text = zlib_grid(
        4,
        1,
        &zlib_array("Float64", "", &zeros, None),
        &zlib_cells(),
    );
    assert!(text.len() < 64 << 10, "{}", text.len());
    let message = refused(
        "bomb.vtu",
        text.as_bytes(),
        Some(6),
        "declares 8388608 bytes, more than the 96 bytes the grid's counts allow",
    );
    assert!(message.contains("`Points`"), "{message}");
    // Counts large enough to allow it, but a header that claims more than zlib can inflate
    // its few compressed bytes to.
    let lie = zlib_array("Float64", "", &[0u8; 96], Some([1, 1 << 30, 1 << 30]));
    refused(
        "lie.vtu",
        zlib_grid(10_000_000, 1, &lie, &zlib_cells()).as_bytes(),
        Some(6),
        "more than the 240000000 bytes the grid's counts allow",
    );
    let lie = zlib_array("Float64", "", &[0u8; 96], Some([1, 100 << 20, 100 << 20]));
    refused(
        "ratio.vtu",
        zlib_grid(10_000_000, 1, &lie, &zlib_cells()).as_bytes(),
        Some(6),
        "more than zlib can inflate them to",
    );
    // A types array (UInt8: 8x as f64) of a million cells for a grid of one.
    let types = zlib_array("UInt8", "types", &vec![10u8; 1 << 20], None);
    let cells = zlib_cells().replace(&zlib_array("UInt8", "types", &[10], None), &types);
    let xyz = f64_bytes(&[0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1.]);
    refused(
        "types.vtu",
        zlib_grid(4, 1, &zlib_array("Float64", "", &xyz, None), &cells).as_bytes(),
        None,
        "more than the 1 bytes the grid's counts allow",
    );
}

#[test]
fn an_uncompressed_binary_array_larger_than_its_counts_allow_is_refused() {
    let mut raw = (1u32 << 20).to_le_bytes().to_vec();
    raw.extend(vec![0u8; 1 << 20]);
    let points = format!(
        "<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"binary\">{}</DataArray>\n",
        base64(&raw)
    );
    let text = vtu(
        "",
        (4, 1),
        &format!("<Points>\n{points}</Points>\n"),
        &cells_ascii("0 1 2 3", "4", "10"),
    );
    refused(
        "raw.vtu",
        text.as_bytes(),
        Some(6),
        "declares 1048576 bytes, more than the 96 bytes",
    );
}

// --- Gmsh ---

const MSH22: &str = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n\
                     3 0 1 0\n4 0 0 1\n$EndNodes\n$Elements\n1\n1 4 2 0 0 1 2 3 4\n$EndElements\n";

#[test]
fn negative_gmsh_22_tags_are_refused() {
    let element = |line: &str| MSH22.replace("1 4 2 0 0 1 2 3 4", line);
    refused(
        "number.msh",
        element("-1 4 2 0 0 1 2 3 4").as_bytes(),
        Some(13),
        "element tag -1 is not positive",
    );
    refused(
        "ntags.msh",
        element("1 4 -2 1 2 3 4").as_bytes(),
        Some(13),
        "cannot be negative",
    );
    refused(
        "physical.msh",
        element("1 4 2 -5 1 1 2 3 4").as_bytes(),
        Some(13),
        "physical tag -5 is negative",
    );
    refused(
        "entity.msh",
        element("1 4 2 0 -7 1 2 3 4").as_bytes(),
        Some(13),
        "elementary entity tag -7",
    );
    // A ghost cell's partition id is negative, and legal.
    let ghost = accepted("ghost.msh", element("1 4 4 0 1 1 -2 1 2 3 4").as_bytes());
    assert_eq!(ghost.tets, vec![[0, 1, 2, 3]]);
}

#[test]
fn negative_gmsh_22_binary_element_numbers_are_refused() {
    let mut binary = b"$MeshFormat\n2.2 1 8\n".to_vec();
    binary.extend(1i32.to_le_bytes());
    binary.extend(b"\n$EndMeshFormat\n$Nodes\n4\n");
    for (i, p) in [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0f64],
    ]
    .iter()
    .enumerate()
    {
        binary.extend((i as i32 + 1).to_le_bytes());
        p.iter().for_each(|x| binary.extend(x.to_le_bytes()));
    }
    binary.extend(b"\n$EndNodes\n$Elements\n1\n");
    let element = |number: i32, physical: i32| {
        let mut b = binary.clone();
        for v in [4i32, 1, 2, number, physical, 0, 1, 2, 3, 4] {
            b.extend(v.to_le_bytes());
        }
        b.extend(b"\n$EndElements\n");
        b
    };
    accepted("ok.msh", &element(1, 0));
    refused(
        "number.msh",
        &element(-3, 0),
        None,
        "element tag -3 is not positive",
    );
    refused(
        "physical.msh",
        &element(1, -3),
        None,
        "physical tag -3 is negative",
    );
}

// --- Unknown format ---

#[test]
fn an_unknown_binary_file_is_quoted_short_and_escaped() {
    // A process environment block: NUL-separated, no whitespace, 554 bytes.
    let mut environ = Vec::new();
    while environ.len() < 554 {
        environ.extend(b"SOME_VARIABLE=some/value\0\x1b[2J");
    }
    environ.truncate(554);
    let dir = TempDir::new("hostile-unknown");
    let path = dir.path().join("environ");
    std::fs::write(&path, &environ).unwrap();
    let err = read_tet_mesh(&path).unwrap_err();
    let message = err.to_string();
    assert!(matches!(err, MeshError::UnknownFormat { .. }), "{message}");
    assert!(message.contains("unknown mesh format"), "{message}");
    assert!(
        message.contains("SOME_VARIABLE=some/value\\0\\u{1b}[2J"),
        "{message}"
    );
    assert!(
        !message.chars().any(|c| c.is_control() && c != '\n'),
        "{message:?}"
    );
    let quoted = message.split('`').nth(1).unwrap();
    assert!(quoted.len() < 100 && quoted.ends_with("..."), "{quoted}");
    assert!(Path::new(&path).exists());
}
