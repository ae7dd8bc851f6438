//! The checkpoint archive's first on-disk format (`EVOGSCK1`, written until checkpoints
//! became safetensors files), still read so that older runs evaluate, render, export and
//! resume.
//!
//! Layout: `b"EVOGSCK1"`, a little-endian `u64` header length, the UTF-8 JSON header
//! `{"meta": …, "arrays": [{"name", "kind", "len"}…], "meta_f64_bits": […]}`, then the
//! arrays' little-endian bytes in header order. Every length the header declares is checked
//! against the bytes (with checked arithmetic) before an array is copied.

use super::float_bits::restore_float_bits;
use serde_json::Value;

/// The first eight bytes of a file in this format.
pub(super) const MAGIC: &[u8; 8] = b"EVOGSCK1";

/// The contents of a file in this format.
#[derive(Debug, Default)]
pub(super) struct Parts {
    /// The metadata, its floats restored bit for bit.
    pub(super) meta: Value,
    /// The `f32` arrays, in file order.
    pub(super) f32s: Vec<(String, Vec<f32>)>,
    /// The `u64` arrays, in file order.
    pub(super) u64s: Vec<(String, Vec<u64>)>,
}

impl Parts {
    fn has(&self, name: &str) -> bool {
        self.f32s.iter().any(|(n, _)| n == name) || self.u64s.iter().any(|(n, _)| n == name)
    }
}

/// Parses a file in this format (starting with [`MAGIC`]).
///
/// # Errors
/// What is wrong with the bytes.
pub(super) fn parse(bytes: &[u8]) -> Result<Parts, String> {
    let corrupt = |msg: &str| msg.to_string();
    if bytes.len() < 16 || &bytes[..8] != MAGIC {
        return Err(corrupt("bad magic"));
    }
    let hl = usize::try_from(u64::from_le_bytes(
        bytes[8..16].try_into().map_err(|_| corrupt("header"))?,
    ))
    .map_err(|_| corrupt("header length"))?;
    let header: Value = serde_json::from_slice(
        16usize
            .checked_add(hl)
            .and_then(|end| bytes.get(16..end))
            .ok_or_else(|| corrupt("truncated header"))?,
    )
    .map_err(|_| corrupt("header JSON"))?;
    let mut parts = Parts {
        meta: header["meta"].clone(),
        ..Parts::default()
    };
    if let Some(bits) = header["meta_f64_bits"].as_array() {
        let bits: Vec<u64> = bits
            .iter()
            .map(|b| b.as_u64().ok_or_else(|| corrupt("metadata float bits")))
            .collect::<Result<_, _>>()?;
        restore_float_bits(&mut parts.meta, &bits)?;
    }
    let mut off = 16 + hl;
    for a in header["arrays"]
        .as_array()
        .ok_or_else(|| corrupt("no array list"))?
    {
        let name = a["name"].as_str().ok_or_else(|| corrupt("array name"))?;
        if parts.has(name) {
            return Err(format!("array `{name}` appears twice"));
        }
        let len = usize::try_from(a["len"].as_u64().ok_or_else(|| corrupt("array length"))?)
            .map_err(|_| corrupt("array length"))?;
        match a["kind"].as_str() {
            Some("f32") => {
                let b = array_bytes(bytes, off, len, 4).ok_or_else(|| corrupt("truncated data"))?;
                let d = b
                    .chunks_exact(4)
                    .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                    .collect();
                parts.f32s.push((name.to_string(), d));
                off += b.len();
            }
            Some("u64") => {
                let b = array_bytes(bytes, off, len, 8).ok_or_else(|| corrupt("truncated data"))?;
                let d = b
                    .chunks_exact(8)
                    .map(|c| u64::from_le_bytes(c.try_into().unwrap_or_default()))
                    .collect();
                parts.u64s.push((name.to_string(), d));
                off += b.len();
            }
            _ => return Err(corrupt("array kind")),
        }
    }
    if off != bytes.len() {
        return Err(corrupt("trailing bytes"));
    }
    Ok(parts)
}

/// The `len · size` bytes of `bytes` from `off`, if they are all there (no overflow).
fn array_bytes(bytes: &[u8], off: usize, len: usize, size: usize) -> Option<&[u8]> {
    let end = len.checked_mul(size).and_then(|n| off.checked_add(n))?;
    bytes.get(off..end)
}
