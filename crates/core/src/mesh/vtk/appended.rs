//! The `<AppendedData>` section of a VTK XML file, where `format="appended"` arrays keep their
//! bytes (VTK's and ParaView's default): after the tag, whitespace, then `_`, then the arrays
//! one after another, each found by its `offset` attribute — a byte offset into the raw data
//! (`encoding="raw"`) or a character offset into the base64 text (`encoding="base64"`, each
//! array encoded on its own). An array's header says how far it reaches; raw data may hold any
//! byte, so nothing after the `_` is scanned as XML.

use super::super::MeshError;
use super::super::bytes::{Cursor, clip};
use super::base64::Base64Stream;
use super::binary::{self, Bytes, Encoding};
use super::tags::Tag;

/// The appended data of a file.
pub(super) struct Appended<'a> {
    /// Raw bytes (`true`) or base64 text.
    raw: bool,
    /// From just after the `_`: to the end of the file for raw data, to the next `<` for
    /// base64.
    data: &'a [u8],
}

impl<'a> Appended<'a> {
    /// The section whose opening `tag` the cursor has just passed.
    pub(super) fn open(c: &mut Cursor<'a>, tag: &Tag) -> Result<Self, MeshError> {
        let raw = match tag.get("encoding") {
            Some("raw") => true,
            Some("base64") => false,
            other => {
                return Err(c.error_at(
                    tag.at,
                    format!(
                        "`AppendedData` encoding `{}` is not supported (raw and base64 are)",
                        clip(other.unwrap_or("(none)"))
                    ),
                ));
            }
        };
        c.skip_whitespace();
        if c.bytes.get(c.pos) != Some(&b'_') {
            let at = c.pos;
            return Err(c.error_at(
                at,
                "`AppendedData` must start with `_` (its arrays' offsets count from just \
                 after it)",
            ));
        }
        let rest = &c.bytes[c.pos + 1..];
        let data = if raw {
            rest
        } else {
            &rest[..rest.iter().position(|&b| b == b'<').unwrap_or(rest.len())]
        };
        Ok(Appended { raw, data })
    }

    /// The data bytes of the array at `offset` (see [`binary::unpack`]).
    pub(super) fn array(
        &self,
        offset: u64,
        enc: Encoding,
        max_bytes: u64,
    ) -> Result<Vec<u8>, String> {
        let (unit, len) = if self.raw {
            ("bytes", self.data.len())
        } else {
            ("base64 characters", self.data.len())
        };
        let Some(from) = usize::try_from(offset)
            .ok()
            .and_then(|o| self.data.get(o..))
        else {
            return Err(format!(
                "offset {offset} is beyond the appended data's {len} {unit}"
            ));
        };
        if self.raw {
            binary::unpack(&mut Bytes(from), enc, max_bytes)
        } else {
            binary::unpack(&mut Base64Stream::new(from), enc, max_bytes)
        }
    }
}
