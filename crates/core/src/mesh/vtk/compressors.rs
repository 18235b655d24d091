//! The compressors a VTK XML file can name in `compressor="..."`, each inflating one block of a
//! binary array to exactly the size the block table declares: `vtkZLibDataCompressor` (zlib
//! streams, flate2), `vtkLZ4DataCompressor` (raw LZ4 blocks, lz4_flex) and
//! `vtkLZMADataCompressor` (xz streams, lzma-rust2).
//!
//! Each has a bound on what one compressed byte can inflate to, checked against every block's
//! declared size before anything is inflated, so a small file cannot make the reader allocate
//! much more than it holds.

use std::io::Read;

/// A block compressor of VTK XML binary arrays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Compressor {
    Zlib,
    Lz4,
    Lzma,
}

/// What the `compressor` attribute may name, for messages.
pub(super) const SUPPORTED: &str =
    "none, vtkZLibDataCompressor, vtkLZ4DataCompressor and vtkLZMADataCompressor are";

impl Compressor {
    /// The compressor a `compressor` attribute names (`None` for no attribute or an empty
    /// one); `Err` with the name when it is not one of VTK's three.
    pub(super) fn from_attribute(name: Option<&str>) -> Result<Option<Compressor>, &str> {
        match name.unwrap_or("") {
            "" => Ok(None),
            "vtkZLibDataCompressor" => Ok(Some(Compressor::Zlib)),
            "vtkLZ4DataCompressor" => Ok(Some(Compressor::Lz4)),
            "vtkLZMADataCompressor" => Ok(Some(Compressor::Lzma)),
            other => Err(other),
        }
    }

    /// Its name in messages.
    pub(super) fn name(self) -> &'static str {
        match self {
            Compressor::Zlib => "zlib",
            Compressor::Lz4 => "LZ4",
            Compressor::Lzma => "LZMA",
        }
    }

    /// Most bytes one compressed byte can inflate to.
    ///
    /// - zlib: deflate's limit, a 258-byte match in two bits (1032).
    /// - LZ4: each further length byte of a match adds at most 255 bytes.
    /// - LZMA: no format limit as plain; the range coder's probabilities saturate, and the
    ///   largest ratio measured here (zeros, every preset, xz and raw LZMA1) is about 7,000:
    ///   2^16 leaves a margin of nine.
    fn max_ratio(self) -> u64 {
        match self {
            Compressor::Zlib => 1032,
            Compressor::Lz4 => 255,
            Compressor::Lzma => 1 << 16,
        }
    }

    /// Whether `size` compressed bytes can hold a block of `expect` bytes (with a constant for
    /// each format's framing).
    pub(super) fn can_inflate(self, size: u64, expect: u64) -> bool {
        /// Headers, trailers and checksums of one block.
        const SLACK: u64 = 4096;
        expect <= size.saturating_mul(self.max_ratio()).saturating_add(SLACK)
    }

    /// Inflates one block, appending exactly `expect` bytes to `out`; an error when the block
    /// is corrupt or inflates to another size. `expect` has been checked with
    /// [`can_inflate`](Self::can_inflate).
    pub(super) fn inflate(
        self,
        block: &[u8],
        expect: u64,
        out: &mut Vec<u8>,
    ) -> Result<(), String> {
        let before = out.len();
        let failed =
            |e: &dyn std::fmt::Display| format!("cannot decompress a {} block: {e}", self.name());
        match self {
            Compressor::Zlib => {
                read_exactly(flate2::read::ZlibDecoder::new(block), expect, out)
                    .map_err(|e| failed(&e))?;
            }
            Compressor::Lzma => {
                let reader = lzma_rust2::XzReader::new(block, false);
                read_exactly(reader, expect, out).map_err(|e| failed(&e))?;
            }
            Compressor::Lz4 => {
                let expect = usize::try_from(expect).map_err(|_| failed(&"too large"))?;
                out.resize(before + expect, 0);
                let n = lz4_flex::block::decompress_into(block, &mut out[before..])
                    .map_err(|e| failed(&e))?;
                out.truncate(before + n);
            }
        }
        let got = (out.len() - before) as u64;
        if got < expect {
            return Err(format!(
                "a {} block inflates to {got} bytes, but the block table says {expect}",
                self.name()
            ));
        }
        Ok(())
    }
}

/// Reads `expect` bytes from `reader` into `out`, then checks the stream ends there (which
/// also makes the decoder verify its checksum); more data is an error.
fn read_exactly(reader: impl Read, expect: u64, out: &mut Vec<u8>) -> std::io::Result<()> {
    let mut limited = reader.take(expect);
    limited.read_to_end(out)?;
    let mut rest = limited.into_inner();
    let mut extra = [0u8; 1];
    if rest.read(&mut extra)? != 0 {
        return Err(std::io::Error::other(format!(
            "the block holds more than the {expect} bytes the block table says"
        )));
    }
    Ok(())
}
