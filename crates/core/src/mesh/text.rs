//! Shared plumbing for the text readers: reading a file, walking its lines and tokens with
//! 1-based line numbers, parsing numbers and indices into [`MeshError`]s that name the file and
//! line, and the checks every tet reader makes (index range, repeated index, empty mesh).
//!
//! Readers take the whole file as one `&str` and split it; nothing here allocates per token.

use std::path::Path;

use super::MeshError;

/// Reads a whole file as UTF-8. Invalid UTF-8 is a parse error at the line holding the
/// first bad byte.
pub(crate) fn read_text(path: &Path) -> Result<String, MeshError> {
    let bytes = std::fs::read(path).map_err(|error| MeshError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    decode_text(path, bytes)
}

/// A file's bytes as UTF-8 text; invalid UTF-8 is a parse error at the line holding the
/// first bad byte.
pub(crate) fn decode_text(path: &Path, bytes: Vec<u8>) -> Result<String, MeshError> {
    String::from_utf8(bytes).map_err(|e| {
        let valid = e.utf8_error().valid_up_to();
        let line = 1 + e.as_bytes()[..valid]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        parse_error(path, line, "not UTF-8 text (is this a binary file?)")
    })
}

/// A [`MeshError::Parse`] at a 1-based line. The message is clipped to a short line: it may
/// quote a token of the file, which can be the whole file.
pub(crate) fn parse_error(path: &Path, line: usize, message: impl Into<String>) -> MeshError {
    MeshError::Parse {
        path: path.to_path_buf(),
        line,
        message: crate::quote::clip_message(&message.into()),
    }
}

/// Shortest text of one entry (a vertex or a tet line such as `0 0 0 0\n`), for bounding
/// what a header's count can make us allocate.
const MIN_ENTRY_BYTES: usize = 8;

/// Checks a count announced by a header (`what` names it) against the mesh budget, and returns
/// the capacity to reserve for it: no more than the text could hold, so a tiny file that
/// announces 10^12 vertices allocates nothing large.
pub(crate) fn announced(
    path: &Path,
    line: usize,
    n: usize,
    what: &str,
    text_len: usize,
) -> Result<usize, MeshError> {
    crate::limits::MESH
        .check_usize(Some(n))
        .map_err(|e| parse_error(path, line, format!("the header announces {n} {what}: {e}")))?;
    Ok(n.min(text_len / MIN_ENTRY_BYTES + 1))
}

/// The lines of a text, 1-based, with `\r` and `#` comments removed.
pub(crate) fn lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.split('\n').enumerate().map(|(i, raw)| {
        let line = raw.split('#').next().unwrap_or("");
        (i + 1, line.trim_end_matches('\r'))
    })
}

/// Number of the last line of a text (1 for an empty text), for errors at end of file.
pub(crate) fn last_line(text: &str) -> usize {
    let n = text.split('\n').count();
    if n > 1 && text.ends_with('\n') {
        n - 1
    } else {
        n
    }
}

/// A stream of whitespace-separated tokens with their 1-based line numbers, for formats whose
/// records may span lines (MEDIT). `#` starts a comment that runs to the end of the line.
pub(crate) struct Tokens<'a> {
    /// Length of the whole text (bytes), to bound what a count can make a reader reserve.
    pub(crate) text_len: usize,
    lines: std::str::Split<'a, char>,
    current: std::str::SplitAsciiWhitespace<'a>,
    line: usize,
    last_line: usize,
}

impl<'a> Tokens<'a> {
    pub(crate) fn new(text: &'a str) -> Self {
        Tokens {
            text_len: text.len(),
            lines: text.split('\n'),
            current: "".split_ascii_whitespace(),
            line: 0,
            last_line: last_line(text),
        }
    }

    /// The line of the most recently returned token, or of the end of the file once the
    /// stream is exhausted.
    pub(crate) fn line(&self) -> usize {
        self.line.clamp(1, self.last_line.max(1))
    }
}

impl<'a> Iterator for Tokens<'a> {
    type Item = (usize, &'a str);

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if let Some(token) = self.current.next() {
                return Some((self.line, token));
            }
            let raw = self.lines.next()?;
            self.line += 1;
            let content = raw.split('#').next().unwrap_or("");
            self.current = content.split_ascii_whitespace();
        }
    }
}

