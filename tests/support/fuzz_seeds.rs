//! Seed files and byte-level mutations for `tests/fuzz_inputs.rs`: the Gmsh, VTU and legacy
//! VTK seeds (ASCII and binary, each built here) and the mutators for binary data — hostile
//! words written over a binary block, and the base64 payloads of a `.vtu` decoded, mutated and
//! encoded again so the damage reaches the block headers and the compressed data instead of
//! stopping at the base64 decoder.

use std::io::Write;

use softbench::export::base64;
use softbench::rng::Rng;

/// The five points and two tets every mesh seed holds.
const POINTS: [[f64; 3]; 5] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0, 1.0, 1.0],
];
const TETS: [[usize; 4]; 2] = [[0, 1, 2, 3], [1, 2, 3, 4]];

pub fn below(rng: &mut Rng, n: usize) -> usize {
    (rng.next_u64() % n.max(1) as u64) as usize
}

/// Gmsh 2.2 ASCII, with a line element and a physical name section read past.
pub const MSH22: &str = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n1\n3 1 \"body\"\n\
$EndPhysicalNames\n$Nodes\n5\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 1 1 1\n$EndNodes\n$Elements\n3\n\
1 1 2 0 1 1 2\n2 4 2 1 1 1 2 3 4\n3 4 4 1 1 1 -1 2 3 4 5\n$EndElements\n";

/// Gmsh 4.1 ASCII, with an entities section read past.
pub const MSH41: &str = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Entities\n0 0 0 1\n\
1 0 0 0 1 1 1 0 0\n$EndEntities\n$Nodes\n1 5 1 5\n3 1 0 5\n1\n2\n3\n4\n5\n0 0 0\n1 0 0\n0 1 0\n\
0 0 1\n1 1 1\n$EndNodes\n$Elements\n1 2 1 2\n3 1 4 2\n1 1 2 3 4\n2 2 3 4 5\n$EndElements\n";

/// Gmsh 2.2 binary (little-endian).
pub fn msh22_binary() -> Vec<u8> {
    let mut b = b"$MeshFormat\n2.2 1 8\n".to_vec();
    b.extend(1i32.to_le_bytes());
    b.extend(b"\n$EndMeshFormat\n$Nodes\n5\n");
    for (i, p) in POINTS.iter().enumerate() {
        b.extend((i as i32 + 1).to_le_bytes());
        p.iter().for_each(|x| b.extend(x.to_le_bytes()));
    }
    b.extend(b"\n$EndNodes\n$Elements\n2\n");
    // One block header (type, count, tags) and two elements of tag, 2 tags, 4 nodes.
    for v in [4i32, 2, 2] {
        b.extend(v.to_le_bytes());
    }
    for (i, t) in TETS.iter().enumerate() {
        b.extend((i as i32 + 1).to_le_bytes());
        b.extend(1i32.to_le_bytes());
        b.extend(1i32.to_le_bytes());
        t.iter()
            .for_each(|&v| b.extend((v as i32 + 1).to_le_bytes()));
    }
    b.extend(b"\n$EndElements\n");
    b
}

/// Gmsh 4.1 binary (little-endian).
pub fn msh41_binary() -> Vec<u8> {
    let mut b = b"$MeshFormat\n4.1 1 8\n".to_vec();
    b.extend(1i32.to_le_bytes());
    b.extend(b"\n$EndMeshFormat\n$Nodes\n");
    for v in [1u64, 5, 1, 5] {
        b.extend(v.to_le_bytes());
    }
    for v in [3i32, 1, 0] {
        b.extend(v.to_le_bytes());
    }
    b.extend(5u64.to_le_bytes());
    for tag in 1..=5u64 {
        b.extend(tag.to_le_bytes());
    }
    for p in &POINTS {
        p.iter().for_each(|x| b.extend(x.to_le_bytes()));
    }
    b.extend(b"\n$EndNodes\n$Elements\n");
    for v in [1u64, 2, 1, 2] {
        b.extend(v.to_le_bytes());
    }
    for v in [3i32, 1, 4] {
        b.extend(v.to_le_bytes());
    }
    b.extend(2u64.to_le_bytes());
    for (i, t) in TETS.iter().enumerate() {
        b.extend((i as u64 + 1).to_le_bytes());
        t.iter()
            .for_each(|&v| b.extend((v as u64 + 1).to_le_bytes()));
    }
    b.extend(b"\n$EndElements\n");
    b
}

/// Legacy VTK 4.2 (CELLS n size) with a vertex cell read past, and point data after.
pub const VTK42: &str = "# vtk DataFile Version 4.2\nfuzz\nASCII\nDATASET UNSTRUCTURED_GRID\n\
POINTS 5 double\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\nCELLS 3 12\n4 0 1 2 3\n4 1 2 3 4\n1 4\n\
CELL_TYPES 3\n10\n10\n1\nPOINT_DATA 5\nSCALARS s double 1\nLOOKUP_TABLE default\n0 1 2 3 4\n";

