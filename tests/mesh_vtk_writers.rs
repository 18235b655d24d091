//! Files written by VTK's own writers (Python's `vtk` module, Debian's `python3-vtk9`) read
//! back with exactly the points and tets VTK's own readers find in them: every data mode of
//! `vtkXMLUnstructuredGridWriter` (ascii, inline binary, appended raw and base64), each
//! compressor (none, zlib, LZ4, LZMA), both header types, both byte orders, 32-bit
//! connectivity and Float32 points; `vtkUnstructuredGridWriter` ASCII and BINARY in the 5.1 and 4.2 layouts,
//! and files VTK has read and written again. The grids carry what VTK adds around the mesh —
//! `<InformationKey>` elements and `METADATA` blocks (an array with a units label), field data
//! (a time and a string), cell data, and a triangle and a vertex among the tets.
//!
//! Under CI (`CI` set) a Python without `vtk` fails the test; otherwise it prints a
//! `skipped:` line and passes.

mod common;

use std::io::Write;
use std::process::Command;

use common::TempDir;
use softbench::mesh::{TetMesh, read_mesh, read_tet_mesh};

/// The first Python that imports `vtk`: Debian's `/usr/bin/python3` (where `python3-vtk9`
/// installs it) or the `python3` on `PATH`. When none does: under CI the test fails;
/// otherwise it prints a `skipped:` line and returns `None`.
fn python_with_vtk() -> Option<&'static str> {
    let mut why = Vec::new();
    for python in ["/usr/bin/python3", "python3"] {
        match Command::new(python)
            .args(["-c", "import vtk; print(vtk.vtkVersion.GetVTKVersion())"])
            .output()
        {
            Ok(o) if o.status.success() => return Some(python),
            Ok(o) => why.push(format!(
                "{python}: {}",
                String::from_utf8_lossy(&o.stderr)
                    .trim()
                    .lines()
                    .last()
                    .unwrap_or("")
            )),
            Err(e) => why.push(format!("{python}: {e}")),
        }
    }
    let why = why.join("; ");
    assert!(
        std::env::var_os("CI").is_none(),
        "CI is set but no Python imports vtk ({why}); .ci/run installs python3-vtk9"
    );
    let test = std::thread::current().name().unwrap_or("?").to_string();
    let _ = writeln!(
        std::io::stderr(),
        "skipped: {test}: no Python imports vtk ({why}); `apt-get install python3-vtk9` to run it"
    );
    None
}

/// A small mesh with coordinates that are not round numbers (so every digit is checked).
fn known_mesh() -> TetMesh {
    let mut mesh = softbench::mesh::box_mesh([2, 1, 1], [0.3, 0.2, 0.1]);
    for (i, p) in mesh.positions.iter_mut().enumerate() {
        p.x += 1e-3 * (i as f64).sin() + 1.0 / 3.0;
        p.z -= 7e-4 * (i as f64 * 0.7).cos();
    }
    mesh
}

/// Builds the grid (`grid(float32)`), with what VTK writes around a mesh.
const GRID: &str = r#"
import json, sys, vtk

def grid(float32=False):
    pts = vtk.vtkPoints()
    if float32:
        pts.SetDataTypeToFloat()
    else:
        pts.SetDataTypeToDouble()
    for p in POINTS:
        pts.InsertNextPoint(*p)
    g = vtk.vtkUnstructuredGrid()
    g.SetPoints(pts)
    half = len(TETS) // 2
    for t in TETS[:half]:
        g.InsertNextCell(vtk.VTK_TETRA, 4, t)
    # Other linear cells, which the reader reads past.
    g.InsertNextCell(vtk.VTK_TRIANGLE, 3, TETS[0][:3])
    g.InsertNextCell(vtk.VTK_VERTEX, 1, TETS[0][:1])
    for t in TETS[half:]:
        g.InsertNextCell(vtk.VTK_TETRA, 4, t)
    # A point array with an information key: <InformationKey> in XML, METADATA in legacy.
    v = vtk.vtkDoubleArray()
    v.SetName("velocity")
    v.SetNumberOfComponents(3)
    for i in range(len(POINTS)):
        v.InsertNextTuple3(i, -2.0 * i, 0.5)
    v.GetInformation().Set(vtk.vtkDataArray.UNITS_LABEL(), "m/s")
    g.GetPointData().AddArray(v)
    region = vtk.vtkIntArray()
    region.SetName("region")
    for i in range(g.GetNumberOfCells()):
        region.InsertNextValue(i % 3)
    g.GetCellData().AddArray(region)
    time = vtk.vtkDoubleArray()
    time.SetName("TimeValue")
    time.InsertNextValue(0.25)
    g.GetFieldData().AddArray(time)
    note = vtk.vtkStringArray()
    note.SetName("note")
    note.InsertNextValue("written by VTK")
    g.GetFieldData().AddArray(note)
    return g