/// Largest |coordinate| a mesh may have (m): volumes and energies are cubes and squares of
/// lengths, so larger coordinates overflow f64 to infinity and NaN.
pub const MAX_COORDINATE: f64 = 1e50;

/// Parses a finite coordinate (at most [`MAX_COORDINATE`] in magnitude).
pub(crate) fn coordinate(path: &Path, line: usize, token: &str) -> Result<f64, MeshError> {
    match token.parse::<f64>() {
        Ok(x) if x.is_finite() && x.abs() > MAX_COORDINATE => Err(parse_error(
            path,
            line,
            format!(
                "coordinate `{token}` is beyond ±{MAX_COORDINATE:e}: volumes and energies \
                 would overflow"
            ),
        )),
        Ok(x) if x.is_finite() => Ok(x),
        Ok(_) => Err(parse_error(
            path,
            line,
            format!("coordinate `{token}` is not a finite number"),
        )),
        Err(_) => Err(parse_error(
            path,
            line,
            format!("expected a number, found `{token}`"),
        )),
    }
}

/// Parses an integer field (`what` names it in the message).
pub(crate) fn integer(path: &Path, line: usize, token: &str, what: &str) -> Result<i64, MeshError> {
    token.parse::<i64>().map_err(|_| {
        parse_error(
            path,
            line,
            format!("expected an integer {what}, found `{token}`"),
        )
    })
}

/// Parses a non-negative count.
pub(crate) fn count(path: &Path, line: usize, token: &str, what: &str) -> Result<usize, MeshError> {
    token.parse::<usize>().map_err(|_| {
        parse_error(
            path,
            line,
            format!("expected a non-negative integer {what}, found `{token}`"),
        )
    })
}

/// Parses a vertex index written with the given base (0 or 1) and returns it 0-based.
/// Range against the vertex count is checked later by [`TetCollector::finish`], because some
/// formats may list tets before all vertices are known.
pub(crate) fn vertex_index(
    path: &Path,
    line: usize,
    token: &str,
    base: i64,
) -> Result<usize, MeshError> {
    let raw = integer(path, line, token, "vertex index")?;
    raw.checked_sub(base)
        .and_then(|i| usize::try_from(i).ok())
        .ok_or_else(|| {
            parse_error(
                path,
                line,
                format!("vertex index {raw} is out of range (indices are {base}-based)"),
            )
        })
}

/// Collects tets with the line each came from, then checks them all at once.
pub(crate) struct TetCollector {
    /// Index base of the file (0 or 1), used to write indices in messages as the file does.
    base: usize,
    pub(crate) tets: Vec<[usize; 4]>,
    lines: Vec<usize>,
}

impl TetCollector {
    pub(crate) fn new(base: usize, capacity: usize) -> Self {
        TetCollector {
            base,
            tets: Vec::with_capacity(capacity),
            lines: Vec::with_capacity(capacity),
        }
    }

    /// Adds a tet (0-based indices); rejects a repeated index at once.
    pub(crate) fn push(
        &mut self,
        path: &Path,
        line: usize,
        tet: [usize; 4],
    ) -> Result<(), MeshError> {
        for i in 0..4 {
            if tet[i + 1..].contains(&tet[i]) {
                return Err(parse_error(
                    path,
                    line,
                    format!(
                        "tet repeats vertex index {}: a tet needs 4 distinct vertices",
                        tet[i] + self.base
                    ),
                ));
            }
        }
        self.tets.push(tet);
        self.lines.push(line);
        Ok(())
    }

    /// Checks every index against the vertex count and returns the tets.
    pub(crate) fn finish(
        self,
        path: &Path,
        num_vertices: usize,
    ) -> Result<Vec<[usize; 4]>, MeshError> {
        let base = self.base;
        for (tet, &line) in self.tets.iter().zip(&self.lines) {
            if let Some(&bad) = tet.iter().find(|&&v| v >= num_vertices) {
                return Err(parse_error(
                    path,
                    line,
                    format!(
                        "vertex index {} is out of range: the mesh has {num_vertices} vertices, \
                         so {base}-based indices run from {base} to {}",
                        bad + base,
                        (num_vertices + base).saturating_sub(1),
                    ),
                ));
            }
        }
        Ok(self.tets)
    }
}

/// The error for a mesh without tets (or without vertices), pointing at `line`.
pub(crate) fn empty_mesh(path: &Path, line: usize, what: &str) -> MeshError {
    parse_error(path, line, format!("empty mesh: {what}"))
}
