//! Gmsh `.msh` (2.2 and 4.1, ASCII and binary) and VTK (`.vtu`, legacy `.vtk` ASCII and
//! binary) input: files written by an independent writer (Python's meshio) read back with the same counts,
//! coordinates and tets; bad files give `file:line` errors and no panic; a run restarted from
//! an exported VTU frame (`[initial] from`) continues exactly as the uninterrupted run.

mod common;

use std::io::Write;
use std::path::Path;
use std::process::Command;

use common::{TempDir, simulate, softbench};
use softbench::mesh::{TetMesh, read_mesh, read_tet_mesh};

/// Runs a Python script with meshio imported. When meshio cannot be imported: under CI (`CI`
/// set) the test fails; otherwise it prints a visible `skipped:` line and returns `None`.
fn run_with_meshio(script: &str) -> Option<String> {
    let probe = Command::new("python3")
        .args(["-c", "import meshio"])
        .output();
    if !probe.as_ref().is_ok_and(|o| o.status.success()) {
        let why = match &probe {
            Ok(o) => String::from_utf8_lossy(&o.stderr)
                .trim()
                .lines()
                .last()
                .unwrap_or("")
                .to_owned(),
            Err(e) => format!("cannot run python3: {e}"),
        };
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set but Python's meshio is not importable ({why}); .ci/run installs it"
        );
        let test = std::thread::current().name().unwrap_or("?").to_string();
        let _ = writeln!(
            std::io::stderr(),
            "skipped: {test}: Python's meshio is not importable ({why}); \
             `python3 -m pip install meshio` to run it"
        );
        return None;
    }
    let out = Command::new("python3")
        .args(["-c", &format!("import json, meshio, numpy\n{script}")])
        .output()
        .expect("cannot run python3");
    assert!(
        out.status.success(),
        "meshio script failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(String::from_utf8(out.stdout).unwrap())
}

/// A small mesh with coordinates that are not round numbers (so every digit is checked).
fn known_mesh() -> TetMesh {
    let mut mesh = softbench::mesh::box_mesh([2, 2, 1], [0.3, 0.2, 0.1]);
    for (i, p) in mesh.positions.iter_mut().enumerate() {
        p.x += 1e-3 * (i as f64).sin() + 1.0 / 3.0;
        p.y -= 7e-4 * (i as f64 * 0.7).cos();
    }
    mesh
}