# A name starting with F32 has Float32 points; with I32, 32-bit connectivity and offsets.
def grid_for(name):
    g = grid(float32=name.startswith("F32"))
    if name.startswith("I32"):
        assert g.GetCells().ConvertTo32BitStorage()
    return g

def xml(name, setup):
    w = vtk.vtkXMLUnstructuredGridWriter()
    w.SetFileName(OUT + "/" + name)
    w.SetInputData(grid_for(name))
    setup(w)
    assert w.Write() == 1, name

def legacy(name, setup, data=None):
    w = vtk.vtkUnstructuredGridWriter()
    w.SetFileName(OUT + "/" + name)
    w.SetInputData(data if data is not None else grid_for(name))
    setup(w)
    assert w.Write() == 1, name

def read_back(name):
    if name.endswith(".vtu"):
        r = vtk.vtkXMLUnstructuredGridReader()
    else:
        r = vtk.vtkUnstructuredGridReader()
    r.SetFileName(OUT + "/" + name)
    r.Update()
    return r.GetOutput()

def mesh_of(g):
    points = [list(g.GetPoint(i)) for i in range(g.GetNumberOfPoints())]
    tets = []
    for c in range(g.GetNumberOfCells()):
        if g.GetCellType(c) == vtk.VTK_TETRA:
            ids = g.GetCell(c).GetPointIds()
            tets.append([ids.GetId(k) for k in range(4)])
    return {"points": points, "tets": tets}
"#;

