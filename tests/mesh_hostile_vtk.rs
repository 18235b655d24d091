//! Malformed VTK files on the paths of issue 30, each generated here: appended data (raw and
//! base64) cut short, block tables that lie, compressed blocks that are corrupt or claim more
//! than they can inflate to, unknown compressors and encodings, `DataArray` children, and
//! binary legacy files with counts larger than the file. Each is refused with a `MeshError`
//! naming the file, the line and what is wrong — never a panic, and never an allocation sized
//! by a count the file cannot back.

mod common;

#[path = "support/fuzz_seeds.rs"]
#[allow(dead_code)]
mod fuzz_seeds;

use common::hostile::{accepted, refused};
use fuzz_seeds::{
    legacy_binary, mesh_arrays, one_block, pack_lz4, pack_lzma, pack_raw, pack_zlib, vtu_appended,
};

const TETS: [[usize; 4]; 2] = [[0, 1, 2, 3], [1, 2, 3, 4]];
const ZLIB: &str = " compressor=\"vtkZLibDataCompressor\"";

/// `file` with the first `from` replaced by `to`, byte for byte (binary data is not UTF-8).
#[track_caller]
fn replace(file: &[u8], from: &str, to: &str) -> Vec<u8> {
    let at = file
        .windows(from.len())
        .position(|w| w == from.as_bytes())
        .unwrap_or_else(|| panic!("no `{from}`"));
    [&file[..at], to.as_bytes(), &file[at + from.len()..]].concat()
}

/// Packs array `i` with `pack`, the others with `others`.
fn with(
    i: usize,
    pack: impl Fn(&[u8]) -> Vec<u8>,
    others: fn(usize, &[u8]) -> Vec<u8>,
) -> impl Fn(usize, &[u8]) -> Vec<u8> {
    move |k, data| if k == i { pack(data) } else { others(k, data) }
}

#[test]
fn appended_seeds_of_every_kind_read() {
    for (name, attributes, base64, pack) in [
        (
            "raw.vtu",
            "",
            false,
            pack_raw as fn(usize, &[u8]) -> Vec<u8>,
        ),
        ("zlib.vtu", ZLIB, false, pack_zlib),
        (
            "lz4.vtu",
            " compressor=\"vtkLZ4DataCompressor\"",
            false,
            pack_lz4,
        ),
        (
            "lzma.vtu",
            " compressor=\"vtkLZMADataCompressor\"",
            false,
            pack_lzma,
        ),
        ("base64.vtu", "", true, pack_raw),
        ("base64_zlib.vtu", ZLIB, true, pack_zlib),
        (
            "base64_lzma.vtu",
            " compressor=\"vtkLZMADataCompressor\"",
            true,
            pack_lzma,
        ),
    ] {
        let file = vtu_appended(attributes, (5, 2), base64, &pack);
        assert_eq!(accepted(name, &file).tets, TETS, "{name}");
    }
    for version in ["4.2", "5.1"] {
        let mesh = accepted("legacy.vtk", &legacy_binary(version));
        assert_eq!(mesh.tets, TETS, "{version}");
        assert_eq!(mesh.positions[4].x, 1.0);
    }
}

#[test]
fn truncated_appended_data_is_refused() {
    for (base64, needle) in [(false, "the data ends"), (true, "the base64 data ends")] {
        for (attributes, pack) in [
            ("", pack_raw as fn(usize, &[u8]) -> Vec<u8>),
            (ZLIB, pack_zlib),
        ] {
            let mut file = vtu_appended(attributes, (5, 2), base64, &pack);
            // Cut inside the last array (types): its data, or its block.
            let end = file.len() - "\n</AppendedData>\n</VTKFile>\n".len();
            file.truncate(end - 2);
            let message = refused("cut.vtu", &file, Some(11), needle);
            assert!(message.contains("`types`"), "{message}");
            assert!(message.contains("appended data at offset"), "{message}");
        }
    }
    // Cut before the `_`.
    let file = vtu_appended("", (5, 2), false, &pack_raw);
    let at = file.windows(2).position(|w| w == b" _").unwrap();
    refused(
        "underscore.vtu",
        &file[..at + 1],
        Some(16),
        "must start with `_`",
    );
}