#[test]
fn files_written_by_meshio_read_back_with_the_same_points_and_tets() {
    let dir = TempDir::new("mesh-formats-meshio");
    let mesh = known_mesh();
    let points: Vec<String> = mesh
        .positions
        .iter()
        .map(|p| format!("[{:?}, {:?}, {:?}]", p.x, p.y, p.z))
        .collect();
    let tets: Vec<String> = mesh.tets.iter().map(|t| format!("{t:?}")).collect();
    // (file name, meshio format, keyword arguments): every writer meshio has for tets.
    let files = [
        ("g22a.msh", "gmsh22", "binary=False"),
        ("g22b.msh", "gmsh22", "binary=True"),
        ("g41a.msh", "gmsh", "binary=False"),
        ("g41b.msh", "gmsh", "binary=True"),
        ("ascii.vtu", "vtu", "binary=False"),
        ("raw.vtu", "vtu", "binary=True, compression=None"),
        ("zlib.vtu", "vtu", "binary=True"),
        ("legacy.vtk", "vtk", "binary=False"),
        ("legacy_binary.vtk", "vtk", "binary=True"),
    ];
    let mut script = format!(
        "import warnings\nwarnings.simplefilter('ignore')\n\
         m = meshio.Mesh(numpy.array([{}]), [('tetra', numpy.array([{}]))])\n",
        points.join(","),
        tets.join(",")
    );
    for (name, format, kwargs) in files {
        let path = dir.path().join(name);
        script += &format!(
            "m.write({:?}, file_format={format:?}, {kwargs})\n",
            path.to_str().unwrap()
        );
    }
    script += "print('written')\n";
    let Some(_) = run_with_meshio(&script) else {
        return;
    };
    for (name, _, _) in files {
        let path = dir.path().join(name);
        let (format, _) = read_mesh(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        let expected = match name.rsplit('.').next() {
            Some("msh") => "gmsh",
            Some("vtu") => "vtu",
            _ => "vtk",
        };
        assert_eq!(format.name(), expected, "{name}");
        let read = read_tet_mesh(&path).unwrap();
        assert_eq!(read.num_vertices(), mesh.num_vertices(), "{name}");
        assert_eq!(read.tets, mesh.tets, "{name}");
        for (v, (a, b)) in read.positions.iter().zip(&mesh.positions).enumerate() {
            if name == "ascii.vtu" {
                // meshio's ASCII VTU writer prints 12 significant digits.
                assert!(
                    (a - b).amax() <= 1e-11 * b.amax().max(1.0),
                    "{name}: vertex {v}"
                );
            } else {
                // Binary files are exact; the other ASCII writers print 17 significant
                // digits, which round-trip.
                assert_eq!(a, b, "{name}: vertex {v}");
            }
        }
    }
    // mesh-info names the new formats.
    for (name, shown) in [("g41b.msh", "Gmsh .msh"), ("zlib.vtu", "VTK XML .vtu")] {
        let out = softbench(&["mesh-info", dir.path().join(name).to_str().unwrap()]);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{name}: {stdout}");
        assert!(stdout.contains(shown), "{name}: {stdout}");
        assert!(
            stdout.contains(&format!("tets                {}", mesh.num_tets())),
            "{stdout}"
        );
    }
}

/// The error for `content` written as `name`, which must name the file and `line`.
fn error_at(dir: &TempDir, name: &str, content: &[u8], line: usize, needle: &str) {
    let path = dir.path().join(name);
    std::fs::write(&path, content).unwrap();
    let result = std::panic::catch_unwind(|| read_tet_mesh(&path));
    let err = match result {
        Ok(Ok(_)) => panic!("{name}: a bad file was accepted"),
        Ok(Err(e)) => e.to_string(),
        Err(_) => panic!("{name}: the reader panicked"),
    };
    let prefix = format!("{}:{line}: ", path.display());
    assert!(
        err.starts_with(&prefix),
        "{name}: expected `{prefix}...`, got `{err}`"
    );
    assert!(
        err.contains(needle),
        "{name}: expected `{needle}` in `{err}`"
    );
}

const MSH22: &str = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n\
                     3 0 1 0\n4 0 0 1\n$EndNodes\n$Elements\n1\n1 4 2 0 0 1 2 3 4\n$EndElements\n";

const MSH41: &str = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 4 1 4\n3 0 0 4\n1\n2\n3\n4\n\
                     0 0 0\n1 0 0\n0 1 0\n0 0 1\n$EndNodes\n$Elements\n1 1 1 1\n3 0 4 1\n\
                     1 1 2 3 4\n$EndElements\n";

const VTK42: &str = "# vtk DataFile Version 4.2\nhand written\nASCII\nDATASET UNSTRUCTURED_GRID\n\
                     POINTS 4 double\n0 0 0\n1 0 0\n0 1 0\n0 0 1\nCELLS 1 5\n4 0 1 2 3\n\
                     CELL_TYPES 1\n10\n";

#[test]
fn well_formed_hand_written_files_of_each_format_read() {
    let dir = TempDir::new("mesh-formats-good");
    for (name, content) in [("a.msh", MSH22), ("b.msh", MSH41), ("c.vtk", VTK42)] {
        let mesh = read_tet_mesh(dir.write(name, content)).unwrap();
        assert_eq!(
            (mesh.num_vertices(), mesh.tets.clone()),
            (4, vec![[0, 1, 2, 3]]),
            "{name}"
        );
        assert!((mesh.total_volume() - 1.0 / 6.0).abs() < 1e-15);
    }
}

#[test]
fn bad_files_of_each_format_give_file_and_line_errors_without_panicking() {
    let dir = TempDir::new("mesh-formats-bad");
    error_at(
        &dir,
        "version.msh",
        MSH22.replace("2.2 0 8", "3.0 0 8").as_bytes(),
        2,
        "version",
    );
    error_at(
        &dir,
        "node.msh",
        MSH22.replace("3 0 1 0", "3 0 one 0").as_bytes(),
        8,
        "coordinate",
    );
    error_at(
        &dir,
        "missing.msh",
        MSH22.replace("1 2 3 4\n$End", "1 2 3 9\n$End").as_bytes(),
        13,
        "node tag 9",
    );
    error_at(
        &dir,
        "count.msh",
        MSH22.replace("$Nodes\n4", "$Nodes\n5").as_bytes(),
        10,
        "node tag",
    );
    error_at(
        &dir,
        "tet10.msh",
        MSH41.replace("3 0 4 1", "3 0 11 1").as_bytes(),
        18,
        "second-order",
    );
    error_at(
        &dir,
        "blocks.msh",
        MSH41
            .replace("1 4 1 4\n3 0 0 4", "1 4 1 4\n3 0 0 3")
            .as_bytes(),
        13,
        "announced",
    );
    error_at(
        &dir,
        "end.msh",
        MSH41.replace("$EndElements\n", "").as_bytes(),
        19,
        "$EndElements",
    );
    // Binary: truncated data, and the endianness word broken.
    let mut binary = b"$MeshFormat\n4.1 1 8\n".to_vec();
    binary.extend(1i32.to_le_bytes());
    binary.extend(b"\n$EndMeshFormat\n$Nodes\n");
    binary.extend(1u64.to_le_bytes());
    binary.extend(1000u64.to_le_bytes());
    error_at(&dir, "truncated.msh", &binary, 6, "file ends");
    let mut word = b"$MeshFormat\n2.2 1 8\n".to_vec();
    word.extend(7i32.to_le_bytes());
    error_at(&dir, "endian.msh", &word, 3, "endianness");

    let vtk = |from: &str, to: &str| VTK42.replace(from, to);
    error_at(
        &dir,
        "binary.vtk",
        vtk("ASCII", "BINARY").as_bytes(),
        6,
        "POINTS announces 12 values of 8 bytes, but only 60 bytes are left",
    );
    error_at(
        &dir,
        "number.vtk",
        vtk("0 1 0\n", "0 x 0\n").as_bytes(),
        8,
        "coordinate",
    );
    error_at(
        &dir,
        "index.vtk",
        vtk("4 0 1 2 3", "4 0 1 2 7").as_bytes(),
        11,
        "out of range",
    );
    error_at(
        &dir,
        "quadratic.vtk",
        vtk("CELL_TYPES 1\n10", "CELL_TYPES 1\n24").as_bytes(),
        13,
        "quadratic",
    );
    error_at(
        &dir,
        "dataset.vtk",
        vtk("UNSTRUCTURED_GRID", "POLYDATA").as_bytes(),
        4,
        "UNSTRUCTURED_GRID",
    );

    let vtu = |points: &str, conn: &str| {
        format!(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\">\n\
             <UnstructuredGrid>\n<Piece NumberOfPoints=\"4\" NumberOfCells=\"1\">\n<Points>\n\
             <DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"{points}</DataArray>\n\
             </Points>\n<Cells>\n\
             <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">{conn}</DataArray>\n\
             <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">4</DataArray>\n\
             <DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">10</DataArray>\n\
             </Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n"
        )
    };
    let good_points = "ascii\">0 0 0 1 0 0 0 1 0 0 0 1";
    assert_eq!(
        read_tet_mesh(dir.write("good.vtu", &vtu(good_points, "0 1 2 3")))
            .unwrap()
            .tets,
        vec![[0, 1, 2, 3]]
    );
    error_at(
        &dir,
        "base64.vtu",
        vtu("binary\">AAAA*AAA", "0 1 2 3").as_bytes(),
        6,
        "base64",
    );
    error_at(
        &dir,
        "short.vtu",
        vtu("binary\">AAAA", "0 1 2 3").as_bytes(),
        6,
        "header",
    );
    error_at(
        &dir,
        "text.vtu",
        vtu("ascii\">0 0 zero", "0 1 2 3").as_bytes(),
        6,
        "zero",
    );
    error_at(
        &dir,
        "count.vtu",
        vtu("ascii\">0 0 0", "0 1 2 3").as_bytes(),
        4,
        "NumberOfPoints",
    );
    error_at(
        &dir,
        "range.vtu",
        vtu(good_points, "0 1 2 4").as_bytes(),
        9,
        "out of range",
    );
    error_at(
        &dir,
        "repeat.vtu",
        vtu(good_points, "0 1 2 2").as_bytes(),
        9,
        "repeats",
    );
    // An appended array whose offset points past the appended data.
    error_at(
        &dir,
        "appended.vtu",
        vtu("appended\" offset=\"1000\">", "0 1 2 3")
            .replace(
                "</VTKFile>",
                "<AppendedData encoding=\"raw\">_\u{4}\0\0\0</AppendedData></VTKFile>",
            )
            .as_bytes(),
        6,
        "offset 1000 is beyond the appended data's",
    );
}

/// Arbitrary bytes after a valid header never panic a reader (a small seeded mutation run;
/// `tests/fuzz_inputs.rs` fuzzes the older readers at length).
#[test]
fn mutated_files_never_panic() {
    let dir = TempDir::new("mesh-formats-mutated");
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    let mut binary = b"$MeshFormat\n2.2 1 8\n".to_vec();
    binary.extend(1i32.to_le_bytes());
    binary.extend(b"\n$EndMeshFormat\n$Nodes\n4\n");
    for (i, p) in [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ]
    .iter()
    .enumerate()
    {
        binary.extend((i as i32 + 1).to_le_bytes());
        p.iter().for_each(|x: &f64| binary.extend(x.to_le_bytes()));
    }
    binary.extend(b"\n$EndNodes\n$Elements\n1\n");
    for v in [4i32, 1, 2, 1, 0, 0, 1, 2, 3, 4] {
        binary.extend(v.to_le_bytes());
    }
    binary.extend(b"\n$EndElements\n");
    let seeds: [(&str, Vec<u8>); 4] = [
        ("m.msh", MSH22.into()),
        ("n.msh", MSH41.into()),
        ("b.msh", binary),
        ("v.vtk", VTK42.into()),
    ];
    for (name, original) in &seeds {
        let path = dir.path().join(name);
        std::fs::write(&path, original).unwrap();
        read_tet_mesh(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        for _ in 0..300 {
            let mut bytes = original.clone();
            for _ in 0..1 + next() % 4 {
                let i = (next() % bytes.len() as u64) as usize;
                match next() % 3 {
                    0 => bytes[i] = next() as u8,
                    1 => {
                        bytes.remove(i);
                    }
                    _ => bytes.insert(i, b"0123456789 -.e\n$"[(next() % 16) as usize]),
                }
            }
            std::fs::write(&path, &bytes).unwrap();
            let outcome = std::panic::catch_unwind(|| read_tet_mesh(&path));
            match outcome {
                Err(_) => panic!(
                    "{name}: the reader panicked on {:?}",
                    String::from_utf8_lossy(&bytes)
                ),
                Ok(Err(e)) => assert!(e.to_string().starts_with(path.to_str().unwrap()), "{e}"),
                Ok(Ok(_)) => {}
            }
        }
    }
}

/// Final positions of a `simulate` run, as written (shortest round-trip decimal).
fn final_positions(out: &Path) -> String {
    std::fs::read_to_string(out.join("final_positions.csv")).unwrap()
}

#[test]
fn a_run_restarted_from_an_exported_vtu_frame_continues_exactly() {
    let dir = TempDir::new("mesh-formats-restart");
    let scene = "[mesh]\ngenerate = { box = [4, 1, 1], size = [0.4, 0.1, 0.1] }\n\
                 [material]\nmodel = \"stable-neo-hookean\"\nyoungs_modulus = 1e5\n\
                 poisson_ratio = 0.3\ndensity = 1000.0\n\
                 [fixed]\nrule = { axis = \"x\", side = \"min\", tolerance = 1e-9 }\n\
                 [forces]\ngravity = [0.0, -9.81, 0.0]\n\
                 [integrator]\nmethod = \"backward-euler\"\n\
                 [run]\ndt = 0.01\nsteps = 5\n";
    let whole = dir.write("whole.toml", scene);
    let out = dir.path().join("whole");
    let r = simulate(&whole, &out, &["--export", "vtu"]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let frame = out.join("frames/frame_00003.vtu");
    assert!(frame.is_file());

    let restart = dir.write(
        "restart.toml",
        &scene.replace("steps = 5", "steps = 2").replace(
            "[run]",
            &format!("[initial]\nfrom = {:?}\n[run]", frame.to_str().unwrap()),
        ),
    );
    let out2 = dir.path().join("restart");
    let r = simulate(&restart, &out2, &[]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    // Positions and velocities are Float64 in the VTU, so the restart is exact.
    assert_eq!(final_positions(&out2), final_positions(&out));
    // The frame's time carries over: the restarted run ends at the same t.
    let trajectory = std::fs::read_to_string(out2.join("trajectory.csv")).unwrap();
    let first = trajectory.lines().nth(1).unwrap();
    let t: f64 = first.split(',').nth(1).unwrap().parse().unwrap();
    assert!((t - 0.03).abs() < 1e-15, "restart starts at t = {t}");

    // A frame of another mesh is refused with the key.
    let other = dir.write(
        "other.toml",
        &std::fs::read_to_string(&restart)
            .unwrap()
            .replace("box = [4, 1, 1]", "box = [3, 1, 1]"),
    );
    let r = simulate(&other, &dir.path().join("other"), &[]);
    assert_eq!(r.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(
        stderr.contains("initial.from") && stderr.contains("not a frame of this scene"),
        "{stderr}"
    );
}
