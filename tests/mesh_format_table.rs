//! The mesh format table (`softbench::mesh::formats`): every registered format reads a small
//! sample of itself through `read_mesh`'s dispatch, by extension and (where it has a sniffer)
//! by content alone; a registered format without a sample here fails the test. Then the
//! dispatch's rules (content first, extension second) and a format registered at run time.

mod common;

use std::path::{Path, PathBuf};
use std::sync::Once;

use common::TempDir;
use nalgebra::Vector3;
use softbench::export::{VtuGrid, write_obj, write_vtu};
use softbench::mesh::formats::{MeshFormatEntry, Reader, Sniff};
use softbench::mesh::{
    AnyMesh, MESH_FORMATS, MeshError, MeshFormat, SurfaceMesh, TetMesh, read_mesh,
};

/// The unit right-corner tet, positively oriented, 0-based.
fn corner_tet() -> TetMesh {
    TetMesh {
        positions: corners(),
        tets: vec![[0, 1, 2, 3]],
    }
}

fn corners() -> Vec<Vector3<f64>> {
    vec![
        Vector3::new(0.0, 0.0, 0.0),
        Vector3::new(1.0, 0.0, 0.0),
        Vector3::new(0.0, 1.0, 0.0),
        Vector3::new(0.0, 0.0, 1.0),
    ]
}

/// A sample of a format: writes its file(s) into `dir` and returns the path to read and the
/// mesh it holds.
type Sample = fn(&TempDir) -> (PathBuf, AnyMesh);

/// One sample per registered format, by name. A format added to the table needs one here.
const SAMPLES: &[(&str, Sample)] = &[
    ("medit", |dir| {
        let text = "MeshVersionFormatted 1\nDimension 3\nVertices\n4\n0 0 0 0\n1 0 0 0\n\
                    0 1 0 0\n0 0 1 0\nTetrahedra\n1\n1 2 3 4 0\nEnd\n";
        (dir.write("medit.mesh", text), AnyMesh::Tet(corner_tet()))
    }),
    ("obj", |dir| {
        let mut bytes = Vec::new();
        write_obj(&mut bytes, "one triangle", &corners()[..3], &[[0, 1, 2]]).unwrap();
        let surface = SurfaceMesh {
            positions: corners()[..3].to_vec(),
            triangles: vec![[0, 1, 2]],
        };
        (write(dir, "surface.obj", &bytes), AnyMesh::Surface(surface))
    }),
    ("plain", |dir| {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nt 0 1 2 3\n";
        (dir.write("plain.mesh", text), AnyMesh::Tet(corner_tet()))
    }),
    ("tetgen", |dir| {
        dir.write("tg.node", "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n");
        (
            dir.write("tg.ele", "1 4 0\n1 1 2 3 4\n"),
            AnyMesh::Tet(corner_tet()),
        )
    }),
    ("gmsh", |dir| {
        let text = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n\
                    3 0 1 0\n4 0 0 1\n$EndNodes\n$Elements\n1\n1 4 2 0 0 1 2 3 4\n$EndElements\n";
        (dir.write("gmsh.msh", text), AnyMesh::Tet(corner_tet()))
    }),
    ("vtu", |dir| {
        let mut bytes = Vec::new();
        let points = corners();
        let grid = VtuGrid {
            points: &points,
            tets: &[[0, 1, 2, 3]],
            point_vectors: &[],
            cell_scalars: &[],
            time: None,
        };
        write_vtu(&mut bytes, &grid).unwrap();
        (write(dir, "frame.vtu", &bytes), AnyMesh::Tet(corner_tet()))
    }),
    ("vtk", |dir| {
        let text = "# vtk DataFile Version 4.2\nsample\nASCII\nDATASET UNSTRUCTURED_GRID\n\
                    POINTS 4 double\n0 0 0\n1 0 0\n0 1 0\n0 0 1\nCELLS 1 5\n4 0 1 2 3\n\
                    CELL_TYPES 1\n10\n";
        (dir.write("legacy.vtk", text), AnyMesh::Tet(corner_tet()))
    }),
    (TOY, |dir| {
        let text = "tets 1\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n";
        (dir.write("toy.tl", text), AnyMesh::Tet(corner_tet()))
    }),
];

