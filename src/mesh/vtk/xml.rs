//! VTK XML unstructured grids (`.vtu`) of linear tets: one `Piece`; `DataArray`s inline as
//! `ascii` or base64 `binary`, uncompressed or zlib-compressed, `UInt32` or `UInt64` headers,
//! either byte order (softbench's own frames and meshio's files). Appended data is refused
//! with a message saying so.
//!
//! Sizes are checked before work: the `Piece` counts against the mesh budget, then every
//! array's declared size (a zlib block table included, and what its compressed bytes can
//! inflate to) against what `NumberOfPoints` and `NumberOfCells` allow, before it is
//! inflated or converted to f64. Arrays softbench does not use are read past undecoded; a
//! second `<Points>`, `<Cells>` or mesh array is refused.
//!
//! Point data with three components (softbench writes `velocity` and `displacement`) and the
//! field `TimeValue` are kept by [`read_vtu_frame`], so a run can start from an exported frame.

use std::io::Read;
use std::path::Path;

use nalgebra::Vector3;

use super::super::bytes::{Cursor, bad_coordinate, clip};
use super::super::text::{self, parse_error};
use super::super::{MeshError, TetMesh};
use super::cells::cells;

/// A `.vtu` grid with the point data and time it carries.
#[derive(Clone, Debug, PartialEq)]
pub struct VtuFrame {
    /// Points and tets.
    pub mesh: TetMesh,
    /// Point arrays with three components, by name (e.g. `velocity`), one entry per point.
    pub point_vectors: Vec<(String, Vec<Vector3<f64>>)>,
    /// The field `TimeValue`, when the file has one (softbench's frames do).
    pub time: Option<f64>,
}

impl VtuFrame {
    /// The point array `name`, if the file has it.
    pub fn point_vector(&self, name: &str) -> Option<&[Vector3<f64>]> {
        self.point_vectors
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }
}

/// Whether bytes look like a VTK XML file (`<?xml` or `<VTKFile` first).
pub fn looks_like_vtu(bytes: &[u8]) -> bool {
    let start = bytes.iter().position(|b| !b.is_ascii_whitespace());
    start.is_some_and(|s| bytes[s..].starts_with(b"<?xml") || bytes[s..].starts_with(b"<VTKFile"))
}

/// Reads a `.vtu` file's tet mesh.
pub fn read_vtu(path: impl AsRef<Path>) -> Result<TetMesh, MeshError> {
    Ok(read_vtu_frame(path)?.mesh)
}

/// Reads a `.vtu` file with its point data and time.
pub fn read_vtu_frame(path: impl AsRef<Path>) -> Result<VtuFrame, MeshError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|error| MeshError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    parse_vtu(&bytes, path)
}

/// One XML tag: its name, attributes, offset, and whether it closes (`</x>`) or is empty
/// (`<x/>`).
struct Tag<'a> {
    at: usize,
    name: &'a str,
    attributes: Vec<(&'a str, &'a str)>,
    closing: bool,
    empty: bool,
}

impl Tag<'_> {
    fn get(&self, key: &str) -> Option<&str> {
        self.attributes
            .iter()
            .find(|(k, _)| *k == key)
            .map(|&(_, v)| v)
    }
}