#[test]
fn an_offset_past_the_appended_data_or_no_appended_data_is_refused() {
    let file = vtu_appended("", (5, 2), false, &pack_raw);
    let text = String::from_utf8_lossy(&file).replace("offset=\"0\"", "offset=\"100000\"");
    refused(
        "offset.vtu",
        text.as_bytes(),
        Some(6),
        "offset 100000 is beyond the appended data's",
    );
    let cut = file
        .windows(14)
        .position(|w| w == b"<AppendedData ")
        .unwrap();
    let mut text = file[..cut].to_vec();
    text.extend(b"</VTKFile>\n");
    refused(
        "none.vtu",
        &text,
        Some(6),
        "the file has no `<AppendedData>` section",
    );
    let text = String::from_utf8_lossy(&file).replace("encoding=\"raw\"", "encoding=\"hex\"");
    refused(
        "encoding.vtu",
        text.as_bytes(),
        Some(15),
        "`AppendedData` encoding `hex` is not supported (raw and base64 are)",
    );
}

/// A block table (UInt32) with `blocks`, `size`, `last` and the compressed sizes, then the
/// blocks.
fn table(words: &[u32], blocks: &[u8]) -> Vec<u8> {
    let mut out: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    out.extend(blocks);
    out
}

#[test]
fn block_tables_that_lie_are_refused_before_anything_is_inflated() {
    let zlib = |data: &[u8]| pack_zlib(0, data);
    let block = |data: &[u8]| zlib(data)[16..].to_vec();
    // Four billion blocks of one byte: more than five points need.
    let huge = with(0, |_| table(&[u32::MAX, 1, 1], &[]), pack_zlib);
    refused(
        "blocks.vtu",
        &vtu_appended(ZLIB, (5, 2), false, &huge),
        Some(6),
        "declares 4294967295 bytes, more than the 120 bytes the grid's counts allow",
    );
    // A compressed size past the end of the data.
    let past = with(0, |d| table(&[1, 120, 120, 1 << 30], &block(d)), pack_zlib);
    refused(
        "past.vtu",
        &vtu_appended(ZLIB, (5, 2), false, &past),
        Some(6),
        "ends inside its 1 compressed blocks",
    );
    // A block table longer than the data (a million blocks of 0 bytes, no room for them).
    let long = with(0, |_| table(&[1_000_000, 1, 0], &[]), pack_zlib);
    refused(
        "table.vtu",
        &vtu_appended(ZLIB, (1 << 20, 2), false, &long),
        Some(6),
        "ends inside its block table of 1000000 blocks",
    );
    // Blocks of size 0.
    let empty = with(0, |_| table(&[3, 0, 0, 8, 8, 8], &[]), pack_zlib);
    refused(
        "zero.vtu",
        &vtu_appended(ZLIB, (5, 2), false, &empty),
        Some(6),
        "3 blocks of 0 bytes",
    );
    // A last block larger than the block size.
    let last = with(0, |d| table(&[1, 100, 120, 20], &block(d)), pack_zlib);
    refused(
        "last.vtu",
        &vtu_appended(ZLIB, (5, 2), false, &last),
        Some(6),
        "larger than the block size",
    );
    // More than zlib can inflate its compressed bytes to, with counts that would allow it.
    let ratio = with(
        0,
        |_| table(&[1, 100 << 20, 100 << 20, 10], &[0; 10]),
        pack_zlib,
    );
    refused(
        "ratio.vtu",
        &vtu_appended(ZLIB, (10_000_000, 2), false, &ratio),
        Some(6),
        "more than zlib can inflate them to",
    );
    // A block that inflates to less or more than the table says.
    for (declared, needle) in [
        (240, "inflates to 120 bytes, but the block table says 240"),
        (60, "holds more than the 60 bytes the block table says"),
    ] {
        let lie = with(
            0,
            move |d| {
                let b = block(d);
                table(&[1, declared, declared, b.len() as u32], &b)
            },
            pack_zlib,
        );
        refused(
            "size.vtu",
            &vtu_appended(ZLIB, (20, 2), false, &lie),
            Some(6),
            needle,
        );
    }
    // A corrupt block.
    let corrupt = with(
        0,
        |d| {
            let mut b = zlib(d);
            let n = b.len();
            b[n - 6] ^= 0xff;
            b
        },
        pack_zlib,
    );
    refused(
        "corrupt.vtu",
        &vtu_appended(ZLIB, (5, 2), false, &corrupt),
        Some(6),
        "cannot decompress a zlib block",
    );
}

