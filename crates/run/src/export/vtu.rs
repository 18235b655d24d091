//! VTK XML unstructured grids (`.vtu`) of linear tets, written by hand: one `Piece`, points
//! and data arrays as inline base64 (`format="binary"`, little-endian, `header_type="UInt64"`,
//! uncompressed). Binary keeps every f64 exact (including NaN and infinities, which ASCII VTK
//! readers do not all accept) and is about half the size of ASCII; ParaView, VisIt and meshio
//! read it.

use std::io::{self, Write};

use nalgebra::Vector3;

use super::base64;

/// `VTK_TETRA`, the VTK cell type of a linear tetrahedron.
pub const VTK_TETRA: u8 = 10;

/// One unstructured tet grid with named point and cell arrays.
#[derive(Clone, Copy, Debug)]
pub struct VtuGrid<'a> {
    /// Point positions.
    pub points: &'a [Vector3<f64>],
    /// Tets as 0-based indices into `points`, in the VTK_TETRA vertex order (the same
    /// positive orientation as the mesh convention).
    pub tets: &'a [[usize; 4]],
    /// Three-component arrays with one entry per point (e.g. `velocity`).
    pub point_vectors: &'a [(&'a str, &'a [Vector3<f64>])],
    /// Scalar arrays with one entry per tet (e.g. `J`).
    pub cell_scalars: &'a [(&'a str, &'a [f64])],
    /// The simulated time (s), written as the field `TimeValue` (VTK's name for it), so a
    /// run can restart from the frame at its time (`[initial] from`).
    pub time: Option<f64>,
}

/// Writes `grid` as a `.vtu` document.
///
/// # Panics
/// When an array does not have one entry per point (or cell).
pub fn write_vtu(w: &mut dyn Write, grid: &VtuGrid) -> io::Result<()> {
    let (n, m) = (grid.points.len(), grid.tets.len());
    for (name, values) in grid.point_vectors {
        assert_eq!(
            values.len(),
            n,
            "point array `{name}` needs one entry per point"
        );
    }
    for (name, values) in grid.cell_scalars {
        assert_eq!(
            values.len(),
            m,
            "cell array `{name}` needs one entry per cell"
        );
    }
    let mut buf = Vec::new();
    let mut text = String::new();
    writeln!(w, r#"<?xml version="1.0"?>"#)?;
    writeln!(
        w,
        r#"<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">"#
    )?;
    writeln!(w, "  <UnstructuredGrid>")?;
    if let Some(t) = grid.time {
        writeln!(w, "    <FieldData>")?;
        let mut block = Vec::with_capacity(16);
        block.extend(8u64.to_le_bytes());
        block.extend(t.to_le_bytes());
        text.clear();
        base64::encode_into(&block, &mut text);
        writeln!(
            w,
            r#"      <DataArray type="Float64" Name="TimeValue" NumberOfTuples="1" format="binary">{text}</DataArray>"#
        )?;
        writeln!(w, "    </FieldData>")?;
    }
    writeln!(w, r#"    <Piece NumberOfPoints="{n}" NumberOfCells="{m}">"#)?;
    if let Some((first, _)) = grid.point_vectors.first() {
        writeln!(w, r#"      <PointData Vectors="{}">"#, escape(first))?;
        for (name, values) in grid.point_vectors {
            vectors(&mut buf, values);
            array(w, "Float64", Some(name), 3, &buf, &mut text)?;
        }
        writeln!(w, "      </PointData>")?;
    }
    if let Some((first, _)) = grid.cell_scalars.first() {
        writeln!(w, r#"      <CellData Scalars="{}">"#, escape(first))?;
        for (name, values) in grid.cell_scalars {
            buf.clear();
            values.iter().for_each(|v| buf.extend(v.to_le_bytes()));
            array(w, "Float64", Some(name), 1, &buf, &mut text)?;
        }
        writeln!(w, "      </CellData>")?;
    }
    writeln!(w, "      <Points>")?;
    vectors(&mut buf, grid.points);
    array(w, "Float64", Some("Points"), 3, &buf, &mut text)?;
    writeln!(w, "      </Points>")?;
    writeln!(w, "      <Cells>")?;
    buf.clear();
    for &v in grid.tets.iter().flatten() {
        buf.extend((v as i64).to_le_bytes());
    }
    array(w, "Int64", Some("connectivity"), 1, &buf, &mut text)?;
    buf.clear();
    for c in 1..=m {
        buf.extend((4 * c as i64).to_le_bytes());
    }
    array(w, "Int64", Some("offsets"), 1, &buf, &mut text)?;
    buf.clear();
    buf.resize(m, VTK_TETRA);
    array(w, "UInt8", Some("types"), 1, &buf, &mut text)?;
    writeln!(w, "      </Cells>")?;
    writeln!(w, "    </Piece>")?;
    writeln!(w, "  </UnstructuredGrid>")?;
    writeln!(w, "</VTKFile>")
}

/// Little-endian bytes of `values`, xyz interleaved.
fn vectors(buf: &mut Vec<u8>, values: &[Vector3<f64>]) {
    buf.clear();
    for v in values {
        for c in v.iter() {
            buf.extend(c.to_le_bytes());
        }
    }
}

/// One `DataArray`: the UInt64 byte count and the data, base64-encoded together (as VTK does
/// for uncompressed inline binary).
fn array(
    w: &mut dyn Write,
    kind: &str,
    name: Option<&str>,
    components: usize,
    bytes: &[u8],
    text: &mut String,
) -> io::Result<()> {
    let mut block = Vec::with_capacity(8 + bytes.len());
    block.extend((bytes.len() as u64).to_le_bytes());
    block.extend_from_slice(bytes);
    text.clear();
    base64::encode_into(&block, text);
    let name = name.map_or(String::new(), |n| format!(r#" Name="{}""#, escape(n)));
    let comps = if components > 1 {
        format!(r#" NumberOfComponents="{components}""#)
    } else {
        String::new()
    };
    writeln!(
        w,
        r#"        <DataArray type="{kind}"{name}{comps} format="binary">{text}</DataArray>"#
    )
}

/// `s` with the XML special characters escaped (for attribute values).
pub(crate) fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}
