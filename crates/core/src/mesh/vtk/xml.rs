//! VTK XML unstructured grids (`.vtu`) of linear tets, as VTK 9, ParaView, meshio and
//! softbench write them: one `Piece`; `DataArray`s `ascii`, inline base64 `binary` or
//! `appended` (raw or base64, `appended.rs`); uncompressed or compressed with zlib, LZ4 or
//! LZMA (`compressors.rs`); `UInt32` or `UInt64` headers; either byte order (`binary.rs`).
//! Child elements of a `DataArray` (VTK's `<InformationKey>`) are read past (`tags.rs`).
//!
//! Sizes are checked before work: the `Piece` counts against the mesh budget, then every
//! array's declared size (a block table included, and what its compressed bytes can inflate
//! to) against what `NumberOfPoints` and `NumberOfCells` allow, before it is inflated or
//! converted to f64. Arrays softbench does not use are read past undecoded; a second
//! `<Points>`, `<Cells>` or mesh array is refused. Appended arrays are decoded once the
//! `<AppendedData>` section is reached, at the end of the file.
//!
//! Point data with three components (softbench writes `velocity` and `displacement`) and the
//! field `TimeValue` are kept by [`read_vtu_frame`], so a run can start from an exported frame.

use std::path::Path;

use nalgebra::Vector3;

use super::super::bytes::{Cursor, bad_coordinate, clip};
use super::super::text::{self, parse_error};
use super::super::{MeshError, TetMesh};
use super::appended::Appended;
use super::base64;
use super::binary::{self, Bytes, Encoding};
use super::cells::cells;
use super::compressors::{self, Compressor};
use super::tags::{Tag, array_content, next_tag};

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

/// A mesh array found while scanning: where it is and how it is stored, decoded once the
/// appended data (if any) has been reached.
struct Found<'a> {
    /// Offset of its `DataArray` tag and the line there.
    at: usize,
    line: usize,
    role: Role,
    /// The VTK type (`Float64`, `Int32`, ...).
    kind: &'a str,
    data: ArrayData,
}

/// An array's values, or where they are in the appended data.
enum ArrayData {
    Values(Vec<f64>),
    Appended(u64),
}

/// Parses `.vtu` bytes; `path` is used only in error messages.
pub fn parse_vtu(bytes: &[u8], path: &Path) -> Result<VtuFrame, MeshError> {
    let mut c = Cursor::new(bytes, path);
    let mut encoding = None;
    let mut piece: Option<(usize, usize, usize)> = None;
    let mut section = "";
    let mut sections_seen = std::collections::HashSet::new();
    let mut points: Option<Found> = None;
    let (mut connectivity, mut offsets, mut types) = (None, None, None);
    let mut point_arrays: Vec<(String, Found)> = Vec::new();
    let mut time: Option<Found> = None;
    let mut appended = None;
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
                let compressor =
                    Compressor::from_attribute(tag.get("compressor")).map_err(|other| {
                        c.error_at(
                            tag.at,
                            format!(
                                "compressor `{}` is not supported ({})",
                                clip(other),
                                compressors::SUPPORTED
                            ),
                        )
                    })?;
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
                let little = match tag.get("byte_order") {
                    None | Some("LittleEndian") => true,
                    Some("BigEndian") => false,
                    Some(other) => {
                        return Err(c.error_at(
                            tag.at,
                            format!(
                                "byte_order `{}` is neither LittleEndian nor BigEndian",
                                clip(other)
                            ),
                        ));
                    }
                };
                encoding = Some(Encoding {
                    little,
                    header64,
                    compressor,
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
                // Its raw bytes are not XML: no tag is looked for after it.
                appended = Some(Appended::open(&mut c, &tag)?);
                break;
            }
            ("DataArray", false) => {
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
                let kind = tag.get("type").unwrap_or("");
                let data = data_array(&mut c, &tag, enc, limit, role.what())?;
                let found = Found {
                    at: tag.at,
                    line,
                    role,
                    kind,
                    data,
                };
                let slot = match role {
                    Role::Points => &mut points,
                    Role::Connectivity => &mut connectivity,
                    Role::Offsets => &mut offsets,
                    Role::Types => &mut types,
                    Role::PointVector => {
                        point_arrays.push((name, found));
                        continue;
                    }
                    Role::Time => {
                        time = Some(found);
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
                *slot = Some(found);
            }
            _ => {}
        }
    }
    let end = c.line_at(bytes.len());
    let Some((piece_at, n, m)) = piece else {
        return Err(text::empty_mesh(path, end, "no `Piece`"));
    };
    // Arrays in the appended data are decoded now that it has been found.
    // Without a `VTKFile` tag no array was found, and the encoding is not used.
    let enc = encoding.unwrap_or(Encoding {
        little: true,
        header64: false,
        compressor: None,
    });
    let counts = (n, m);
    let mut values = |found: Found| -> Result<(usize, Vec<f64>), MeshError> {
        resolve(&mut c, found, enc, appended.as_ref(), counts)
    };
    let points = points.map(&mut values).transpose()?;
    let connectivity = connectivity.map(&mut values).transpose()?;
    let offsets = offsets.map(&mut values).transpose()?;
    let types = types.map(&mut values).transpose()?;
    let time = time.map(&mut values).transpose()?;
    let point_arrays = point_arrays
        .into_iter()
        .map(|(name, found)| Ok((name, values(found)?)))
        .collect::<Result<Vec<_>, MeshError>>()?;
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
    for (name, (line, values)) in point_arrays {
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
        time: time.and_then(|(_, t)| t.first().copied()),
    })
}