#[test]
fn huge_declared_sizes_in_a_small_file_are_refused_without_allocating_them() {
    // Counts that allow 240 MB of points, a header that declares them, 120 bytes of data:
    // refused at the end of the data (raw) or of the text (base64), nothing reserved.
    for base64 in [false, true] {
        let big = with(
            0,
            |d| {
                let mut out = 240_000_000u32.to_le_bytes().to_vec();
                out.extend(d);
                out
            },
            pack_raw,
        );
        let message = refused(
            "big.vtu",
            &vtu_appended("", (10_000_000, 2), base64, &big),
            Some(6),
            "ends inside its 240000000 bytes of data",
        );
        assert!(message.contains("`Points`"), "{message}");
    }
    // The same through a UInt64 header: 2^63 bytes.
    let big = with(
        0,
        |d| {
            let mut out = (1u64 << 63).to_le_bytes().to_vec();
            out.extend(d);
            out
        },
        |_, d| {
            let mut out = (d.len() as u64).to_le_bytes().to_vec();
            out.extend(d);
            out
        },
    );
    refused(
        "u64.vtu",
        &vtu_appended(" header_type=\"UInt64\"", (5, 2), false, &big),
        Some(6),
        "declares 9223372036854775808 bytes, more than the 120 bytes",
    );
}

#[test]
fn lz4_and_lzma_blocks_are_checked_like_zlib_blocks() {
    const LZ4: &str = " compressor=\"vtkLZ4DataCompressor\"";
    const LZMA: &str = " compressor=\"vtkLZMADataCompressor\"";
    // LZ4 inflates a byte to at most 255.
    let ratio = with(0, |_| table(&[1, 1 << 20, 1 << 20, 10], &[0; 10]), pack_lz4);
    refused(
        "lz4_ratio.vtu",
        &vtu_appended(LZ4, (1_000_000, 2), false, &ratio),
        Some(6),
        "more than LZ4 can inflate them to",
    );
    let corrupt = with(0, |d| one_block(d, vec![0xff; 30]), pack_lz4);
    refused(
        "lz4_corrupt.vtu",
        &vtu_appended(LZ4, (5, 2), false, &corrupt),
        Some(6),
        "cannot decompress a LZ4 block",
    );
    // LZMA: 2^16 per compressed byte (about nine times the best ratio measured).
    let ratio = with(
        0,
        |_| table(&[1, 1 << 26, 1 << 26, 10], &[0; 10]),
        pack_lzma,
    );
    refused(
        "lzma_ratio.vtu",
        &vtu_appended(LZMA, (3_000_000, 2), false, &ratio),
        Some(6),
        "more than LZMA can inflate them to",
    );
    for flip in [0, 8, 20, 40, 60] {
        let corrupt = with(
            0,
            move |d| {
                let mut b = pack_lzma(0, d);
                b[16 + flip] ^= 0x55;
                b
            },
            pack_lzma,
        );
        refused(
            "lzma_corrupt.vtu",
            &vtu_appended(LZMA, (5, 2), false, &corrupt),
            Some(6),
            "cannot decompress a LZMA block",
        );
    }
    // The right stream for the wrong array: the points' 120 bytes where the types' 2 are.
    let swapped = with(3, |d| pack_lzma(0, &[d, &[0; 118]].concat()), pack_lzma);
    refused(
        "lzma_swapped.vtu",
        &vtu_appended(LZMA, (5, 2), false, &swapped),
        Some(11),
        "more than the 2 bytes the grid's counts allow",
    );
}

#[test]
fn an_unknown_compressor_names_itself_and_the_supported_ones() {
    let file = vtu_appended(
        " compressor=\"vtkZstdDataCompressor\"",
        (5, 2),
        false,
        &pack_zlib,
    );
    refused(
        "zstd.vtu",
        &file,
        Some(2),
        "compressor `vtkZstdDataCompressor` is not supported (none, vtkZLibDataCompressor, \
         vtkLZ4DataCompressor and vtkLZMADataCompressor are)",
    );
    let file = vtu_appended(" header_type=\"UInt16\"", (5, 2), false, &pack_raw);
    refused("header.vtu", &file, Some(2), "neither UInt32 nor UInt64");
    let file = vtu_appended("", (5, 2), false, &pack_raw);
    let text = String::from_utf8_lossy(&file).replace("LittleEndian", "MiddleEndian");
    refused(
        "order.vtu",
        text.as_bytes(),
        Some(2),
        "byte_order `MiddleEndian` is neither LittleEndian nor BigEndian",
    );
    let text = String::from_utf8_lossy(&file).replace("Float64", "Float16");
    refused(
        "type.vtu",
        text.as_bytes(),
        Some(6),
        "DataArray type `Float16` is not supported",
    );
}