fn write(dir: &TempDir, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// A format registered at run time, as a program that depends on softbench would: `tets 1`
/// and the four corners of one tet, one per line.
const TOY: &str = "toy-tets";

fn parse_toy(text: &str, path: &Path) -> Result<AnyMesh, MeshError> {
    let bad = |line| MeshError::Parse {
        path: path.to_path_buf(),
        line,
        message: "not a toy-tets file".into(),
    };
    let mut lines = text.lines();
    if lines.next() != Some("tets 1") {
        return Err(bad(1));
    }
    let mut positions = Vec::new();
    for (i, line) in lines.enumerate() {
        let x: Vec<f64> = line
            .split_whitespace()
            .map(|t| t.parse().map_err(|_| bad(i + 2)))
            .collect::<Result<_, _>>()?;
        positions.push(Vector3::new(x[0], x[1], x[2]));
    }
    Ok(AnyMesh::Tet(TetMesh {
        positions,
        tets: vec![[0, 1, 2, 3]],
    }))
}

/// Registers [`TOY`] once per test process (the tests of this file share the table).
fn register_toy() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        MESH_FORMATS
            .register(MeshFormatEntry {
                name: TOY,
                title: "toy tets",
                extensions: &["tl"],
                starts_with: "`tets 1`",
                sniff: |b| Sniff::sure_if(b.starts_with(b"tets 1\n")),
                reader: Reader::Text(parse_toy),
                description: "one tet, for the tests",
            })
            .unwrap();
    });
}

fn sample(name: &str) -> Sample {
    SAMPLES
        .iter()
        .find(|(n, _)| *n == name)
        .map(|&(_, s)| s)
        .unwrap_or_else(|| panic!("the mesh format `{name}` has no sample in SAMPLES"))
}

#[test]
fn every_registered_format_reads_its_sample_by_extension_and_by_content() {
    register_toy();
    let formats = MeshFormat::all();
    assert!(formats.len() >= 8, "{:?}", MeshFormat::names());
    for format in formats {
        let dir = TempDir::new(&format!("format-{}", format.name()));
        let (path, expected) = sample(format.name())(&dir);
        let (read_as, mesh) = read_mesh(&path).unwrap_or_else(|e| panic!("{}: {e}", format.name()));
        assert_eq!(read_as, format, "{}", path.display());
        assert_eq!(mesh, expected, "{}", path.display());
        // A format with a sniffer is also recognized without its extension.
        let bytes = std::fs::read(&path).unwrap();
        if (format.entry().sniff)(&bytes) != Sniff::No {
            let renamed = write(&dir, "sample.dat", &bytes);
            let (read_as, mesh) = read_mesh(&renamed).unwrap();
            assert_eq!((read_as, mesh), (format, expected), "{format} as .dat");
        } else {
            assert!(matches!(format.entry().reader, Reader::Files(_)));
        }
        // Every extension it claims is routed to it (by content, for a shared one).
        for ext in format.entry().extensions {
            let claimed: Vec<&str> = MeshFormat::all()
                .into_iter()
                .filter(|f| f.claims(ext))
                .map(MeshFormat::name)
                .collect();
            assert!(claimed.contains(&format.name()), "{ext}: {claimed:?}");
        }
    }
}

#[test]
fn every_sample_names_a_registered_format() {
    register_toy();
    for (name, _) in SAMPLES {
        assert!(MeshFormat::from_name(name).is_ok(), "{name}");
    }
}

#[test]
fn content_comes_before_the_extension() {
    let dir = TempDir::new("format-content-first");
    let (gmsh, _) = sample("gmsh")(&dir);
    let text = std::fs::read_to_string(&gmsh).unwrap();
    let misnamed = dir.write("gmsh.vtk", &text);
    assert_eq!(read_mesh(misnamed).unwrap().0.name(), "gmsh");
    // An extension whose format's signature is missing: that format's reader says what it
    // expected, at the line.
    let junk = dir.write("junk.vtk", "hello\n");
    let err = read_mesh(junk).unwrap_err().to_string();
    assert!(err.contains("junk.vtk:1:"), "{err}");
    assert!(err.contains("# vtk DataFile"), "{err}");
    // `.mesh` is claimed by two formats: the content decides, and without a hint the format
    // is unknown rather than guessed.
    let shared = dir.write("odd.mesh", "hello 1 2 3\n");
    let err = read_mesh(shared).unwrap_err();
    assert!(matches!(err, MeshError::UnknownFormat { .. }), "{err}");
    // Without an extension, OBJ's `f` records win over plain's `v` lines.
    let obj = dir.write("surface", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    assert_eq!(read_mesh(obj).unwrap().0.name(), "obj");
}

#[test]
fn an_unknown_format_message_lists_every_format_from_the_table() {
    register_toy();
    let dir = TempDir::new("format-unknown");
    let path = dir.write("what.txt", "\n\nhello there\n");
    let err = read_mesh(&path).unwrap_err().to_string();
    assert!(err.contains("line 3 starts with `hello`"), "{err}");
    for format in MeshFormat::all() {
        let e = format.entry();
        if e.starts_with.is_empty() {
            for ext in e.extensions {
                assert!(err.contains(&format!(".{ext}")), "{ext} not in {err}");
            }
        } else {
            assert!(
                err.contains(e.starts_with),
                "{} not in {err}",
                e.starts_with
            );
        }
    }
}