/// The next tag at or after the cursor, skipping comments, declarations and text.
fn next_tag<'a>(c: &mut Cursor<'a>) -> Result<Option<Tag<'a>>, MeshError> {
    loop {
        let rest = &c.bytes[c.pos..];
        let Some(i) = rest.iter().position(|&b| b == b'<') else {
            c.pos = c.bytes.len();
            return Ok(None);
        };
        let at = c.pos + i;
        let rest = &c.bytes[at..];
        let skip_to = |end: &[u8]| rest.windows(end.len()).position(|w| w == end);
        if rest.starts_with(b"<!--") || rest.starts_with(b"<?") || rest.starts_with(b"<!") {
            let end: &[u8] = if rest.starts_with(b"<!--") {
                b"-->"
            } else if rest.starts_with(b"<?") {
                b"?>"
            } else {
                b">"
            };
            match skip_to(end) {
                Some(j) => {
                    c.pos = at + j + end.len();
                    continue;
                }
                None => return Err(c.error_at(at, "unterminated XML comment or declaration")),
            }
        }
        let Some(close) = rest.iter().position(|&b| b == b'>') else {
            return Err(c.error_at(at, "unterminated XML tag"));
        };
        c.pos = at + close + 1;
        let Ok(inner) = std::str::from_utf8(&rest[1..close]) else {
            return Err(c.error_at(at, "XML tag is not UTF-8 text"));
        };
        let closing = inner.starts_with('/');
        let empty = inner.ends_with('/');
        let inner = inner.trim_start_matches('/').trim_end_matches('/');
        let (name, mut attrs) = inner
            .split_once(|ch: char| ch.is_ascii_whitespace())
            .unwrap_or((inner, ""));
        let mut attributes = Vec::new();
        loop {
            attrs = attrs.trim_start();
            if attrs.is_empty() {
                break;
            }
            let Some((key, after)) = attrs.split_once('=') else {
                return Err(c.error_at(
                    at,
                    format!("malformed XML attributes in `<{}>`", clip(name)),
                ));
            };
            let after = after.trim_start();
            let quote = after.chars().next().filter(|q| *q == '"' || *q == '\'');
            let Some(q) = quote else {
                return Err(c.error_at(at, format!("unquoted attribute `{}`", clip(key.trim()))));
            };
            let Some((value, rest)) = after[1..].split_once(q) else {
                return Err(
                    c.error_at(at, format!("unterminated attribute `{}`", clip(key.trim())))
                );
            };
            attributes.push((key.trim(), value));
            attrs = rest;
        }
        return Ok(Some(Tag {
            at,
            name,
            attributes,
            closing,
            empty,
        }));
    }
}

/// How binary arrays are encoded, from the `VTKFile` tag.
#[derive(Clone, Copy)]
struct Encoding {
    little: bool,
    header64: bool,
    zlib: bool,
}

