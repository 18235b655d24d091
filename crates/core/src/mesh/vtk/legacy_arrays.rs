//! The data of a legacy VTK file, ASCII or BINARY: keywords and counts are text either way;
//! an array's values are text tokens, or, in a BINARY file, big-endian bytes starting on the
//! line after the array's header line (VTK's `vtkDataReader::ReadArray`). Also what is read
//! past: `METADATA` blocks (an array's component names and `INFORMATION` keys, ended by a
//! blank line) and `FIELD` data (named arrays of any type, strings included).
//!
//! Counts are checked before anything is reserved: against the mesh budget, and for binary
//! data against the bytes left in the file.

use super::super::MeshError;
use super::super::bytes::{Cursor, clip};
use super::super::text;

/// The value types of legacy VTK, by their names in array headers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Scalar {
    Bit,
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
    /// `string` and `utf8_string`: only read past (in `FIELD` data).
    Str,
}

/// The type names [`Scalar::parse`] knows, for messages.
const KNOWN_TYPES: &str = "bit, char, signed_char, unsigned_char, short, unsigned_short, int, \
     unsigned_int, long, unsigned_long, vtktypeint64, vtktypeuint64, vtkIdType, float, double, \
     string, utf8_string";

impl Scalar {
    /// The type a header names (any case), `None` for an unknown one.
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name.to_ascii_lowercase().as_str() {
            "bit" => Scalar::Bit,
            "char" | "signed_char" => Scalar::I8,
            "unsigned_char" => Scalar::U8,
            "short" => Scalar::I16,
            "unsigned_short" => Scalar::U16,
            // VTK writes `vtkIdType` arrays as 32-bit ints.
            "int" | "vtkidtype" => Scalar::I32,
            "unsigned_int" => Scalar::U32,
            // VTK no longer writes `long`; its readers take it as 8 bytes where long is (Linux,
            // macOS).
            "long" | "vtktypeint64" => Scalar::I64,
            "unsigned_long" | "vtktypeuint64" => Scalar::U64,
            "float" => Scalar::F32,
            "double" => Scalar::F64,
            "string" | "utf8_string" => Scalar::Str,
            _ => return None,
        })
    }

    /// Bytes per binary value (bits and strings are not of fixed width).
    fn width(self) -> usize {
        match self {
            Scalar::Bit | Scalar::Str | Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::I64 | Scalar::U64 | Scalar::F64 => 8,
        }
    }

    /// One big-endian value as f64 (exact for every float and for integers up to 2^53).
    fn value(self, b: &[u8]) -> f64 {
        let mut a = [0u8; 8];
        a[8 - b.len()..].copy_from_slice(b);
        let u = u64::from_be_bytes(a);
        match self {
            Scalar::I8 => f64::from(u as u8 as i8),
            Scalar::I16 => f64::from(u as u16 as i16),
            Scalar::I32 => f64::from(u as u32 as i32),
            Scalar::I64 => u as i64 as f64,
            Scalar::F32 => f64::from(f32::from_bits(u as u32)),
            Scalar::F64 => f64::from_bits(u),
            _ => u as f64,
        }
    }
}

/// A forward reader over a legacy file's bytes after its header lines.
pub(super) struct Reader<'a> {
    pub(super) c: Cursor<'a>,
    /// Whether arrays are big-endian bytes (`BINARY`) rather than text.
    pub(super) binary: bool,
}

impl<'a> Reader<'a> {
    /// The next whitespace-separated word with its offset, `None` at the end of the file.
    pub(super) fn next_word(&mut self) -> Result<Option<(usize, &'a str)>, MeshError> {
        self.c.skip_whitespace();
        if self.c.at_end() {
            return Ok(None);
        }
        self.c.token("a keyword").map(Some)
    }

    /// The next word, or an error saying the file ends where `what` was expected.
    pub(super) fn word(&mut self, what: &str) -> Result<(usize, &'a str), MeshError> {
        self.c.token(what)
    }

    /// Expects the keyword `word` (any case).
    pub(super) fn keyword(&mut self, word: &str) -> Result<(), MeshError> {
        let (at, found) = self.word(word)?;
        if found.eq_ignore_ascii_case(word) {
            Ok(())
        } else {
            Err(self
                .c
                .error_at(at, format!("expected `{word}`, found `{}`", clip(found))))
        }
    }

    /// A count, checked against the mesh budget.
    pub(super) fn count(&mut self, what: &str) -> Result<usize, MeshError> {
        let (at, token) = self.word(what)?;
        let line = self.c.line_at(at);
        let path = self.c.path;
        let n = text::count(path, line, token, what)?;
        text::announced(path, line, n, what, self.c.bytes.len())?;
        Ok(n)
    }

