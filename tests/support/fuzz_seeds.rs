//! Seed files and byte-level mutations for `tests/fuzz_inputs.rs` (and the hostile files of
//! `tests/mesh_hostile_vtk.rs`): the Gmsh, VTU and legacy VTK seeds (ASCII and binary, inline
//! and appended, each compressor; each built here) and the mutators for binary data — hostile
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

/// Legacy VTK 5.1 as VTK writes it after a round trip: dataset `FIELD` data (with a
/// `NULL_ARRAY` and strings) before `POINTS`, `METADATA` blocks after arrays, cell data after
/// the cells.
pub const VTK51_METADATA: &str = "# vtk DataFile Version 5.1\nvtk output\nASCII\n\
DATASET UNSTRUCTURED_GRID\nFIELD FieldData 3\nTimeValue 1 1 double\n0.5 \nNULL_ARRAY\n\
note 1 2 string\nfirst%20note\nsecond\nMETADATA\nINFORMATION 1\n\
NAME UNITS_LABEL LOCATION vtkDataArray\nDATA s\n\nPOINTS 5 float\n0 0 0 1 0 0 0 1 0 0 0 1 1 1 1 \n\
METADATA\nINFORMATION 1\nNAME L2_NORM_RANGE LOCATION vtkDataArray\nDATA 2 0 1.73205 \n\n\
CELLS 3 8\nOFFSETS vtktypeint64\n0 4 8 \nMETADATA\nCOMPONENT_NAMES\nfirst\n\n\
CONNECTIVITY vtktypeint64\n0 1 2 3 1 2 3 4 \nCELL_TYPES 2\n10\n10\n\nCELL_DATA 2\n\
FIELD FieldData 1\nregion 1 2 int\n0 1 \nMETADATA\nINFORMATION 0\n\n";

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

/// The seed mesh's four mesh arrays as a `.vtu` stores them: points (Float64), connectivity
/// and offsets (Int64), types (UInt8), little-endian.
pub fn mesh_arrays() -> [Vec<u8>; 4] {
    [
        POINTS
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect(),
        TETS.iter()
            .flatten()
            .flat_map(|&v| (v as i64).to_le_bytes())
            .collect(),
        [4i64, 8].iter().flat_map(|v| v.to_le_bytes()).collect(),
        vec![10, 10],
    ]
}

/// An uncompressed binary array: its byte count (UInt32), then its bytes.
pub fn pack_raw(_: usize, data: &[u8]) -> Vec<u8> {
    let mut out = (data.len() as u32).to_le_bytes().to_vec();
    out.extend(data);
    out
}

/// A compressed array of one block: the block table (UInt32: 1 block, its size twice, the
/// compressed size), then the block.
pub fn one_block(data: &[u8], block: Vec<u8>) -> Vec<u8> {
    let mut out = Vec::new();
    for v in [1, data.len(), data.len(), block.len()] {
        out.extend((v as u32).to_le_bytes());
    }
    out.extend(block);
    out
}

pub fn pack_zlib(_: usize, data: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(data).unwrap();
    one_block(data, e.finish().unwrap())
}

pub fn pack_lz4(_: usize, data: &[u8]) -> Vec<u8> {
    one_block(data, lz4_flex::block::compress(data))
}

/// xz streams of [`mesh_arrays`] (CRC64 check, preset 5: what vtkLZMADataCompressor writes
/// at VTK's default level), made with Python's `lzma` module.
const XZ: [&str; 4] = [
    "fd377a585a000004e6d6b4460200210116000000742fe5a3e00077000d5d00006e1537c41921d82fb8a84c00\
     0000000085a36b2fd4cf228900012978ced31e3a1fb6f37d010000000004595a",
    "fd377a585a000004e6d6b4460200210116000000742fe5a3e0003f00105d00006a7ebb146f1b410e01725139\
     ccace50082fd11ffa640127f00012c40159f6b6f1fb6f37d010000000004595a",
    "fd377a585a000004e6d6b4460200210116000000742fe5a3e0000f00095d00020037e1ce2af9680000000000\
     ed75900dcf22f1d300012510a875c2d51fb6f37d010000000004595a",
    "fd377a585a000004e6d6b4460200210116000000742fe5a30100010a0a000000470f20a80332c5f800011a02\
     dc2ea57e1fb6f37d010000000004595a",
];

/// The LZMA-compressed `i`th of [`mesh_arrays`] (`data`).
pub fn pack_lzma(i: usize, data: &[u8]) -> Vec<u8> {
    let hex = XZ[i];
    let block = (0..hex.len())
        .step_by(2)
        .map(|k| u8::from_str_radix(&hex[k..k + 2], 16).unwrap())
        .collect();
    one_block(data, block)
}