/// Legacy VTK 5.1 (OFFSETS and CONNECTIVITY).
pub const VTK51: &str = "# vtk DataFile Version 5.1\nfuzz\nASCII\nDATASET UNSTRUCTURED_GRID\n\
POINTS 5 float\n0 0 0 1 0 0 0 1 0\n0 0 1 1 1 1\nCELLS 4 9\nOFFSETS vtktypeint64\n0 4 8 9\n\
CONNECTIVITY vtktypeint64\n0 1 2 3\n1 2 3 4\n4\nCELL_TYPES 3\n10\n10\n1\n";

/// A `.vtu` with inline ascii arrays, point and cell data and a time.
pub const VTU_ASCII: &str = "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" \
version=\"1.0\" byte_order=\"LittleEndian\">\n<UnstructuredGrid>\n<FieldData>\n<DataArray \
type=\"Float64\" Name=\"TimeValue\" NumberOfTuples=\"1\" format=\"ascii\">0.5</DataArray>\n\
</FieldData>\n<Piece NumberOfPoints=\"5\" NumberOfCells=\"2\">\n<PointData>\n<DataArray \
type=\"Float64\" Name=\"velocity\" NumberOfComponents=\"3\" format=\"ascii\">0 0 0 1 1 1 0 0 0 \
2 2 2 0 0 0</DataArray>\n</PointData>\n<CellData>\n<DataArray type=\"Float64\" Name=\"J\" \
format=\"ascii\">1 1</DataArray>\n</CellData>\n<Points>\n<DataArray type=\"Float32\" \
NumberOfComponents=\"3\" format=\"ascii\">0 0 0 1 0 0 0 1 0 0 0 1 1 1 1</DataArray>\n\
</Points>\n<Cells>\n<DataArray type=\"Int32\" Name=\"connectivity\" format=\"ascii\">0 1 2 3 \
1 2 3 4</DataArray>\n<DataArray type=\"Int32\" Name=\"offsets\" format=\"ascii\">4 8\
</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">10 10</DataArray>\n\
</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n";

/// A `.vtu` as softbench writes it (base64, UInt64 headers, uncompressed).
pub fn vtu_base64() -> Vec<u8> {
    use nalgebra::Vector3;
    use softbench::export::vtu::{VtuGrid, write_vtu};
    let points: Vec<Vector3<f64>> = POINTS.iter().map(|p| Vector3::from(*p)).collect();
    let velocity = vec![Vector3::new(0.0, 0.0, 1.0); 5];
    let mut out = Vec::new();
    write_vtu(
        &mut out,
        &VtuGrid {
            points: &points,
            tets: &TETS,
            point_vectors: &[("velocity", &velocity)],
            cell_scalars: &[("J", &[1.0, 1.0])],
            time: Some(0.25),
        },
    )
    .unwrap();
    out
}

/// One zlib-compressed array as VTK writes it: UInt32 headers (blocks, block size, last
/// block size, compressed sizes) base64-encoded apart from the blocks; `block` bytes per block.
fn zlib_array(kind: &str, name: &str, components: usize, data: &[u8], block: usize) -> String {
    let chunks: Vec<&[u8]> = data.chunks(block).collect();
    let compressed: Vec<Vec<u8>> = chunks
        .iter()
        .map(|c| {
            let mut e = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
            e.write_all(c).unwrap();
            e.finish().unwrap()
        })
        .collect();
    let last = chunks.last().map_or(0, |c| c.len());
    let mut header = Vec::new();
    let sizes = [chunks.len(), block, if last == block { 0 } else { last }];
    for v in sizes.into_iter().chain(compressed.iter().map(Vec::len)) {
        header.extend((v as u32).to_le_bytes());
    }
    format!(
        "<DataArray type=\"{kind}\" Name=\"{name}\" NumberOfComponents=\"{components}\" \
         format=\"binary\">{}{}</DataArray>\n",
        base64::encode(&header),
        base64::encode(&compressed.concat())
    )
}

/// A zlib-compressed `.vtu` (UInt32 headers, points in several blocks, a full last block in
/// the connectivity).
pub fn vtu_zlib() -> Vec<u8> {
    let xyz: Vec<u8> = POINTS
        .iter()
        .flatten()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    let conn: Vec<u8> = TETS
        .iter()
        .flatten()
        .flat_map(|&v| (v as i64).to_le_bytes())
        .collect();
    let offsets: Vec<u8> = [4i64, 8].iter().flat_map(|v| v.to_le_bytes()).collect();
    format!(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" \
         byte_order=\"LittleEndian\" compressor=\"vtkZLibDataCompressor\">\n<UnstructuredGrid>\n\
         <Piece NumberOfPoints=\"5\" NumberOfCells=\"2\">\n<PointData>\n{}</PointData>\n\
         <Points>\n{}</Points>\n<Cells>\n{}{}{}</Cells>\n</Piece>\n</UnstructuredGrid>\n\
         </VTKFile>\n",
        zlib_array("Float64", "velocity", 3, &xyz, 48),
        zlib_array("Float64", "Points", 3, &xyz, 48),
        zlib_array("Int64", "connectivity", 1, &conn, 32),
        zlib_array("Int64", "offsets", 1, &offsets, 64),
        zlib_array("UInt8", "types", 1, &[10, 10], 64),
    )
    .into_bytes()
}

