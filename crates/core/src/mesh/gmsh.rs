//! Gmsh `.msh` files, format versions 2.2 and 4.1, ASCII and binary (either byte order).
//!
//! The linear tets (element type 4) become the [`TetMesh`]; every node is kept, in file
//! order; other elements (points, lines, triangles of physical groups, ...) are read past.
//! Second-order tets (type 11) are refused rather than cut to their corners. Sections other
//! than `$MeshFormat`, `$Nodes` and `$Elements` (`$Entities`, `$PhysicalNames`, `$NodeData`,
//! ...) are skipped to their `$End` line. Node tags may be any positive numbers, in any order.
//!
//! Errors name the file and line; in a binary block the line is the one an editor would
//! show, and the byte offset is given as well.

use std::collections::HashMap;
use std::path::Path;

use nalgebra::Vector3;

use super::bytes::{Cursor, Endian, bad_coordinate, clip};
use super::text::{self, TetCollector};
use super::{MeshError, TetMesh};

/// Gmsh's linear tetrahedron.
const TET4: i32 = 4;
/// Gmsh's second-order (10-node) tetrahedron.
const TET10: i32 = 11;

/// Reads a `.msh` file.
pub fn read(path: impl AsRef<Path>) -> Result<TetMesh, MeshError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|error| MeshError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    parse(&bytes, path)
}

/// Whether a file's content looks like Gmsh: its first line is `$MeshFormat`.
pub fn looks_like(bytes: &[u8]) -> bool {
    let start = bytes.iter().position(|b| !b.is_ascii_whitespace());
    start.is_some_and(|s| bytes[s..].starts_with(b"$MeshFormat"))
}

/// Format version and encoding from `$MeshFormat`.
#[derive(Clone, Copy)]
struct Format {
    v4: bool,
    /// `None` for ASCII.
    binary: Option<Endian>,
}

/// Parses `.msh` bytes; `path` is used only in error messages.
pub fn parse(bytes: &[u8], path: &Path) -> Result<TetMesh, MeshError> {
    let mut c = Cursor::new(bytes, path);
    let (at, first) = c.nonblank_line("`$MeshFormat`")?;
    if first != "$MeshFormat" {
        return Err(c.error_at(
            at,
            format!(
                "expected `$MeshFormat` to start a Gmsh file, found `{}`",
                clip(first)
            ),
        ));
    }
    let format = mesh_format(&mut c)?;
    let mut nodes: Option<Nodes> = None;
    let mut tets: Option<(usize, TetCollector)> = None;
    while let Some((at, line)) = c.line()? {
        if line.is_empty() {
            continue;
        }
        let Some(name) = line.strip_prefix('$') else {
            return Err(c.error_at(
                at,
                format!(
                    "expected a section such as `$Nodes` or `$Elements`, found `{}`",
                    clip(line)
                ),
            ));
        };
        match name {
            "Nodes" => {
                if nodes.is_some() {
                    return Err(c.error_at(at, "a second `$Nodes` section"));
                }
                nodes = Some(if format.v4 {
                    nodes_v4(&mut c, format.binary)?
                } else {
                    nodes_v2(&mut c, format.binary)?
                });
            }
            "Elements" => {
                if tets.is_some() {
                    return Err(c.error_at(at, "a second `$Elements` section"));
                }
                let Some(nodes) = &nodes else {
                    return Err(c.error_at(at, "`$Elements` comes before `$Nodes`"));
                };
                let line = c.line_at(at);
                let collected = if format.v4 {
                    elements_v4(&mut c, format.binary, nodes)?
                } else {
                    elements_v2(&mut c, format.binary, nodes)?
                };
                tets = Some((line, collected));
            }
            _ => {
                skip_section(&mut c, at, name)?;
                continue;
            }
        }
        end_section(&mut c, name)?;
    }
    let end = c.line_at(bytes.len());
    let nodes = nodes.ok_or_else(|| text::empty_mesh(path, end, "no `$Nodes` section"))?;
    let (tets_line, tets) =
        tets.ok_or_else(|| text::empty_mesh(path, end, "no `$Elements` section"))?;
    if nodes.positions.is_empty() {
        return Err(text::empty_mesh(path, end, "the `$Nodes` section is empty"));
    }
    if tets.tets.is_empty() {
        return Err(text::empty_mesh(
            path,
            tets_line,
            "no linear tets (element type 4) in `$Elements`",
        ));
    }
    let positions = nodes.positions;
    let tets = tets.finish(path, positions.len())?;
    Ok(TetMesh { positions, tets })
}