#[test]
fn data_array_children_are_read_past_and_must_nest() {
    let array = |children: &str| {
        format!(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\">\n\
             <UnstructuredGrid>\n<Piece NumberOfPoints=\"4\" NumberOfCells=\"1\">\n<Points>\n\
             <DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n\
             0 0 0 1 0 0 0 1 0 0 0 1\n{children}</DataArray>\n</Points>\n<Cells>\n\
             <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">0 1 2 3\
             </DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">4\
             </DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">10\
             </DataArray>\n</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n"
        )
    };
    let keys = "<InformationKey name=\"L2_NORM_RANGE\" location=\"vtkDataArray\" length=\"2\">\n\
                <Value index=\"0\">\n0\n</Value>\n<Value index=\"1\">\n1\n</Value>\n\
                </InformationKey>\n<!-- a comment -->\n\
                <InformationKey name=\"UNITS_LABEL\" location=\"vtkDataArray\">m</InformationKey>\n";
    assert_eq!(
        accepted("keys.vtu", array(keys).as_bytes()).tets,
        vec![[0, 1, 2, 3]]
    );
    refused(
        "nest.vtu",
        array("<InformationKey name=\"x\">\n<Value>1</InformationKey>\n").as_bytes(),
        Some(9),
        "`</InformationKey>` inside a `DataArray` where `</Value>` was expected",
    );
    let whole = array(keys);
    let cut = whole.find("</DataArray>\n</Points>").unwrap();
    refused(
        "open.vtu",
        &whole.as_bytes()[..cut],
        Some(6),
        "`DataArray` has no `</DataArray>`",
    );
}

#[test]
fn cells_of_every_integer_type_and_either_byte_order_read() {
    let ascii = |conn: &str, offsets: &str, types: &str| {
        format!(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\">\n\
             <UnstructuredGrid>\n<Piece NumberOfPoints=\"4\" NumberOfCells=\"1\">\n<Points>\n\
             <DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"ascii\">\
             0 0 0 1 0 0 0 1 0 0 0 1</DataArray>\n</Points>\n<Cells>\n\
             <DataArray type=\"{conn}\" Name=\"connectivity\" format=\"ascii\">0 1 2 3\
             </DataArray>\n<DataArray type=\"{offsets}\" Name=\"offsets\" format=\"ascii\">4\
             </DataArray>\n<DataArray type=\"{types}\" Name=\"types\" format=\"ascii\">10\
             </DataArray>\n</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n"
        )
    };
    for (conn, offsets, types) in [
        ("Int8", "Int16", "Int32"),
        ("UInt8", "UInt16", "UInt32"),
        ("UInt64", "Int64", "UInt8"),
        ("UInt32", "UInt64", "Int8"),
    ] {
        let text = ascii(conn, offsets, types);
        assert_eq!(
            accepted("ints.vtu", text.as_bytes()).tets,
            vec![[0, 1, 2, 3]],
            "{conn} {offsets} {types}"
        );
    }
    // Big-endian appended raw arrays with UInt32 connectivity and UInt16 offsets.
    let be = |data: &[u8], width: usize| -> Vec<u8> {
        let mut out = (data.len() as u32).to_be_bytes().to_vec();
        for v in data.chunks(width) {
            out.extend(v.iter().rev());
        }
        out
    };
    let [points, _, _, types] = mesh_arrays();
    let conn: Vec<u8> = TETS
        .iter()
        .flatten()
        .flat_map(|&v| (v as u32).to_le_bytes())
        .collect();
    let offsets: Vec<u8> = [4u16, 8].iter().flat_map(|v| v.to_le_bytes()).collect();
    let arrays = [points, conn, offsets, types];
    let widths = [8, 4, 2, 1];
    let file = vtu_appended("", (5, 2), false, &|i, _| be(&arrays[i], widths[i]));
    let file = replace(&file, "LittleEndian", "BigEndian");
    let file = replace(
        &file,
        "\"Int64\" Name=\"connectivity\"",
        "\"UInt32\" Name=\"connectivity\"",
    );
    let file = replace(
        &file,
        "\"Int64\" Name=\"offsets\"",
        "\"UInt16\" Name=\"offsets\"",
    );
    let mesh = accepted("big_endian.vtu", &file);
    assert_eq!(mesh.tets, TETS);
    assert_eq!(mesh.positions[4].x, 1.0);
}

#[test]
fn other_grids_and_pieces_are_refused_saying_what_is_read() {
    let file = String::from_utf8(vtu_appended("", (5, 2), true, &pack_raw)).unwrap();
    for (kind, name) in [("PUnstructuredGrid", "grid.pvtu"), ("PolyData", "poly.vtp")] {
        refused(
            name,
            file.replace("\"UnstructuredGrid\"", &format!("\"{kind}\""))
                .as_bytes(),
            Some(2),
            &format!("VTK file type `{kind}` is not supported; expected `UnstructuredGrid`"),
        );
    }
    let twice = file.replace(
        "</Piece>",
        "</Piece>\n<Piece NumberOfPoints=\"5\" NumberOfCells=\"2\">\n</Piece>",
    );
    refused(
        "pieces.vtu",
        twice.as_bytes(),
        Some(14),
        "a second `Piece`: only single-piece grids are supported",
    );
}