/// A `.vtu` whose mesh arrays ([`mesh_arrays`], each `pack`ed with its index) are appended,
/// raw or base64 (each array encoded apart), for a `Piece` of `piece` points and cells;
/// `attributes` are added to `VTKFile` (a compressor, a header type). The connectivity array
/// carries an `<InformationKey>` child as VTK writes. Line 6 holds the points' `DataArray`,
/// 9 to 11 the cells', 16 the start of the appended data.
pub fn vtu_appended(
    attributes: &str,
    piece: (usize, usize),
    base64: bool,
    pack: &dyn Fn(usize, &[u8]) -> Vec<u8>,
) -> Vec<u8> {
    let packed: Vec<Vec<u8>> = mesh_arrays()
        .iter()
        .enumerate()
        .map(|(i, d)| pack(i, d))
        .collect();
    let stored: Vec<Vec<u8>> = if base64 {
        packed
            .iter()
            .map(|p| base64::encode(p).into_bytes())
            .collect()
    } else {
        packed
    };
    let mut offsets = [0usize; 4];
    for i in 1..4 {
        offsets[i] = offsets[i - 1] + stored[i - 1].len();
    }
    let array = |kind: &str, name: &str, i: usize| {
        format!(
            "<DataArray type=\"{kind}\" Name=\"{name}\" format=\"appended\" offset=\"{}\"/>\n",
            offsets[i]
        )
    };
    let mut out = format!(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" \
         byte_order=\"LittleEndian\"{attributes}>\n<UnstructuredGrid>\n\
         <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">\n<Points>\n\
         <DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" \
         format=\"appended\" offset=\"0\"/>\n</Points>\n<Cells>\n\
         <DataArray type=\"Int64\" Name=\"connectivity\" format=\"appended\" offset=\"{}\">\
         <InformationKey name=\"L2_NORM_RANGE\" location=\"vtkDataArray\" length=\"2\">\
         <Value index=\"0\">0</Value><Value index=\"1\">4</Value></InformationKey></DataArray>\n\
         {}{}</Cells>\n</Piece>\n</UnstructuredGrid>\n<AppendedData encoding=\"{}\">\n   _",
        piece.0,
        piece.1,
        offsets[1],
        array("Int64", "offsets", 2),
        array("UInt8", "types", 3),
        if base64 { "base64" } else { "raw" },
    )
    .into_bytes();
    for s in stored {
        out.extend(s);
    }
    out.extend(b"\n</AppendedData>\n</VTKFile>\n");
    out
}

/// A binary legacy VTK file of the seed mesh, in the 4.2 (`CELLS n size`) or 5.1
/// (`OFFSETS`/`CONNECTIVITY`) layout, as VTK writes it after a round trip: dataset `FIELD` data
/// (a double, a string and bits) before `POINTS`, a `METADATA` block after them, point data after
/// the cells.
pub fn legacy_binary(version: &str) -> Vec<u8> {
    let mut b = format!(
        "# vtk DataFile Version {version}\nfuzz\nBINARY\nDATASET UNSTRUCTURED_GRID\n\
         FIELD FieldData 3\nTimeValue 1 1 double\n"
    )
    .into_bytes();
    b.extend(0.5f64.to_be_bytes());
    b.extend(b"\nnote 1 1 string\n");
    b.push(0xc0 | 5);
    b.extend(b"hello\nflags 1 9 bit\n");
    b.extend([0b1010_1010, 0b1000_0000]);
    b.extend(b"\n\nPOINTS 5 double\n");
    POINTS
        .iter()
        .flatten()
        .for_each(|x| b.extend(x.to_be_bytes()));
    b.extend(
        b"\nMETADATA\nINFORMATION 1\nNAME L2_NORM_RANGE LOCATION vtkDataArray\n\
          DATA 2 0 1.73205 \n\n",
    );
    if version == "5.1" {
        b.extend(b"CELLS 3 8\nOFFSETS vtktypeint64\n");
        [0i64, 4, 8].iter().for_each(|v| b.extend(v.to_be_bytes()));
        b.extend(b"\nCONNECTIVITY vtktypeint64\n");
        TETS.iter()
            .flatten()
            .for_each(|&v| b.extend((v as i64).to_be_bytes()));
    } else {
        b.extend(b"CELLS 2 10\n");
        for t in TETS {
            b.extend(4i32.to_be_bytes());
            t.iter().for_each(|&v| b.extend((v as i32).to_be_bytes()));
        }
    }
    b.extend(b"\nCELL_TYPES 2\n");
    b.extend(10i32.to_be_bytes());
    b.extend(10i32.to_be_bytes());
    b.extend(b"\n\nPOINT_DATA 5\nSCALARS s double 1\nLOOKUP_TABLE default\n");
    (0..5).for_each(|i| b.extend(f64::from(i).to_be_bytes()));
    b.extend(b"\n");
    b
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
/// array, or the appended base64 data, is decoded, mutated with [`mutate_bytes`] (block tables, sizes, compressed bytes) and
/// encoded again; or, half the time, the file's text is mutated by `text`.
pub fn mutate_vtu(rng: &mut Rng, data: &[u8], text: fn(&mut Rng, &[u8]) -> Vec<u8>) -> Vec<u8> {
    const OPEN: &[u8] = b"format=\"binary\">";
    const APPENDED: &[u8] = b"encoding=\"base64\">";
    let after = |marker: &'static [u8]| {
        data.windows(marker.len())
            .enumerate()
            .filter(move |(_, w)| *w == marker)
            .map(move |(i, _)| i + marker.len())
    };
    // Inline payloads, and the appended base64 text after its `_`.
    let starts: Vec<usize> = after(OPEN)
        .chain(after(APPENDED).filter_map(|i| {
            let underscore = data[i..].iter().position(|&b| b == b'_')?;
            Some(i + underscore + 1)
        }))
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