    /// An array's type word (`float`, `vtktypeint64`, ...).
    pub(super) fn scalar(&mut self, what: &str) -> Result<Scalar, MeshError> {
        let (at, name) = self.word(what)?;
        Scalar::parse(name).ok_or_else(|| {
            self.c.error_at(
                at,
                format!(
                    "`{}` is not a legacy VTK data type (known: {KNOWN_TYPES})",
                    clip(name)
                ),
            )
        })
    }

    /// Moves past the rest of the current line, which must be blank: binary values start on
    /// the next line.
    fn end_of_line(&mut self, what: &str) -> Result<(), MeshError> {
        let rest = &self.c.bytes[self.c.pos..];
        let len = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
        if let Some(i) = rest[..len].iter().position(|b| !b.is_ascii_whitespace()) {
            let at = self.c.pos + i;
            return Err(self.c.error_at(
                at,
                format!(
                    "unexpected text before the binary data of {what}: it starts on the next line"
                ),
            ));
        }
        self.c.pos += (len + 1).min(rest.len());
        Ok(())
    }

    /// `n` values of type `ty` as f64 with the line of the first: the values of `section`
    /// (`POINTS`), each `what` (`a coordinate`). Bit and string arrays cannot hold
    /// coordinates or indices and are refused.
    pub(super) fn values(
        &mut self,
        ty: Scalar,
        n: usize,
        section: &str,
        what: &str,
    ) -> Result<(usize, Vec<f64>), MeshError> {
        if matches!(ty, Scalar::Bit | Scalar::Str) {
            let at = self.c.pos;
            return Err(self.c.error_at(
                at,
                format!("{section} cannot be a bit or string array: it holds numbers"),
            ));
        }
        if !self.binary {
            let mut values = Vec::with_capacity(n.min(self.c.bytes.len() / 2 + 1));
            let mut first = self.c.pos;
            for i in 0..n {
                let (at, token) = self.word(what)?;
                if i == 0 {
                    first = at;
                }
                let x = token.parse::<f64>().map_err(|_| {
                    self.c
                        .error_at(at, format!("expected {what}, found `{}`", clip(token)))
                })?;
                values.push(x);
            }
            return Ok((self.c.line_at(first), values));
        }
        if n == 0 {
            return Ok((self.c.line_at(self.c.pos), Vec::new()));
        }
        self.end_of_line(section)?;
        let w = ty.width();
        let at = self.c.pos;
        let left = self.c.bytes.len() - at;
        if n.checked_mul(w).is_none_or(|need| need > left) {
            return Err(self.c.error_at(
                at,
                format!(
                    "{section} announces {n} values of {w} bytes, but only {left} bytes are left"
                ),
            ));
        }
        let bytes = self.c.take(n * w, section)?;
        let values = bytes.chunks_exact(w).map(|b| ty.value(b)).collect();
        Ok((self.c.line_at(at), values))
    }

    /// Reads past `n` values of type `ty`.
    fn skip_values(&mut self, ty: Scalar, n: u64, what: &str) -> Result<(), MeshError> {
        if n == 0 {
            return Ok(());
        }
        if !self.binary {
            if ty == Scalar::Str {
                // The rest of the header line, then one string per line.
                self.end_of_text_line();
                for _ in 0..n {
                    if self.c.at_end() {
                        let end = self.c.bytes.len();
                        return Err(self.c.error_at(end, format!("file ends inside {what}")));
                    }
                    self.end_of_text_line();
                }
            } else {
                for _ in 0..n {
                    self.word(what)?;
                }
            }
            return Ok(());
        }
        self.end_of_line(what)?;
        match ty {
            Scalar::Bit => {
                self.c.take(n.div_ceil(8) as usize, what)?;
            }
            // Each string is a length (its first byte's top two bits say the length's size)
            // then its bytes.
            Scalar::Str => {
                for _ in 0..n {
                    let first = self.c.take(1, what)?[0];
                    let len = match first >> 6 {
                        3 => u64::from(first & 0x3f),
                        2 => {
                            let b = self.c.take(1, what)?;
                            u64::from(u16::from_be_bytes([first, b[0]]) & 0x3fff)
                        }
                        1 => {
                            let b = self.c.take(3, what)?;
                            u64::from(u32::from_be_bytes([first, b[0], b[1], b[2]]) & 0x3fff_ffff)
                        }
                        _ => {
                            let b = self.c.take(7, what)?;
                            let mut a = [first; 8];
                            a[1..].copy_from_slice(b);
                            u64::from_be_bytes(a)
                        }
                    };
                    self.c.check_fits(len, 1, what)?;
                    self.c.take(len as usize, what)?;
                }
            }
            _ => {
                self.c.check_fits(n, ty.width(), what)?;
                self.c.take(n as usize * ty.width(), what)?;
            }
        }
        Ok(())
    }

