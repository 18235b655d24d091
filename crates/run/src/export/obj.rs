//! Wavefront OBJ triangle surfaces: `v x y z` and 1-based `f a b c` records, readable by
//! Blender, MeshLab, ParaView and [`softbench_core::mesh::obj`]. Coordinates are written with Rust's
//! shortest round-trip formatting, so reading them back gives the same f64.

use std::io::{self, Write};

use nalgebra::Vector3;

/// Writes `positions` and `triangles` (0-based) as OBJ, with `comment` lines first (each
/// prefixed with `# `).
///
/// # Panics
/// When a triangle index is out of range.
pub fn write_obj(
    w: &mut dyn Write,
    comment: &str,
    positions: &[Vector3<f64>],
    triangles: &[[usize; 3]],
) -> io::Result<()> {
    for line in comment.lines() {
        writeln!(w, "# {line}")?;
    }
    for p in positions {
        writeln!(w, "v {:?} {:?} {:?}", p.x, p.y, p.z)?;
    }
    for t in triangles {
        assert!(
            t.iter().all(|&v| v < positions.len()),
            "triangle {t:?} out of range"
        );
        writeln!(w, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
    }
    Ok(())
}