/// Reads `version file-type data-size` (and the binary endianness word) up to
/// `$EndMeshFormat`.
fn mesh_format(c: &mut Cursor) -> Result<Format, MeshError> {
    let (at, line) = c.nonblank_line("`version file-type data-size`")?;
    let fields: Vec<&str> = line.split_ascii_whitespace().collect();
    let [version, file_type, data_size] = fields[..] else {
        return Err(c.error_at(
            at,
            format!(
                "expected `version file-type data-size` (e.g. `4.1 0 8`), found `{}`",
                clip(line)
            ),
        ));
    };
    let v4 = match version {
        "4.1" => true,
        "2.2" | "2.1" | "2" | "2.0" => false,
        other => {
            return Err(c.error_at(
                at,
                format!(
                    "Gmsh format version `{}` is not supported (2.2 and 4.1 are; in Gmsh, \
                     save with `Mesh.MshFileVersion = 4.1` or `2.2`)",
                    clip(other)
                ),
            ));
        }
    };
    if data_size != "8" {
        return Err(c.error_at(
            at,
            format!(
                "data size `{}` is not supported: coordinates must be 8-byte doubles",
                clip(data_size)
            ),
        ));
    }
    let binary = match file_type {
        "0" => None,
        "1" => {
            let word = c.take(4, "the binary endianness check")?;
            let endian = if Endian::Little.i32(word) == 1 {
                Endian::Little
            } else if Endian::Big.i32(word) == 1 {
                Endian::Big
            } else {
                let p = c.pos - 4;
                return Err(c.error_at(
                    p,
                    "the binary endianness check is not the integer 1: is the file truncated \
                     or converted as text?",
                ));
            };
            Some(endian)
        }
        other => {
            return Err(c.error_at(
                at,
                format!(
                    "file type `{}` is neither 0 (ASCII) nor 1 (binary)",
                    clip(other)
                ),
            ));
        }
    };
    end_section(c, "MeshFormat")?;
    Ok(Format { v4, binary })
}

/// Expects the `$End<name>` line of a section just read.
fn end_section(c: &mut Cursor, name: &str) -> Result<(), MeshError> {
    let what = format!("`$End{name}`");
    let (at, line) = c.nonblank_line(&what)?;
    if line.strip_prefix("$End") != Some(name) {
        return Err(c.error_at(
            at,
            format!(
                "expected {what}, found `{}`: does the section's count match its entries?",
                clip(line)
            ),
        ));
    }
    Ok(())
}

/// Skips a section this reader does not use, up to its `$End<name>` line.
fn skip_section(c: &mut Cursor, at: usize, name: &str) -> Result<(), MeshError> {
    let end = format!("$End{name}");
    let rest = &c.bytes[c.pos..];
    match rest.windows(end.len()).position(|w| w == end.as_bytes()) {
        Some(i) => {
            c.pos += i;
            let _ = c.line()?;
            Ok(())
        }
        None => Err(c.error_at(
            at,
            format!("section `${}` has no `{}` line", clip(name), clip(&end)),
        )),
    }
}

/// The nodes: positions in file order and the index of every tag.
struct Nodes {
    positions: Vec<Vector3<f64>>,
    index: HashMap<u64, usize>,
}

impl Nodes {
    fn with_capacity(n: usize) -> Self {
        Nodes {
            positions: Vec::with_capacity(n),
            index: HashMap::with_capacity(n),
        }
    }

    fn push(&mut self, c: &mut Cursor, at: usize, tag: u64, x: [f64; 3]) -> Result<(), MeshError> {
        for v in x {
            if let Some(m) = bad_coordinate(v) {
                return Err(c.error_at(at, format!("node {tag}: {m}")));
            }
        }
        if self.index.insert(tag, self.positions.len()).is_some() {
            return Err(c.error_at(at, format!("node tag {tag} appears twice")));
        }
        self.positions.push(x.into());
        Ok(())
    }

    fn resolve(&self, c: &mut Cursor, at: usize, tag: u64) -> Result<usize, MeshError> {
        self.index.get(&tag).copied().ok_or_else(|| {
            c.error_at(
                at,
                format!("element refers to node tag {tag}, which is not in `$Nodes`"),
            )
        })
    }
}