/// Parses `.vtu` bytes; `path` is used only in error messages.
pub fn parse_vtu(bytes: &[u8], path: &Path) -> Result<VtuFrame, MeshError> {
    let mut c = Cursor::new(bytes, path);
    let mut encoding = None;
    let mut piece: Option<(usize, usize, usize)> = None;
    let mut section = "";
    let mut sections_seen = std::collections::HashSet::new();
    let mut points: Option<(usize, Vec<f64>)> = None;
    let (mut connectivity, mut offsets, mut types) = (None, None, None);
    let mut point_arrays: Vec<(String, usize, Vec<f64>)> = Vec::new();
    let mut time = None;
    while let Some(tag) = next_tag(&mut c)? {
        match (tag.name, tag.closing) {
            ("VTKFile", false) => {
                if tag.get("type") != Some("UnstructuredGrid") {
                    return Err(c.error_at(
                        tag.at,
                        format!(
                            "VTK file type `{}` is not supported; expected `UnstructuredGrid`",
                            clip(tag.get("type").unwrap_or("(none)"))
                        ),
                    ));
                }
                let zlib = match tag.get("compressor") {
                    None | Some("") => false,
                    Some("vtkZLibDataCompressor") => true,
                    Some(other) => {
                        return Err(c.error_at(
                            tag.at,
                            format!(
                                "compressor `{}` is not supported (uncompressed and \
                                 vtkZLibDataCompressor are)",
                                clip(other)
                            ),
                        ));
                    }
                };
                let header64 = match tag.get("header_type") {
                    None | Some("UInt32") => false,
                    Some("UInt64") => true,
                    Some(other) => {
                        return Err(c.error_at(
                            tag.at,
                            format!("header_type `{}` is neither UInt32 nor UInt64", clip(other)),
                        ));
                    }
                };
                encoding = Some(Encoding {
                    little: tag.get("byte_order") != Some("BigEndian"),
                    header64,
                    zlib,
                });
            }
            ("Piece", false) => {
                if piece.is_some() {
                    return Err(c.error_at(
                        tag.at,
                        "a second `Piece`: only single-piece grids are supported",
                    ));
                }
                let count = |c: &mut Cursor, key: &str| -> Result<usize, MeshError> {
                    let v = tag.get(key).unwrap_or("");
                    v.parse().map_err(|_| {
                        c.error_at(tag.at, format!("`Piece` needs {key}, found `{}`", clip(v)))
                    })
                };
                let n = count(&mut c, "NumberOfPoints")?;
                let m = count(&mut c, "NumberOfCells")?;
                let line = c.line_at(tag.at);
                text::announced(
                    path,
                    line,
                    n.saturating_add(m),
                    "points and cells",
                    bytes.len(),
                )?;
                piece = Some((tag.at, n, m));
            }
            ("Points" | "Cells", false) if !tag.empty => {
                if !sections_seen.insert(tag.name) {
                    return Err(c.error_at(
                        tag.at,
                        format!(
                            "a second `<{}>`: a single-piece grid has one (the first would be \
                             silently replaced)",
                            tag.name
                        ),
                    ));
                }
                section = tag.name;
            }
            ("PointData" | "CellData" | "FieldData", false) if !tag.empty => {
                section = tag.name;
            }
            ("Points" | "Cells" | "PointData" | "CellData" | "FieldData", true) => section = "",
            ("AppendedData", false) => {
                return Err(c.error_at(
                    tag.at,
                    "appended data is not supported; write the arrays inline (ParaView: \
                     Data Mode Binary or Ascii)",
                ));
            }
            ("DataArray", false) if !tag.empty => {
                let Some(enc) = encoding else {
                    return Err(c.error_at(tag.at, "`DataArray` outside a `VTKFile`"));
                };
                let name = tag.get("Name").unwrap_or("").to_string();
                let components: usize = tag
                    .get("NumberOfComponents")
                    .unwrap_or("1")
                    .parse()
                    .map_err(|_| c.error_at(tag.at, "NumberOfComponents is not a count"))?;
                let line = c.line_at(tag.at);
                let role = match (section, name.as_str()) {
                    ("Points", _) => Role::Points,
                    ("Cells", "connectivity") => Role::Connectivity,
                    ("Cells", "offsets") => Role::Offsets,
                    ("Cells", "types") => Role::Types,
                    ("PointData", _) if components == 3 => Role::PointVector,
                    ("FieldData", "TimeValue") => Role::Time,
                    // Arrays softbench does not use are read past, never decoded.
                    _ => {
                        array_content(&mut c, &tag)?;
                        continue;
                    }
                };
                let counts = piece.map(|(_, n, m)| (n, m));
                if counts.is_none() && role != Role::Time {
                    return Err(c.error_at(
                        tag.at,
                        "a mesh `DataArray` before its `Piece` (NumberOfPoints and \
                         NumberOfCells must come first)",
                    ));
                }
                let (n, m) = counts.unwrap_or((0, 0));
                let limit = role.max_values(n, m);
                let values = data_array(&mut c, &tag, enc, limit, role.what())?;
                let slot = match role {
                    Role::Points => &mut points,
                    Role::Connectivity => &mut connectivity,
                    Role::Offsets => &mut offsets,
                    Role::Types => &mut types,
                    Role::PointVector => {
                        point_arrays.push((name, line, values));
                        continue;
                    }
                    Role::Time => {
                        time = values.first().copied();
                        continue;
                    }
                };
                if slot.is_some() {
                    return Err(c.error_at(
                        tag.at,
                        format!(
                            "a second {} array: a grid has one (the first would be silently \
                             replaced)",
                            role.what()
                        ),
                    ));
                }
                *slot = Some((line, values));
            }
            _ => {}
        }
    }
    let end = c.line_at(bytes.len());
    let Some((piece_at, n, m)) = piece else {
        return Err(text::empty_mesh(path, end, "no `Piece`"));
    };
    let piece_line = c.line_at(piece_at);
    let (_, points) = points.ok_or_else(|| text::empty_mesh(path, end, "no `Points` array"))?;
    if points.len() != 3 * n {
        return Err(parse_error(
            path,
            piece_line,
            format!(
                "`Points` holds {} numbers, but NumberOfPoints = {n} needs {}",
                points.len(),
                3 * n
            ),
        ));
    }
    let mut positions = Vec::with_capacity(n);
    for p in points.chunks_exact(3) {
        if let Some(msg) = p.iter().find_map(|&x| bad_coordinate(x)) {
            return Err(parse_error(path, piece_line, msg));
        }
        positions.push(Vector3::new(p[0], p[1], p[2]));
    }
    let missing =
        |what: &str| text::empty_mesh(path, end, &format!("no `{what}` array in `Cells`"));
    let (cl, connectivity) = connectivity.ok_or_else(|| missing("connectivity"))?;
    let (ol, offsets) = offsets.ok_or_else(|| missing("offsets"))?;
    let (tl, types) = types.ok_or_else(|| missing("types"))?;
    let lines = [cl, ol, tl];
    if offsets.len() != m || types.len() != m {
        return Err(parse_error(
            path,
            ol,
            format!(
                "`offsets` and `types` hold {} and {} entries, but NumberOfCells = {m}",
                offsets.len(),
                types.len()
            ),
        ));
    }
    let tets = cells(path, &connectivity, &offsets, &types, lines, n)?;
    let mut point_vectors = Vec::new();
    for (name, line, values) in point_arrays {
        if values.len() != 3 * n {
            return Err(parse_error(
                path,
                line,
                format!(
                    "point array `{}` holds {} numbers, but {n} points need {}",
                    clip(&name),
                    values.len(),
                    3 * n
                ),
            ));
        }
        let v = values
            .chunks_exact(3)
            .map(|p| Vector3::new(p[0], p[1], p[2]))
            .collect();
        point_vectors.push((name, v));
    }
    Ok(VtuFrame {
        mesh: TetMesh { positions, tets },
        point_vectors,
        time,
    })
}