/// Integers that have broken binary readers: zero, one, signs, the edges of each width, and
/// the bits of hostile doubles.
const HOSTILE_WORDS: &[u64] = &[
    0,
    1,
    2,
    4,
    10,
    u64::MAX,
    u32::MAX as u64,
    i32::MAX as u64,
    0x8000_0000,
    i64::MAX as u64,
    1 << 32,
    1 << 40,
    0x7ff8_0000_0000_0000, // NaN
    0x7ff0_0000_0000_0000, // inf
    0x7fe1_ccf3_85eb_c8a0, // 1e308
];

/// One to four byte-level mutations: a hostile 4- or 8-byte word written anywhere, a byte
/// changed, a range deleted, duplicated or cut off, a text token inserted.
pub fn mutate_bytes(rng: &mut Rng, data: &[u8]) -> Vec<u8> {
    let mut b = data.to_vec();
    for _ in 0..1 + below(rng, 4) {
        let len = b.len();
        match below(rng, 7) {
            0 | 1 => {
                let w = HOSTILE_WORDS[below(rng, HOSTILE_WORDS.len())];
                let bytes = if below(rng, 2) == 0 {
                    w.to_le_bytes().to_vec()
                } else {
                    (w as u32).to_le_bytes().to_vec()
                };
                let at = below(rng, len + 1);
                let end = (at + bytes.len()).min(len);
                b.splice(at..end, bytes[..end - at].iter().copied());
            }
            2 => {
                if len > 0 {
                    let at = below(rng, len);
                    b[at] = rng.next_u64() as u8;
                }
            }
            3 => {
                let a = below(rng, len + 1);
                let e = (a + below(rng, 40)).min(len);
                b.drain(a..e);
            }
            4 => {
                let a = below(rng, len + 1);
                let e = (a + below(rng, 64)).min(len);
                let copy = b[a..e].to_vec();
                b.splice(a..a, copy);
            }
            5 => {
                const TOKENS: &[&[u8]] = &[b" -1 ", b" 0 ", b"\n", b"$EndNodes\n", b" 1e300 "];
                let at = below(rng, len + 1);
                let t = TOKENS[below(rng, TOKENS.len())];
                b.splice(at..at, t.iter().copied());
            }
            _ => b.truncate(below(rng, len + 1)),
        }
    }
    b
}

/// Decodes base64 leniently (whitespace skipped, padding ending one run and another
/// following, as VTK writes a compressed array's header and data); `None` on a bad character.
fn decode(text: &[u8]) -> Option<Vec<u8>> {
    let mut out = Vec::new();
    let (mut acc, mut n) = (0u32, 0);
    for &ch in text {
        let v = match ch {
            b'A'..=b'Z' => ch - b'A',
            b'a'..=b'z' => ch - b'a' + 26,
            b'0'..=b'9' => ch - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            b'=' => {
                // Flush the partial group.
                match n {
                    2 => out.push((acc >> 4) as u8),
                    3 => out.extend([(acc >> 10) as u8, (acc >> 2) as u8]),
                    _ => {}
                }
                (acc, n) = (0, 0);
                continue;
            }
            c if c.is_ascii_whitespace() => continue,
            _ => return None,
        };
        acc = acc << 6 | u32::from(v);
        n += 1;
        if n == 4 {
            out.extend([(acc >> 16) as u8, (acc >> 8) as u8, acc as u8]);
            (acc, n) = (0, 0);
        }
    }
    Some(out)
}

/// A `.vtu` mutation that reaches its binary arrays: the payload of one `format="binary"`
/// array is decoded, mutated with [`mutate_bytes`] (block tables, sizes, compressed bytes) and
/// encoded again; or, half the time, the file's text is mutated by `text`.
pub fn mutate_vtu(rng: &mut Rng, data: &[u8], text: fn(&mut Rng, &[u8]) -> Vec<u8>) -> Vec<u8> {
    const OPEN: &[u8] = b"format=\"binary\">";
    let starts: Vec<usize> = data
        .windows(OPEN.len())
        .enumerate()
        .filter(|(_, w)| *w == OPEN)
        .map(|(i, _)| i + OPEN.len())
        .collect();
    if starts.is_empty() || below(rng, 2) == 0 {
        return text(rng, data);
    }
    let start = starts[below(rng, starts.len())];
    let Some(len) = data[start..].iter().position(|&b| b == b'<') else {
        return text(rng, data);
    };
    let Some(payload) = decode(&data[start..start + len]) else {
        return text(rng, data);
    };
    let mutated = mutate_bytes(rng, &payload);
    let mut out = data[..start].to_vec();
    out.extend(base64::encode(&mutated).into_bytes());
    out.extend(&data[start + len..]);
    out
}
