//! The layout of one binary array of a VTK XML file, inline (`format="binary"`) or appended:
//! a header of `header_type` words in the file's `byte_order` — the byte count, or, under a
//! compressor, the block table (number of blocks, block size, size of the last block, then each
//! block's compressed size) — then the data or the compressed blocks.
//!
//! Every size the header declares is checked — against what the grid's counts allow, the mesh
//! budget and what the compressed bytes can inflate to — before anything is allocated or
//! inflated; the array's bytes are read through [`Payload`], so an appended base64 array is
//! decoded only as far as its header says it reaches.

use super::compressors::Compressor;

/// How binary arrays are stored, from the `VTKFile` tag.
#[derive(Clone, Copy, Debug)]
pub(super) struct Encoding {
    pub(super) little: bool,
    pub(super) header64: bool,
    pub(super) compressor: Option<Compressor>,
}

/// The bytes of one binary array from its start, read on demand.
pub(super) trait Payload {
    /// The first `n` bytes, or why there are fewer (`what` names the part being read).
    fn prefix(&mut self, n: u64, what: &str) -> Result<&[u8], String>;
}

/// An array whose bytes are at hand (decoded inline base64, appended raw data).
pub(super) struct Bytes<'a>(pub(super) &'a [u8]);

impl Payload for Bytes<'_> {
    fn prefix(&mut self, n: u64, what: &str) -> Result<&[u8], String> {
        match usize::try_from(n).ok().and_then(|n| self.0.get(..n)) {
            Some(b) => Ok(b),
            None => Err(format!(
                "the data ends inside {what}: the array needs {n} bytes from its start, {} are \
                 there",
                self.0.len()
            )),
        }
    }
}

impl Payload for super::base64::Base64Stream<'_> {
    fn prefix(&mut self, n: u64, what: &str) -> Result<&[u8], String> {
        super::base64::Base64Stream::prefix(self, n, what)
    }
}

/// One value of a binary array as f64 (exact for every float and for integers up to 2^53).
/// `kind` is a VTK XML type name; `b` holds its bytes.
pub(super) fn number(kind: &str, b: &[u8], little: bool) -> f64 {
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

/// Bytes per value of a VTK XML type, `None` for a type softbench does not know.
pub(super) fn width(kind: &str) -> Option<usize> {
    match kind {
        "Int8" | "UInt8" => Some(1),
        "Int16" | "UInt16" => Some(2),
        "Int32" | "UInt32" | "Float32" => Some(4),
        "Int64" | "UInt64" | "Float64" => Some(8),
        _ => None,
    }
}

/// The array's data bytes: the header read and checked, then the data copied or the blocks
/// inflated. `max_bytes` is what the grid's counts allow the array.
pub(super) fn unpack(
    src: &mut dyn Payload,
    enc: Encoding,
    max_bytes: u64,
) -> Result<Vec<u8>, String> {
    let hs = if enc.header64 { 8 } else { 4 };
    let word = |b: &[u8], i: usize| {
        number(
            if enc.header64 { "UInt64" } else { "UInt32" },
            &b[i * hs..(i + 1) * hs],
            enc.little,
        ) as u64
    };
    let over = |n: u64| {
        format!("it declares {n} bytes, more than the {max_bytes} bytes the grid's counts allow")
    };
    let hs64 = hs as u64;
    let Some(compressor) = enc.compressor else {
        let n = word(src.prefix(hs64, "its header")?, 0);
        if n > max_bytes {
            return Err(over(n));
        }
        let all = src.prefix(hs64.saturating_add(n), &format!("its {n} bytes of data"))?;
        return Ok(all[hs..].to_vec());
    };
    let head = src.prefix(3 * hs64, "its block table")?;
    let (blocks, block_size) = (word(head, 0), word(head, 1));
    // VTK writes 0 here when the last block is full.
    let last_size = match word(head, 2) {
        0 => block_size,
        partial => partial,
    };
    if blocks > 0 && block_size == 0 {
        return Err(format!("its block table has {blocks} blocks of 0 bytes"));
    }
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
    // Each block holds at least one byte of the array, so `blocks` is at most `total` (which
    // is bounded) unless the array is empty.
    let table_end = blocks
        .checked_add(3)
        .and_then(|k| k.checked_mul(hs64))
        .ok_or("its block table is longer than the file")?;
    let table = src.prefix(table_end, &format!("its block table of {blocks} blocks"))?;
    // Each block's declared size against what its compressed bytes can inflate to, before
    // any is inflated.
    let mut sizes = Vec::new();
    let mut compressed = 0u64;
    for b in 0..blocks as usize {
        let size = word(table, 3 + b);
        let expect = if b + 1 == blocks as usize {
            last_size
        } else {
            block_size
        };
        if !compressor.can_inflate(size, expect) {
            return Err(format!(
                "block {b} declares {expect} bytes from {size} compressed bytes, more than {} \
                 can inflate them to",
                compressor.name()
            ));
        }
        compressed = compressed.saturating_add(size);
        sizes.push((size, expect));
    }
    let all = src.prefix(
        table_end.saturating_add(compressed),
        &format!("its {blocks} compressed blocks"),
    )?;
    let mut out = Vec::with_capacity((total as usize).min(all.len().saturating_mul(4)));
    let mut at = table_end as usize;
    for (size, expect) in sizes {
        let block = &all[at..at + size as usize];
        at += size as usize;
        compressor.inflate(block, expect, &mut out)?;
    }
    Ok(out)
}
