//! A cursor over a file's bytes for formats that mix text and binary data (Gmsh `.msh`, VTK
//! XML): text lines and tokens, fixed-size binary values, and 1-based line numbers for
//! errors. In a binary block the line is the one an editor would show (newline bytes counted
//! up to the offset), and messages there also give the byte offset.

use std::path::Path;

use super::MeshError;
use super::text::parse_error;

/// A forward cursor over `bytes` that counts lines incrementally, so naming the line of
/// every record costs O(file size) in total.
pub(crate) struct Cursor<'a> {
    pub(crate) bytes: &'a [u8],
    pub(crate) pos: usize,
    pub(crate) path: &'a Path,
    /// `(offset, line at offset)` of the last line computed.
    counted: (usize, usize),
}

impl<'a> Cursor<'a> {
    pub(crate) fn new(bytes: &'a [u8], path: &'a Path) -> Self {
        Cursor {
            bytes,
            pos: 0,
            path,
            counted: (0, 1),
        }
    }

    /// The 1-based line holding byte `offset`.
    pub(crate) fn line_at(&mut self, offset: usize) -> usize {
        let offset = offset.min(self.bytes.len());
        let (from, line) = if offset >= self.counted.0 {
            self.counted
        } else {
            (0, 1)
        };
        let line = line
            + self.bytes[from..offset]
                .iter()
                .filter(|&&b| b == b'\n')
                .count();
        self.counted = (offset, line);
        // The end of a file that ends with a newline is on its last line, not after it.
        if offset == self.bytes.len() && self.bytes.last() == Some(&b'\n') {
            line - 1
        } else {
            line
        }
    }

    /// A parse error at the line holding byte `offset`.
    pub(crate) fn error_at(&mut self, offset: usize, message: impl Into<String>) -> MeshError {
        let line = self.line_at(offset);
        parse_error(self.path, line, message)
    }

    /// Whether the cursor is at the end of the file.
    pub(crate) fn at_end(&self) -> bool {
        self.pos >= self.bytes.len()
    }

    /// The next line (without `\r\n`), trimmed, with its start offset; `None` at end of
    /// file. Not UTF-8 is an error.
    pub(crate) fn line(&mut self) -> Result<Option<(usize, &'a str)>, MeshError> {
        if self.at_end() {
            return Ok(None);
        }
        let start = self.pos;
        let rest = &self.bytes[start..];
        let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
        self.pos = start + end + usize::from(end < rest.len());
        match std::str::from_utf8(&rest[..end]) {
            Ok(s) => Ok(Some((start, s.trim()))),
            Err(_) => Err(self.error_at(start, "expected a text line, found binary data")),
        }
    }

    /// The next non-blank line, or an error saying the file ends where `what` was expected.
    pub(crate) fn nonblank_line(&mut self, what: &str) -> Result<(usize, &'a str), MeshError> {
        loop {
            match self.line()? {
                Some((_, "")) => continue,
                Some(found) => return Ok(found),
                None => {
                    let end = self.bytes.len();
                    return Err(self.error_at(end, format!("file ends where {what} was expected")));
                }
            }
        }
    }

    /// Moves past whitespace (so `pos` is where the next token starts).
    pub(crate) fn skip_whitespace(&mut self) {
        while self.pos < self.bytes.len() && self.bytes[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
    }

    /// The next whitespace-separated ASCII token (crossing lines) with its offset.
    pub(crate) fn token(&mut self, what: &str) -> Result<(usize, &'a str), MeshError> {
        let b = self.bytes;
        self.skip_whitespace();
        let start = self.pos;
        while self.pos < b.len() && !b[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        if start == self.pos {
            return Err(self.error_at(start, format!("file ends where {what} was expected")));
        }
        match std::str::from_utf8(&b[start..self.pos]) {
            Ok(s) => Ok((start, s)),
            Err(_) => Err(self.error_at(start, format!("expected {what}, found binary data"))),
        }
    }

    /// The next token parsed as `T` (an integer or a number).
    pub(crate) fn parse<T: std::str::FromStr>(&mut self, what: &str) -> Result<T, MeshError> {
        let (at, t) = self.token(what)?;
        t.parse()
            .map_err(|_| self.error_at(at, format!("expected {what}, found `{}`", clip(t))))
    }

    /// The next `n` bytes, or an error saying how many the file still has.
    pub(crate) fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], MeshError> {
        let left = self.bytes.len() - self.pos.min(self.bytes.len());
        if n > left {
            let at = self.pos;
            return Err(self.error_at(
                at,
                format!(
                    "file ends inside {what} (byte offset {at}): {n} bytes needed, {left} left"
                ),
            ));
        }
        let s = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    /// Checks that `count` records of `size` bytes fit in the rest of the file, before
    /// anything is reserved for them.
    pub(crate) fn check_fits(
        &mut self,
        count: u64,
        size: usize,
        what: &str,
    ) -> Result<(), MeshError> {
        let left = (self.bytes.len() - self.pos.min(self.bytes.len())) as u64;
        if count
            .checked_mul(size as u64)
            .is_none_or(|need| need > left)
        {
            let at = self.pos;
            return Err(self.error_at(
                at,
                format!("{count} {what} of {size} bytes announced, but only {left} bytes are left"),
            ));
        }
        Ok(())
    }
}

/// A token clipped for quoting in a message.
pub(crate) fn clip(t: &str) -> String {
    crate::quote::clip_message(t)
}

/// Byte order of a binary block.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Endian {
    Little,
    Big,
}

impl Endian {
    pub(crate) fn i32(self, b: &[u8]) -> i32 {
        let a: [u8; 4] = b[..4].try_into().expect("4 bytes");
        match self {
            Endian::Little => i32::from_le_bytes(a),
            Endian::Big => i32::from_be_bytes(a),
        }
    }

    pub(crate) fn u64(self, b: &[u8]) -> u64 {
        let a: [u8; 8] = b[..8].try_into().expect("8 bytes");
        match self {
            Endian::Little => u64::from_le_bytes(a),
            Endian::Big => u64::from_be_bytes(a),
        }
    }

    pub(crate) fn f64(self, b: &[u8]) -> f64 {
        f64::from_bits(self.u64(b))
    }
}

/// Checks a coordinate read from binary data (finite, at most
/// [`MAX_COORDINATE`](super::text::MAX_COORDINATE)); `None` when it is fine.
pub(crate) fn bad_coordinate(x: f64) -> Option<String> {
    if !x.is_finite() {
        Some(format!("coordinate {x} is not a finite number"))
    } else if x.abs() > super::text::MAX_COORDINATE {
        Some(format!(
            "coordinate {x:e} is beyond ±{:e}: volumes and energies would overflow",
            super::text::MAX_COORDINATE
        ))
    } else {
        None
    }
}