/// What a decoded `DataArray` is for; every other array is read past undecoded.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Role {
    Points,
    Connectivity,
    Offsets,
    Types,
    /// A point array of three components (velocity, displacement).
    PointVector,
    /// The field `TimeValue`.
    Time,
}

/// Most points a VTK cell has (the triquadratic hexahedron's 27): a bound on the connectivity
/// of a grid of linear tets and the other fixed-size cells read past.
const MAX_CELL_POINTS: usize = 27;
/// Most values a `TimeValue` field may hold.
const MAX_TIME_VALUES: usize = 16;

impl Role {
    /// Most values the array may hold for `n` points and `m` cells: checked against the sizes
    /// it declares before anything is decoded, inflated or converted.
    fn max_values(self, n: usize, m: usize) -> usize {
        match self {
            Role::Points | Role::PointVector => n.saturating_mul(3),
            Role::Connectivity => m.saturating_mul(MAX_CELL_POINTS),
            Role::Offsets | Role::Types => m,
            Role::Time => MAX_TIME_VALUES,
        }
    }

    /// The array in messages, with the count that bounds it.
    fn what(self) -> &'static str {
        match self {
            Role::Points => "`Points` (3 per point of NumberOfPoints)",
            Role::Connectivity => "`connectivity` (at most 27 per cell of NumberOfCells)",
            Role::Offsets => "`offsets` (one per cell of NumberOfCells)",
            Role::Types => "`types` (one per cell of NumberOfCells)",
            Role::PointVector => "point array (3 per point of NumberOfPoints)",
            Role::Time => "`TimeValue` (at most 16)",
        }
    }
}

/// The content of one `DataArray` (the cursor is just past its opening tag); moves past
/// `</DataArray>`.
fn array_content<'a>(c: &mut Cursor<'a>, tag: &Tag) -> Result<(usize, &'a [u8]), MeshError> {
    let start = c.pos;
    let rest = &c.bytes[start..];
    let close = b"</DataArray>";
    let Some(len) = rest.windows(close.len()).position(|w| w == close) else {
        return Err(c.error_at(tag.at, "`DataArray` has no `</DataArray>`"));
    };
    c.pos = start + len + close.len();
    Ok((start, &rest[..len]))
}

