//! Base64 as VTK XML writes it: standard alphabet, `=` padding, whitespace ignored, and one
//! padded run followed by another (VTK encodes a compressed array's block table and its blocks
//! apart). [`decode`] decodes a whole inline array; [`Base64Stream`] decodes an appended array
//! only as far as its header says it reaches, since appended arrays follow one another with
//! nothing between them.

/// The value of one base64 character: `Some(0..64)`, `Some(PAD)` for `=`, `None` for
/// whitespace; `Err` for anything else.
fn value(ch: u8) -> Result<Option<u8>, ()> {
    Ok(Some(match ch {
        b'A'..=b'Z' => ch - b'A',
        b'a'..=b'z' => ch - b'a' + 26,
        b'0'..=b'9' => ch - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        b'=' => PAD,
        c if c.is_ascii_whitespace() => return Ok(None),
        _ => return Err(()),
    }))
}

/// Marks `=` among character values.
const PAD: u8 = 64;

/// A group of four characters being gathered.
#[derive(Default)]
struct Group {
    values: [u8; 4],
    n: usize,
    pad: usize,
}

impl Group {
    /// Adds one character value; returns the group's bytes when it is complete, or `Err` when
    /// the character cannot stand there (padding too early, data after padding).
    fn push(&mut self, v: u8, out: &mut Vec<u8>) -> Result<(), ()> {
        if v == PAD {
            if self.n < 2 {
                return Err(());
            }
            self.pad += 1;
        } else if self.pad > 0 {
            return Err(());
        }
        self.values[self.n] = if v == PAD { 0 } else { v };
        self.n += 1;
        if self.n == 4 {
            let [a, b, c, d] = self.values.map(u32::from);
            let x = a << 18 | b << 12 | c << 6 | d;
            let bytes = [(x >> 16) as u8, (x >> 8) as u8, x as u8];
            out.extend_from_slice(&bytes[..3 - self.pad]);
            *self = Group::default();
        }
        Ok(())
    }
}

/// Decodes all of `text`. On error, the offset of the bad character (or of the end, when the
/// last group is incomplete).
pub(super) fn decode(text: &[u8]) -> Result<Vec<u8>, usize> {
    let mut out = Vec::with_capacity(text.len() / 4 * 3);
    let mut group = Group::default();
    for (i, &ch) in text.iter().enumerate() {
        match value(ch) {
            Ok(Some(v)) => group.push(v, &mut out).map_err(|()| i)?,
            Ok(None) => {}
            Err(()) => return Err(i),
        }
    }
    if group.n != 0 {
        return Err(text.len());
    }
    Ok(out)
}

/// Decodes a base64 text from its start on demand: [`Base64Stream::prefix`] decodes no more
/// groups than the bytes asked for need, so an array is decoded without the arrays after it.
pub(super) struct Base64Stream<'a> {
    text: &'a [u8],
    /// Characters consumed.
    pos: usize,
    out: Vec<u8>,
}

impl<'a> Base64Stream<'a> {
    pub(super) fn new(text: &'a [u8]) -> Self {
        Base64Stream {
            text,
            pos: 0,
            out: Vec::new(),
        }
    }

    /// The first `n` decoded bytes. Memory grows with the text actually decoded, never with
    /// `n` itself; the error says how many bytes the text holds when it is shorter, or where
    /// a character is not base64 (`what` names the part of the array being read).
    pub(super) fn prefix(&mut self, n: u64, what: &str) -> Result<&[u8], String> {
        let mut group = Group::default();
        while (self.out.len() as u64) < n {
            let Some(&ch) = self.text.get(self.pos) else {
                return Err(format!(
                    "the base64 data ends inside {what}: the array needs {n} bytes from its \
                     start, {} are there",
                    self.out.len()
                ));
            };
            let pos = self.pos;
            let bad = || format!("character {pos} of the base64 data is not base64");
            match value(ch) {
                Ok(Some(v)) => group.push(v, &mut self.out).map_err(|()| bad())?,
                Ok(None) => {}
                Err(()) => return Err(bad()),
            }
            self.pos += 1;
        }
        // Bytes appear only when a group completes, so no group is left half read here.
        Ok(&self.out[..n as usize])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_padded_apart_decode_as_one() {
        // "AQAAAA==" is 01 00 00 00; "eF4=" is 78 5e.
        assert_eq!(decode(b"AQAAAA==eF4=").unwrap(), [1, 0, 0, 0, 0x78, 0x5e]);
        let mut s = Base64Stream::new(b"AQAAAA==eF4=");
        assert_eq!(s.prefix(4, "a header").unwrap(), [1, 0, 0, 0]);
        assert_eq!(s.prefix(6, "data").unwrap(), [1, 0, 0, 0, 0x78, 0x5e]);
        let err = s.prefix(7, "a block").unwrap_err();
        assert!(
            err.contains(
                "ends inside a block: the array needs 7 bytes from its start, 6 are there"
            ),
            "{err}"
        );
    }

    #[test]
    fn bad_characters_are_located() {
        assert_eq!(decode(b"AAAA*AAA"), Err(4));
        assert_eq!(decode(b"AA=A"), Err(3));
        assert_eq!(decode(b"AAA"), Err(3));
        let err = Base64Stream::new(b"AAAA*AAA").prefix(6, "x").unwrap_err();
        assert!(err.contains("character 4"), "{err}");
    }
}