/// A found array's values with its line: decoded already, or decoded now from the appended
/// data at its offset.
fn resolve(
    c: &mut Cursor,
    found: Found,
    enc: Encoding,
    appended: Option<&Appended>,
    (n, m): (usize, usize),
) -> Result<(usize, Vec<f64>), MeshError> {
    let offset = match found.data {
        ArrayData::Values(values) => return Ok((found.line, values)),
        ArrayData::Appended(offset) => offset,
    };
    let Some(appended) = appended else {
        return Err(c.error_at(
            found.at,
            "an appended `DataArray`, but the file has no `<AppendedData>` section",
        ));
    };
    let what = found.role.what();
    let limit = found.role.max_values(n, m);
    // The type was checked when the array was found.
    let width = binary::width(found.kind).unwrap_or(1);
    let data = appended
        .array(offset, enc, limit.saturating_mul(width) as u64)
        .map_err(|m| {
            c.error_at(
                found.at,
                format!("the {what} array (appended data at offset {offset}): {m}"),
            )
        })?;
    let values = to_values(c, found.at, found.kind, width, &data, enc.little)?;
    Ok((found.line, values))
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

/// Reads one `DataArray` (the cursor is just past its opening tag) up to its `</DataArray>`:
/// an inline array decoded to at most `limit` f64 values, an appended one as its offset. The
/// sizes a binary array declares are checked against `limit` before it is inflated, and its
/// values counted before they are converted; an ascii array stops at the first value past
/// `limit`.
fn data_array(
    c: &mut Cursor,
    tag: &Tag,
    enc: Encoding,
    limit: usize,
    what: &str,
) -> Result<ArrayData, MeshError> {
    let kind = tag.get("type").unwrap_or("");
    let Some(width) = binary::width(kind) else {
        return Err(c.error_at(
            tag.at,
            format!(
                "DataArray type `{}` is not supported (Int8 to Int64, UInt8 to UInt64, Float32 \
                 and Float64 are)",
                clip(kind)
            ),
        ));
    };
    let format = tag.get("format").unwrap_or("ascii");
    let (start, content) = array_content(c, tag)?;
    let too_many = |found: String| {
        format!("the {what} array holds {found}, more than the {limit} values the grid allows")
    };
    match format {
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
            Ok(ArrayData::Values(values))
        }
        "binary" => {
            let raw = base64::decode(content)
                .map_err(|i| c.error_at(start + i, "DataArray is not valid base64"))?;
            let max_bytes = limit.saturating_mul(width) as u64;
            let data = binary::unpack(&mut Bytes(&raw), enc, max_bytes)
                .map_err(|m| c.error_at(start, format!("the {what} array: {m}")))?;
            let values = to_values(c, start, kind, width, &data, enc.little)?;
            Ok(ArrayData::Values(values))
        }
        "appended" => {
            let offset = tag.get("offset").unwrap_or("");
            let offset = offset.parse().map_err(|_| {
                c.error_at(
                    tag.at,
                    format!(
                        "an appended DataArray needs an `offset`, found `{}`",
                        clip(offset)
                    ),
                )
            })?;
            Ok(ArrayData::Appended(offset))
        }
        other => Err(c.error_at(
            tag.at,
            format!(
                "DataArray format `{}` is not supported (ascii, binary and appended are)",
                clip(other)
            ),
        )),
    }
}

/// The values of a binary array's bytes; `at` locates errors.
fn to_values(
    c: &mut Cursor,
    at: usize,
    kind: &str,
    width: usize,
    data: &[u8],
    little: bool,
) -> Result<Vec<f64>, MeshError> {
    if !data.len().is_multiple_of(width) {
        return Err(c.error_at(
            at,
            format!(
                "{} bytes is not a whole number of {kind} values",
                data.len()
            ),
        ));
    }
    Ok(data
        .chunks_exact(width)
        .map(|b| binary::number(kind, b, little))
        .collect())
}