/// Decodes one `DataArray`'s content (the cursor is just past its opening tag) to at most
/// `limit` f64 values, and moves past `</DataArray>`. The sizes a binary array declares are
/// checked against `limit` before it is inflated, and its values counted before they are
/// converted; an ascii array stops at the first value past `limit`.
fn data_array(
    c: &mut Cursor,
    tag: &Tag,
    enc: Encoding,
    limit: usize,
    what: &str,
) -> Result<Vec<f64>, MeshError> {
    let (start, content) = array_content(c, tag)?;
    let kind = tag.get("type").unwrap_or("");
    let width = match kind {
        "Int8" | "UInt8" => 1,
        "Int16" | "UInt16" => 2,
        "Int32" | "UInt32" | "Float32" => 4,
        "Int64" | "UInt64" | "Float64" => 8,
        other => {
            return Err(c.error_at(tag.at, format!("unknown DataArray type `{}`", clip(other))));
        }
    };
    let too_many = |found: String| {
        format!("the {what} array holds {found}, more than the {limit} values the grid allows")
    };
    match tag.get("format").unwrap_or("ascii") {
        "ascii" => {
            let Ok(text) = std::str::from_utf8(content) else {
                return Err(c.error_at(start, "ascii DataArray is not text"));
            };
            let mut values = Vec::with_capacity(limit.min(text.len() / 2 + 1));
            for token in text.split_ascii_whitespace() {
                let at = start + (token.as_ptr() as usize - text.as_ptr() as usize);
                if values.len() == limit {
                    return Err(c.error_at(at, too_many("more values".into())));
                }
                match token.parse::<f64>() {
                    Ok(x) => values.push(x),
                    Err(_) => {
                        return Err(
                            c.error_at(at, format!("expected a number, found `{}`", clip(token)))
                        );
                    }
                }
            }
            Ok(values)
        }
        "binary" => {
            let raw = decode_base64(content)
                .map_err(|i| c.error_at(start + i, "DataArray is not valid base64"))?;
            let max_bytes = limit.saturating_mul(width) as u64;
            let data = unpack(&raw, enc, max_bytes)
                .map_err(|m| c.error_at(start, format!("the {what} array: {m}")))?;
            if data.len() % width != 0 {
                return Err(c.error_at(
                    start,
                    format!(
                        "{} bytes is not a whole number of {kind} values",
                        data.len()
                    ),
                ));
            }
            Ok(data
                .chunks_exact(width)
                .map(|b| number(kind, b, enc.little))
                .collect())
        }
        "appended" => Err(c.error_at(
            tag.at,
            "appended data is not supported; write the arrays inline",
        )),
        other => Err(c.error_at(
            tag.at,
            format!(
                "DataArray format `{}` is not ascii, binary or appended",
                clip(other)
            ),
        )),
    }
}

/// One value of a binary array as f64 (exact for every float and for integers up to 2^53).
fn number(kind: &str, b: &[u8], little: bool) -> f64 {
    let mut a = [0u8; 8];
    a[..b.len()].copy_from_slice(b);
    if !little {
        a[..b.len()].reverse();
    }
    let u = u64::from_le_bytes(a);
    match kind {
        "Int8" => f64::from(u as u8 as i8),
        "Int16" => f64::from(u as u16 as i16),
        "Int32" => f64::from(u as u32 as i32),
        "Int64" => u as i64 as f64,
        "Float32" => f64::from(f32::from_bits(u as u32)),
        "Float64" => f64::from_bits(u),
        _ => u as f64,
    }
}

/// Most bytes a zlib stream can inflate to per compressed byte (deflate's limit: a 258-byte
/// match in two bits), plus a constant for the stream's own framing.
const MAX_ZLIB_RATIO: u64 = 1032;
const ZLIB_SLACK: u64 = 4096;

