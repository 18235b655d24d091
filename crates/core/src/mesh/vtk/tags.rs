//! Just enough XML for VTK files: tags with their attributes, one after another (comments,
//! declarations and text skipped), and the content of a `DataArray` — the character data
//! before its first child element, with the children (VTK 9 writes `<InformationKey>`
//! metadata after an array's values) read past up to the matching `</DataArray>`.
//!
//! It never scans appended data: `xml.rs` stops at `<AppendedData>`, whose raw bytes may hold
//! anything.

use super::super::MeshError;
use super::super::bytes::{Cursor, clip};

/// One XML tag: its name, attributes, offset, and whether it closes (`</x>`) or is empty
/// (`<x/>`).
pub(super) struct Tag<'a> {
    pub(super) at: usize,
    pub(super) name: &'a str,
    pub(super) attributes: Vec<(&'a str, &'a str)>,
    pub(super) closing: bool,
    pub(super) empty: bool,
}

impl<'a> Tag<'a> {
    /// The value of attribute `key`, without surrounding whitespace.
    pub(super) fn get(&self, key: &str) -> Option<&'a str> {
        self.attributes
            .iter()
            .find(|(k, _)| *k == key)
            .map(|&(_, v)| v.trim())
    }
}

/// The next tag at or after the cursor, skipping comments, declarations and text.
pub(super) fn next_tag<'a>(c: &mut Cursor<'a>) -> Result<Option<Tag<'a>>, MeshError> {
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

/// The character data of the `DataArray` whose opening `tag` the cursor has just passed, with
/// its offset: the text before its first child element (empty for `<DataArray .../>`). Moves
/// past the matching `</DataArray>`, reading child elements past whatever their depth. Text
/// after a child element is not part of the values (VTK reads them from the first character
/// data on).
pub(super) fn array_content<'a>(
    c: &mut Cursor<'a>,
    tag: &Tag,
) -> Result<(usize, &'a [u8]), MeshError> {
    let start = c.pos;
    if tag.empty {
        return Ok((start, &[]));
    }
    let rest = &c.bytes[start..];
    let len = rest.iter().position(|&b| b == b'<').unwrap_or(rest.len());
    c.pos = start + len;
    let mut open: Vec<&str> = Vec::new();
    loop {
        let Some(child) = next_tag(c)? else {
            return Err(c.error_at(tag.at, "`DataArray` has no `</DataArray>`"));
        };
        if !child.closing {
            if !child.empty {
                open.push(child.name);
            }
            continue;
        }
        match open.pop() {
            Some(name) if name == child.name => {}
            None if child.name == "DataArray" => break,
            expected => {
                return Err(c.error_at(
                    child.at,
                    format!(
                        "`</{}>` inside a `DataArray` where `</{}>` was expected",
                        clip(child.name),
                        expected.unwrap_or("DataArray")
                    ),
                ));
            }
        }
    }
    Ok((start, &rest[..len]))
}