// --- legacy binary ---

#[test]
fn binary_legacy_counts_larger_than_the_file_are_refused_before_reserving() {
    let file = legacy_binary("5.1");
    let swap = |from: &str, to: &str| replace(&file, from, to);
    let message = refused(
        "points.vtk",
        &swap("POINTS 5 double", "POINTS 10000000 double"),
        Some(14),
        "POINTS announces 30000000 values of 8 bytes, but only",
    );
    assert!(message.contains("bytes are left"), "{message}");
    refused(
        "offsets.vtk",
        &swap("CELLS 3 8", "CELLS 5000000 8"),
        Some(22),
        "OFFSETS announces 5000000 values of 8 bytes",
    );
    refused(
        "types.vtk",
        &swap("CELL_TYPES 2", "CELL_TYPES 9000000"),
        Some(26),
        "CELL_TYPES announces 9000000 values of 4 bytes",
    );
    refused(
        "field.vtk",
        &swap("TimeValue 1 1 double", "TimeValue 1 9000000 double"),
        Some(7),
        "9000000 field array `TimeValue` of 8 bytes announced",
    );
    refused(
        "budget.vtk",
        &swap("POINTS 5 double", "POINTS 99999999999 double"),
        Some(13),
        "the header announces 99999999999 the number of points",
    );
    // A string whose length (8-byte form) runs past the file.
    let mut long = file.clone();
    let at = long.iter().position(|&b| b == 0xc5).unwrap();
    long.splice(at..at + 1, [0, 0, 0, 0, 0x7f, 0, 0, 0]);
    refused(
        "string.vtk",
        &long,
        Some(9),
        "field array `note` of 1 bytes announced",
    );
    // Text where the binary data should start.
    refused(
        "text.vtk",
        &swap("POINTS 5 double\n", "POINTS 5 double 7\n"),
        Some(13),
        "unexpected text before the binary data of POINTS",
    );
    // Cut inside the cell types.
    let cut = &file[..file.windows(12).position(|w| w == b"CELL_TYPES 2").unwrap() + 16];
    refused(
        "cut.vtk",
        cut,
        Some(26),
        "CELL_TYPES announces 2 values of 4 bytes, but only 3 bytes are left",
    );
    // A type no legacy reader knows, and one that cannot be read past.
    refused(
        "type.vtk",
        &swap("POINTS 5 double", "POINTS 5 quad"),
        Some(13),
        "`quad` is not a legacy VTK data type",
    );
    refused(
        "variant.vtk",
        &swap("TimeValue 1 1 double", "TimeValue 1 1 variant"),
        Some(6),
        "type `variant` cannot be read past",
    );
}

#[test]
fn metadata_and_field_data_are_read_past_in_ascii_files() {
    let text = "# vtk DataFile Version 5.1\nvtk output\nASCII\nDATASET UNSTRUCTURED_GRID\n\
        FIELD FieldData 4\nTimeValue 1 1 double\n0.5 \nNULL_ARRAY\nnote 1 2 string\n\
        first%20note\nsecond\nflags 1 3 bit\n1 0 1\n\
        METADATA\nINFORMATION 1\nNAME UNITS_LABEL LOCATION vtkDataArray\nDATA s\n\n\
        POINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1 \nMETADATA\nINFORMATION 1\n\
        NAME L2_NORM_RANGE LOCATION vtkDataArray\nDATA 2 0 1 \n\n\
        CELLS 2 4\nOFFSETS vtktypeint64\n0 4 \nMETADATA\nCOMPONENT_NAMES\nfirst\n\n\
        CONNECTIVITY vtktypeint64\n0 1 2 3 \nCELL_TYPES 1\n10\n\nCELL_DATA 1\n\
        FIELD FieldData 1\nregion 1 1 int\n0 \nMETADATA\nINFORMATION 0\n\n";
    assert_eq!(
        accepted("metadata.vtk", text.as_bytes()).tets,
        vec![[0, 1, 2, 3]]
    );
    // A METADATA block runs to a blank line: without one it swallows what follows.
    let open = text.replace("DATA 2 0 1 \n\n", "DATA 2 0 1 \n");
    refused(
        "open.vtk",
        open.as_bytes(),
        Some(32),
        "unexpected `CONNECTIVITY`",
    );
}