/// The array bytes of a decoded binary block: a byte count then the data, or (zlib) a
/// block table then the compressed blocks. Every size the header declares is checked —
/// against `max_bytes` (what the grid's counts allow), the mesh budget and what the
/// compressed blocks can inflate to — before anything is allocated or inflated.
fn unpack(raw: &[u8], enc: Encoding, max_bytes: u64) -> Result<Vec<u8>, String> {
    let hs = if enc.header64 { 8 } else { 4 };
    let header = |i: usize| -> Result<u64, String> {
        let b = raw
            .get(i * hs..(i + 1) * hs)
            .ok_or("binary DataArray ends inside its header")?;
        Ok(number(
            if enc.header64 { "UInt64" } else { "UInt32" },
            b,
            enc.little,
        ) as u64)
    };
    let over = |n: u64| {
        format!("it declares {n} bytes, more than the {max_bytes} bytes the grid's counts allow")
    };
    if !enc.zlib {
        let n = header(0)?;
        let data = &raw[hs..];
        if n > max_bytes {
            return Err(over(n));
        }
        if (data.len() as u64) < n {
            return Err(format!(
                "binary DataArray announces {n} bytes but holds {}",
                data.len()
            ));
        }
        return Ok(data[..n as usize].to_vec());
    }
    let blocks = header(0)?;
    let block_size = header(1)?;
    // VTK writes 0 here when the last block is full.
    let last_size = match header(2)? {
        0 => block_size,
        partial => partial,
    };
    let table_end = 3u64
        .checked_add(blocks)
        .and_then(|k| k.checked_mul(hs as u64))
        .filter(|&e| e <= raw.len() as u64)
        .ok_or("compressed DataArray's block table is longer than the array")?;
    if blocks > 0 && last_size > block_size {
        return Err(format!(
            "its last block of {last_size} bytes is larger than the block size {block_size}"
        ));
    }
    let total = blocks
        .saturating_sub(1)
        .saturating_mul(block_size)
        .saturating_add(if blocks > 0 { last_size } else { 0 });
    if total > max_bytes {
        return Err(over(total));
    }
    // Every entry of a point or cell array of a budget-sized mesh, nine 8-byte components.
    let budget = crate::limits::MESH.limit().saturating_mul(9 * 8);
    if total > budget {
        return Err(format!(
            "it declares {total} bytes, more than an array of a mesh within the mesh budget \
             can hold"
        ));
    }
    // Each block's declared size against what its compressed bytes can inflate to, and the
    // blocks against the array's length, before any is inflated.
    let mut at = table_end;
    for b in 0..blocks as usize {
        let size = header(3 + b)?;
        let expect = if b + 1 == blocks as usize {
            last_size
        } else {
            block_size
        };
        at = at
            .checked_add(size)
            .filter(|&e| e <= raw.len() as u64)
            .ok_or("compressed DataArray ends inside a block")?;
        if expect
            > size
                .saturating_mul(MAX_ZLIB_RATIO)
                .saturating_add(ZLIB_SLACK)
        {
            return Err(format!(
                "block {b} declares {expect} bytes from {size} compressed bytes, more than \
                 zlib can inflate them to"
            ));
        }
    }
    let mut out = Vec::with_capacity((total as usize).min(raw.len().saturating_mul(4)));
    let mut at = table_end as usize;
    for b in 0..blocks as usize {
        let size = header(3 + b)? as usize;
        let chunk = &raw[at..at + size];
        at += size;
        let expect = if b + 1 == blocks as usize {
            last_size
        } else {
            block_size
        };
        let before = out.len();
        flate2::read::ZlibDecoder::new(chunk)
            .take(expect)
            .read_to_end(&mut out)
            .map_err(|e| format!("cannot decompress a block: {e}"))?;
        if (out.len() - before) as u64 != expect {
            return Err("a compressed block is shorter than its header says".into());
        }
    }
    Ok(out)
}

/// Standard base64 with `=` padding, ignoring whitespace; padding may end one encoded run
/// and another follow (VTK encodes a compressed array's header and data separately). On
/// error, the offset of the bad character.
fn decode_base64(text: &[u8]) -> Result<Vec<u8>, usize> {
    let mut out = Vec::with_capacity(text.len() / 4 * 3);
    let mut group = [0u8; 4];
    let mut n = 0;
    let mut pad = 0;
    for (i, &ch) in text.iter().enumerate() {
        let v = match ch {
            b'A'..=b'Z' => ch - b'A',
            b'a'..=b'z' => ch - b'a' + 26,
            b'0'..=b'9' => ch - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            b'=' => {
                if n < 2 {
                    return Err(i);
                }
                pad += 1;
                0
            }
            c if c.is_ascii_whitespace() => continue,
            _ => return Err(i),
        };
        if pad > 0 && ch != b'=' {
            return Err(i);
        }
        group[n] = v;
        n += 1;
        if n == 4 {
            let x = u32::from(group[0]) << 18
                | u32::from(group[1]) << 12
                | u32::from(group[2]) << 6
                | u32::from(group[3]);
            let bytes = [(x >> 16) as u8, (x >> 8) as u8, x as u8];
            out.extend_from_slice(&bytes[..3 - pad]);
            n = 0;
            pad = 0;
        }
    }
    if n != 0 {
        return Err(text.len());
    }
    Ok(out)
}