    /// Moves past the rest of the current line, whatever it holds.
    fn end_of_text_line(&mut self) {
        let rest = &self.c.bytes[self.c.pos..];
        let len = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
        self.c.pos += (len + 1).min(rest.len());
    }

    /// Reads past a `METADATA` block if one comes next (VTK writes one after an array with
    /// component names or information keys): the keyword's line, then lines up to a blank
    /// one.
    pub(super) fn skip_metadata(&mut self) -> Result<(), MeshError> {
        let save = self.c.pos;
        match self.next_word()? {
            Some((_, word)) if word.eq_ignore_ascii_case("METADATA") => {
                self.skip_metadata_block();
                Ok(())
            }
            _ => {
                self.c.pos = save;
                Ok(())
            }
        }
    }

    /// Reads past a `METADATA` block whose keyword has just been read.
    pub(super) fn skip_metadata_block(&mut self) {
        self.end_of_text_line();
        while !self.c.at_end() {
            let rest = &self.c.bytes[self.c.pos..];
            let len = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
            let blank = rest[..len].iter().all(u8::is_ascii_whitespace);
            self.c.pos += (len + 1).min(rest.len());
            if blank {
                break;
            }
        }
    }

    /// Reads past `FIELD name n` data whose keyword has just been read: `n` arrays, each
    /// `name components tuples type` then its values and perhaps a `METADATA` block
    /// (`NULL_ARRAY` stands for an array with nothing after it).
    pub(super) fn skip_field(&mut self) -> Result<(), MeshError> {
        self.word("the field's name")?;
        let arrays = self.count("the number of field arrays")?;
        for _ in 0..arrays {
            let (_, name) = self.word("a field array's name")?;
            if name == "NULL_ARRAY" {
                continue;
            }
            let what = format!("field array `{}`", clip(name));
            let components = self.count("the number of components")?;
            let tuples = self.count("the number of tuples")?;
            let (at, type_name) = self.word("the field array's type")?;
            let Some(ty) = Scalar::parse(type_name) else {
                return Err(self.c.error_at(
                    at,
                    format!(
                        "{what}: type `{}` cannot be read past (known: {KNOWN_TYPES})",
                        clip(type_name)
                    ),
                ));
            };
            let n = (components as u64).saturating_mul(tuples as u64);
            self.skip_values(ty, n, &what)?;
            self.skip_metadata()?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::Scalar;

    #[test]
    fn every_legacy_type_name_reads_its_big_endian_values() {
        for (name, bytes, value) in [
            ("char", vec![0xfe], -2.0),
            ("signed_char", vec![0x7f], 127.0),
            ("unsigned_char", vec![0xfe], 254.0),
            ("short", vec![0xff, 0xfe], -2.0),
            ("unsigned_short", vec![0x01, 0x02], 258.0),
            ("int", vec![0xff, 0xff, 0xff, 0xfe], -2.0),
            ("vtkIdType", vec![0, 0, 1, 0], 256.0),
            ("unsigned_int", vec![0xff, 0xff, 0xff, 0xfe], 4294967294.0),
            ("long", (-3i64).to_be_bytes().to_vec(), -3.0),
            ("vtktypeint64", (-3i64).to_be_bytes().to_vec(), -3.0),
            ("unsigned_long", 5u64.to_be_bytes().to_vec(), 5.0),
            ("vtktypeuint64", 5u64.to_be_bytes().to_vec(), 5.0),
            ("float", 0.1f32.to_be_bytes().to_vec(), f64::from(0.1f32)),
            ("DOUBLE", 0.1f64.to_be_bytes().to_vec(), 0.1),
        ] {
            let ty = Scalar::parse(name).unwrap();
            assert_eq!(ty.width(), bytes.len(), "{name}");
            assert_eq!(ty.value(&bytes), value, "{name}");
        }
        assert_eq!(Scalar::parse("bit"), Some(Scalar::Bit));
        assert_eq!(Scalar::parse("utf8_string"), Some(Scalar::Str));
        assert_eq!(Scalar::parse("variant"), None);
    }
}