/// Checks an announced count against the mesh budget and the file's size; returns how many
/// entries to reserve.
fn announced(c: &mut Cursor, at: usize, n: u64, what: &str) -> Result<usize, MeshError> {
    let n = usize::try_from(n).unwrap_or(usize::MAX);
    let line = c.line_at(at);
    text::announced(c.path, line, n, what, c.bytes.len())
}

/// A count read as a text token.
fn count_token(c: &mut Cursor, what: &str) -> Result<(usize, u64), MeshError> {
    c.skip_whitespace();
    let at = c.pos;
    let n = c.parse::<u64>(what)?;
    Ok((at, n))
}

/// Reads an `size_t`-sized (8-byte) count of a binary v4 file, or a text count.
fn size_t(c: &mut Cursor, binary: Option<Endian>, what: &str) -> Result<(usize, u64), MeshError> {
    match binary {
        None => count_token(c, what),
        Some(e) => {
            let at = c.pos;
            Ok((at, e.u64(c.take(8, what)?)))
        }
    }
}

/// Reads an `int` (4-byte) field of a binary file, or a text integer.
fn int(c: &mut Cursor, binary: Option<Endian>, what: &str) -> Result<(usize, i32), MeshError> {
    match binary {
        None => {
            c.skip_whitespace();
            let at = c.pos;
            Ok((at, c.parse::<i32>(what)?))
        }
        Some(e) => {
            let at = c.pos;
            Ok((at, e.i32(c.take(4, what)?)))
        }
    }
}

fn double(c: &mut Cursor, binary: Option<Endian>, what: &str) -> Result<f64, MeshError> {
    match binary {
        None => c.parse::<f64>(what),
        Some(e) => Ok(e.f64(c.take(8, what)?)),
    }
}

/// Version 2: `n`, then `tag x y z` per node (binary: int tag, 3 doubles).
fn nodes_v2(c: &mut Cursor, binary: Option<Endian>) -> Result<Nodes, MeshError> {
    let (at, n) = count_token(c, "the number of nodes")?;
    let cap = announced(c, at, n, "nodes")?;
    if binary.is_some() {
        skip_newline(c);
        c.check_fits(n, 4 + 24, "nodes")?;
    }
    let mut nodes = Nodes::with_capacity(cap);
    for _ in 0..n {
        let (at, tag) = int(c, binary, "a node tag")?;
        let tag = positive_tag(c, at, i64::from(tag), "node")?;
        let mut x = [0.0; 3];
        for v in &mut x {
            *v = double(c, binary, "a coordinate")?;
        }
        nodes.push(c, at, tag, x)?;
    }
    Ok(nodes)
}

/// Version 4.1: `blocks nodes min max`, then per block `dim tag parametric n`, the `n` tags,
/// then the `n` coordinate rows (with `dim` parametric coordinates when `parametric` is 1).
fn nodes_v4(c: &mut Cursor, binary: Option<Endian>) -> Result<Nodes, MeshError> {
    let (_, blocks) = size_t(c, binary, "the number of node blocks")?;
    let (at, n) = size_t(c, binary, "the number of nodes")?;
    let cap = announced(c, at, n, "nodes")?;
    size_t(c, binary, "the smallest node tag")?;
    size_t(c, binary, "the largest node tag")?;
    let mut nodes = Nodes::with_capacity(cap);
    let mut tags = Vec::new();
    for _ in 0..blocks {
        let (at, dim) = int(c, binary, "a node block's entity dimension")?;
        int(c, binary, "a node block's entity tag")?;
        let (_, parametric) = int(c, binary, "a node block's parametric flag")?;
        let (count_at, count) = size_t(c, binary, "a node block's number of nodes")?;
        if !(0..=3).contains(&dim) || !(0..=1).contains(&parametric) {
            return Err(c.error_at(
                at,
                format!(
                    "node block with entity dimension {dim} and parametric flag {parametric}: \
                     expected 0..=3 and 0 or 1"
                ),
            ));
        }
        let extra = if parametric == 1 { dim as usize } else { 0 };
        if (nodes.positions.len() as u64).saturating_add(count) > n {
            return Err(c.error_at(
                count_at,
                format!("node blocks hold more than the {n} nodes announced"),
            ));
        }
        if binary.is_some() {
            c.check_fits(count, 8 + 8 * (3 + extra), "nodes")?;
        }
        tags.clear();
        for _ in 0..count {
            let (at, tag) = size_t(c, binary, "a node tag")?;
            tags.push((at, tag));
        }
        for &(at, tag) in &tags {
            let tag = positive_tag(c, at, tag as i64, "node")?;
            let mut x = [0.0; 3];
            for v in &mut x {
                *v = double(c, binary, "a coordinate")?;
            }
            for _ in 0..extra {
                double(c, binary, "a parametric coordinate")?;
            }
            nodes.push(c, at, tag, x)?;
        }
    }
    if nodes.positions.len() as u64 != n {
        let at = c.pos;
        return Err(c.error_at(
            at,
            format!(
                "the node blocks hold {} nodes, but {n} were announced",
                nodes.positions.len()
            ),
        ));
    }
    Ok(nodes)
}