/// (file, writer calls on `w`, what the file must contain so the mode is the one meant).
/// `F32` starting a name writes Float32 points, `I32` 32-bit connectivity and offsets.
const XML_FILES: &[(&str, &str, &[&str])] = &[
    (
        "ascii.vtu",
        "w.SetDataModeToAscii()",
        &["format=\"ascii\"", "<InformationKey"],
    ),
    (
        "binary.vtu",
        "w.SetDataModeToBinary(); w.SetCompressorTypeToNone()",
        &["format=\"binary\"", "<InformationKey"],
    ),
    (
        "binary_zlib.vtu",
        "w.SetDataModeToBinary(); w.SetCompressorTypeToZLib()",
        &["format=\"binary\"", "vtkZLibDataCompressor"],
    ),
    (
        "binary_lz4.vtu",
        "w.SetDataModeToBinary(); w.SetCompressorTypeToLZ4()",
        &["format=\"binary\"", "vtkLZ4DataCompressor"],
    ),
    (
        "binary_lzma.vtu",
        "w.SetDataModeToBinary(); w.SetCompressorTypeToLZMA()",
        &["format=\"binary\"", "vtkLZMADataCompressor"],
    ),
    (
        "appended_raw.vtu",
        "w.SetDataModeToAppended(); w.SetEncodeAppendedData(0); w.SetCompressorTypeToNone()",
        &["encoding=\"raw\"", "format=\"appended\""],
    ),
    (
        "appended_raw_zlib.vtu",
        "w.SetDataModeToAppended(); w.SetEncodeAppendedData(0); w.SetCompressorTypeToZLib()",
        &["encoding=\"raw\"", "vtkZLibDataCompressor"],
    ),
    (
        "appended_raw_lz4.vtu",
        "w.SetDataModeToAppended(); w.SetEncodeAppendedData(0); w.SetCompressorTypeToLZ4()",
        &["encoding=\"raw\"", "vtkLZ4DataCompressor"],
    ),
    (
        "appended_raw_lzma.vtu",
        "w.SetDataModeToAppended(); w.SetEncodeAppendedData(0); w.SetCompressorTypeToLZMA()",
        &["encoding=\"raw\"", "vtkLZMADataCompressor"],
    ),
    (
        "appended_base64.vtu",
        "w.SetDataModeToAppended(); w.SetEncodeAppendedData(1); w.SetCompressorTypeToNone()",
        &["encoding=\"base64\""],
    ),
    (
        "appended_base64_zlib.vtu",
        "w.SetDataModeToAppended(); w.SetEncodeAppendedData(1); w.SetCompressorTypeToZLib()",
        &["encoding=\"base64\"", "vtkZLibDataCompressor"],
    ),
    (
        "appended_base64_lzma.vtu",
        "w.SetDataModeToAppended(); w.SetEncodeAppendedData(1); w.SetCompressorTypeToLZMA()",
        &["encoding=\"base64\"", "vtkLZMADataCompressor"],
    ),
    (
        "uint64_appended_zlib.vtu",
        "w.SetHeaderTypeToUInt64(); w.SetDataModeToAppended(); w.SetEncodeAppendedData(0); \
         w.SetCompressorTypeToZLib()",
        &["header_type=\"UInt64\"", "encoding=\"raw\""],
    ),
    (
        "uint64_binary.vtu",
        "w.SetHeaderTypeToUInt64(); w.SetDataModeToBinary(); w.SetCompressorTypeToNone()",
        &["header_type=\"UInt64\"", "format=\"binary\""],
    ),
    (
        "big_endian_appended_zlib.vtu",
        "w.SetByteOrderToBigEndian(); w.SetDataModeToAppended(); w.SetEncodeAppendedData(0); \
         w.SetCompressorTypeToZLib()",
        &["byte_order=\"BigEndian\"", "encoding=\"raw\""],
    ),
    (
        "big_endian_binary.vtu",
        "w.SetByteOrderToBigEndian(); w.SetDataModeToBinary(); w.SetCompressorTypeToNone()",
        &["byte_order=\"BigEndian\"", "format=\"binary\""],
    ),
    (
        "I32_binary_zlib.vtu",
        "w.SetDataModeToBinary(); w.SetCompressorTypeToZLib()",
        &[
            "type=\"Int32\" Name=\"connectivity\"",
            "type=\"Int32\" Name=\"offsets\"",
        ],
    ),
    (
        "I32_ascii.vtu",
        "w.SetDataModeToAscii()",
        &["type=\"Int32\" Name=\"connectivity\""],
    ),
    (
        "F32_appended_raw.vtu",
        "w.SetDataModeToAppended(); w.SetEncodeAppendedData(0)",
        &["type=\"Float32\" Name=\"Points\""],
    ),
    // VTK's defaults, whatever they are.
    ("default.vtu", "None", &["<AppendedData"]),
];

/// Legacy files: (file, writer calls on `w`, what the file must contain).
const LEGACY_FILES: &[(&str, &str, &[&str])] = &[
    (
        "legacy_ascii.vtk",
        "None",
        &["Version 5.1", "ASCII", "OFFSETS", "METADATA", "FIELD"],
    ),
    (
        "legacy_binary.vtk",
        "w.SetFileTypeToBinary()",
        &["Version 5.1", "BINARY", "OFFSETS", "METADATA", "FIELD"],
    ),
    (
        "legacy42_ascii.vtk",
        "w.SetFileVersion(42)",
        &["Version 4.2", "ASCII", "CELLS", "METADATA"],
    ),
    (
        "legacy42_binary.vtk",
        "w.SetFileVersion(42); w.SetFileTypeToBinary()",
        &["Version 4.2", "BINARY", "CELLS", "METADATA"],
    ),
    (
        "F32_legacy_binary.vtk",
        "w.SetFileTypeToBinary()",
        &["BINARY", "float"],
    ),
];