/// A node or element tag, which Gmsh requires to be positive.
fn positive_tag(c: &mut Cursor, at: usize, tag: i64, what: &str) -> Result<u64, MeshError> {
    u64::try_from(tag)
        .ok()
        .filter(|&t| t > 0)
        .ok_or_else(|| c.error_at(at, format!("{what} tag {tag} is not positive")))
}

/// A version 2 element's `i`-th tag: the physical group, the elementary entity and the number
/// of partitions cannot be negative (partition ids after them can: a ghost cell's are).
fn element_tag(c: &mut Cursor, at: usize, i: i32, tag: i32) -> Result<(), MeshError> {
    const NAMES: [&str; 3] = [
        "physical tag",
        "elementary entity tag",
        "number of partitions",
    ];
    match NAMES.get(i as usize) {
        Some(name) if tag < 0 => Err(c.error_at(
            at,
            format!("element {name} {tag} is negative; Gmsh writes it as 0 or more"),
        )),
        _ => Ok(()),
    }
}

/// After a text count in a binary v2 section, the binary data starts past the newline.
fn skip_newline(c: &mut Cursor) {
    while c.pos < c.bytes.len() && c.bytes[c.pos] != b'\n' {
        c.pos += 1;
    }
    c.pos = (c.pos + 1).min(c.bytes.len());
}

/// Adds an element to the tets if it is a linear tet; refuses second-order tets.
fn element(
    c: &mut Cursor,
    nodes: &Nodes,
    tets: &mut TetCollector,
    at: usize,
    kind: i32,
    tags: &[u64],
) -> Result<(), MeshError> {
    if kind != TET4 {
        return Ok(());
    }
    let mut tet = [0; 4];
    for (slot, &tag) in tet.iter_mut().zip(tags) {
        *slot = nodes.resolve(c, at, tag)?;
    }
    let line = c.line_at(at);
    tets.push(c.path, line, tet)
}

/// Version 2: `n`, then `tag type ntags tags... nodes...` per element; binary: blocks of
/// `type count ntags` headers, each followed by `count` elements of `1 + ntags + nodes` ints.
fn elements_v2(
    c: &mut Cursor,
    binary: Option<Endian>,
    nodes: &Nodes,
) -> Result<TetCollector, MeshError> {
    let (at, n) = count_token(c, "the number of elements")?;
    let cap = announced(c, at, n, "elements")?;
    let mut tets = TetCollector::new(1, cap);
    let mut tags = Vec::new();
    match binary {
        None => {
            for _ in 0..n {
                let (at, number) = int(c, None, "an element tag")?;
                positive_tag(c, at, i64::from(number), "element")?;
                let (kind_at, kind) = int(c, None, "an element type")?;
                let (ntags_at, ntags) = int(c, None, "the number of element tags")?;
                if ntags < 0 {
                    return Err(c.error_at(
                        ntags_at,
                        format!("the number of element tags is {ntags}; it cannot be negative"),
                    ));
                }
                let width = node_count(c, kind_at, kind)?;
                for i in 0..ntags {
                    let (a, t) = int(c, None, "an element tag value")?;
                    element_tag(c, a, i, t)?;
                }
                tags.clear();
                for _ in 0..width {
                    let (a, t) = int(c, None, "an element node")?;
                    tags.push(positive_tag(c, a, i64::from(t), "node")?);
                }
                element(c, nodes, &mut tets, at, kind, &tags)?;
            }
        }
        Some(_) => {
            skip_newline(c);
            let mut read = 0u64;
            while read < n {
                let (kind_at, kind) = int(c, binary, "an element block's type")?;
                let (count_at, count) = int(c, binary, "an element block's count")?;
                let (_, ntags) = int(c, binary, "an element block's number of tags")?;
                let width = node_count(c, kind_at, kind)?;
                if count < 0 || ntags < 0 || read + count as u64 > n {
                    return Err(c.error_at(
                        count_at,
                        format!(
                            "element block of {count} elements with {ntags} tags: more than the \
                             {n} announced, or negative"
                        ),
                    ));
                }
                let ints = 1 + ntags as usize + width;
                c.check_fits(count as u64, 4 * ints, "elements")?;
                for _ in 0..count {
                    let at = c.pos;
                    let (_, number) = int(c, binary, "an element tag")?;
                    positive_tag(c, at, i64::from(number), "element")?;
                    for i in 0..ntags {
                        let (a, t) = int(c, binary, "an element tag value")?;
                        element_tag(c, a, i, t)?;
                    }
                    tags.clear();
                    for _ in 0..width {
                        let (a, t) = int(c, binary, "an element node")?;
                        tags.push(positive_tag(c, a, i64::from(t), "node")?);
                    }
                    element(c, nodes, &mut tets, at, kind, &tags)?;
                }
                read += count as u64;
            }
        }
    }
    Ok(tets)
}

/// Version 4.1: `blocks elements min max`, then per block `dim tag type n` and `n` rows of
/// `tag node...`.
fn elements_v4(
    c: &mut Cursor,
    binary: Option<Endian>,
    nodes: &Nodes,
) -> Result<TetCollector, MeshError> {
    let (_, blocks) = size_t(c, binary, "the number of element blocks")?;
    let (at, n) = size_t(c, binary, "the number of elements")?;
    let cap = announced(c, at, n, "elements")?;
    size_t(c, binary, "the smallest element tag")?;
    size_t(c, binary, "the largest element tag")?;
    let mut tets = TetCollector::new(1, cap);
    let mut tags = Vec::new();
    let mut read = 0u64;
    for _ in 0..blocks {
        int(c, binary, "an element block's entity dimension")?;
        int(c, binary, "an element block's entity tag")?;
        let (kind_at, kind) = int(c, binary, "an element block's element type")?;
        let (count_at, count) = size_t(c, binary, "an element block's number of elements")?;
        let width = node_count(c, kind_at, kind)?;
        if read.saturating_add(count) > n {
            return Err(c.error_at(
                count_at,
                format!("element blocks hold more than the {n} elements announced"),
            ));
        }
        if binary.is_some() {
            c.check_fits(count, 8 * (1 + width), "elements")?;
        }
        for _ in 0..count {
            let (at, tag) = size_t(c, binary, "an element tag")?;
            positive_tag(c, at, tag as i64, "element")?;
            tags.clear();
            for _ in 0..width {
                let (a, t) = size_t(c, binary, "an element node")?;
                tags.push(positive_tag(c, a, t as i64, "node")?);
            }
            element(c, nodes, &mut tets, at, kind, &tags)?;
        }
        read += count;
    }
    if read != n {
        let at = c.pos;
        return Err(c.error_at(
            at,
            format!("the element blocks hold {read} elements, but {n} were announced"),
        ));
    }
    Ok(tets)
}

/// Nodes per element of a Gmsh element type (types 1 to 31: lines to fourth-order
/// elements); unknown types are an error, since their width is needed to read past them, and
/// so are second-order tets, which this reader does not cut to their corners.
fn node_count(c: &mut Cursor, at: usize, kind: i32) -> Result<usize, MeshError> {
    if kind == TET10 {
        return Err(c.error_at(
            at,
            "second-order (10-node) tets are not supported; export linear tets \
             (Gmsh: `Mesh.ElementOrder = 1`)",
        ));
    }
    const NODES: [usize; 31] = [
        2, 3, 4, 4, 8, 6, 5, 3, 6, 9, 10, 27, 18, 14, 1, 8, 20, 15, 13, 9, 10, 12, 15, 15, 21, 4,
        5, 6, 20, 35, 56,
    ];
    usize::try_from(kind)
        .ok()
        .and_then(|k| k.checked_sub(1))
        .and_then(|k| NODES.get(k).copied())
        .ok_or_else(|| {
            c.error_at(
                at,
                format!("unknown Gmsh element type {kind} (known: 1 to 31; 4 is the linear tet)"),
            )
        })
}