#[test]
fn files_written_by_vtk_read_back_as_vtk_reads_them() {
    let Some(python) = python_with_vtk() else {
        return;
    };
    let dir = TempDir::new("mesh-vtk-writers");
    let mesh = known_mesh();
    let points: Vec<String> = mesh
        .positions
        .iter()
        .map(|p| format!("[{:?}, {:?}, {:?}]", p.x, p.y, p.z))
        .collect();
    let tets: Vec<String> = mesh.tets.iter().map(|t| format!("{t:?}")).collect();
    let mut script = format!(
        "POINTS = [{}]\nTETS = [{}]\nOUT = {:?}\n{GRID}",
        points.join(", "),
        tets.join(", "),
        dir.path().to_str().unwrap()
    );
    for (name, setup, _) in XML_FILES {
        script += &format!("xml({name:?}, lambda w: [{}])\n", setup.replace(';', ","));
    }
    for (name, setup, _) in LEGACY_FILES {
        script += &format!(
            "legacy({name:?}, lambda w: [{}])\n",
            setup.replace(';', ",")
        );
    }
    // Read and written again: a legacy binary file, and an appended .vtu as legacy ASCII.
    script += "legacy('round_trip_binary.vtk', lambda w: w.SetFileTypeToBinary(), \
               read_back('legacy_binary.vtk'))\n\
               legacy('round_trip_ascii.vtk', lambda w: None, \
               read_back('appended_raw_zlib.vtu'))\n";
    let round_trips: &[(&str, &str, &[&str])] = &[
        ("round_trip_binary.vtk", "", &["BINARY", "FIELD"]),
        ("round_trip_ascii.vtk", "", &["ASCII", "FIELD"]),
    ];
    let all: Vec<&(&str, &str, &[&str])> = XML_FILES
        .iter()
        .chain(LEGACY_FILES)
        .chain(round_trips)
        .collect();
    script += "print(json.dumps({name: mesh_of(read_back(name)) for name in [";
    for (name, _, _) in &all {
        script += &format!("{name:?}, ");
    }
    script += "]}))\n";
    let out = Command::new(python)
        .args(["-c", &script])
        .output()
        .expect("cannot run python");
    assert!(
        out.status.success(),
        "the VTK script failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let seen: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for (name, _, needles) in all {
        let path = dir.path().join(name);
        let content = String::from_utf8_lossy(&std::fs::read(&path).unwrap()).into_owned();
        for needle in *needles {
            assert!(
                content.contains(needle),
                "{name}: VTK did not write `{needle}`"
            );
        }
        // What VTK's own reader makes of the file.
        let vtk = &seen[name];
        let vtk_points: Vec<[f64; 3]> = serde_json::from_value(vtk["points"].clone()).unwrap();
        let vtk_tets: Vec<[usize; 4]> = serde_json::from_value(vtk["tets"].clone()).unwrap();
        // It is the mesh written (legacy ASCII prints 11 significant digits, Float32 has 24
        // bits)...
        assert_eq!(vtk_tets, mesh.tets, "{name}: VTK's reader");
        assert_eq!(vtk_points.len(), mesh.num_vertices(), "{name}");
        for (a, b) in vtk_points.iter().zip(&mesh.positions) {
            for k in 0..3 {
                assert!((a[k] - b[k]).abs() <= 1e-6, "{name}: {a:?} vs {b:?}");
            }
        }
        // ...and softbench reads exactly what VTK reads.
        let (format, _) = read_mesh(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        let expected = if name.ends_with(".vtu") { "vtu" } else { "vtk" };
        assert_eq!(format.name(), expected, "{name}");
        let read = read_tet_mesh(&path).unwrap();
        assert_eq!(read.tets, vtk_tets, "{name}");
        let read_points: Vec<[f64; 3]> = read.positions.iter().map(|p| [p.x, p.y, p.z]).collect();
        assert_eq!(read_points, vtk_points, "{name}");
    }
}
