//! A minimal binary archive of named `f32`/`u64` arrays plus a JSON metadata value, written
//! atomically (temporary file, fsync, rename): the checkpoint format.
//!
//! Layout: `b"EVOGSCK1"`, a little-endian `u64` header length, the UTF-8 JSON header
//! `{"meta": …, "arrays": [{"name", "kind", "len"}…]}`, then the arrays' little-endian bytes
//! in header order.

use serde_json::{Value, json};
use std::path::Path;

const MAGIC: &[u8; 8] = b"EVOGSCK1";

/// Why an archive could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum ArchiveError {
    /// I/O failure.
    #[error("{path}: {source}")]
    Io {
        /// File.
        path: String,
        /// Cause.
        source: std::io::Error,
    },
    /// Not an archive, or a corrupt one.
    #[error("{path}: not a valid evogs checkpoint ({msg})")]
    Corrupt {
        /// File.
        path: String,
        /// What is wrong.
        msg: String,
    },
}

/// An in-memory archive.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Archive {
    /// Free-form metadata.
    pub meta: Value,
    f32s: Vec<(String, Vec<f32>)>,
    u64s: Vec<(String, Vec<u64>)>,
}

impl Archive {
    /// An empty archive with metadata.
    #[must_use]
    pub fn new(meta: Value) -> Self {
        Self {
            meta,
            f32s: Vec::new(),
            u64s: Vec::new(),
        }
    }
    /// Adds an `f32` array.
    pub fn put_f32(&mut self, name: &str, data: &[f32]) {
        self.f32s.push((name.to_string(), data.to_vec()));
    }
    /// Adds a `u64` array.
    pub fn put_u64(&mut self, name: &str, data: &[u64]) {
        self.u64s.push((name.to_string(), data.to_vec()));
    }
    /// An `f32` array by name.
    #[must_use]
    pub fn f32(&self, name: &str) -> Option<&[f32]> {
        self.f32s
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, d)| d.as_slice())
    }
    /// The first non-finite `f32` value: its array's name and index.
    #[must_use]
    pub fn first_non_finite(&self) -> Option<(&str, usize)> {
        self.f32s.iter().find_map(|(name, d)| {
            d.iter()
                .position(|v| !v.is_finite())
                .map(|i| (name.as_str(), i))
        })
    }
    /// A `u64` array by name.
    #[must_use]
    pub fn u64(&self, name: &str) -> Option<&[u64]> {
        self.u64s
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, d)| d.as_slice())
    }

    /// Writes the archive atomically.
    ///
    /// # Errors
    /// I/O failures (the previous file, if any, is left intact).
    pub fn write(&self, path: &Path) -> Result<(), ArchiveError> {
        let io = |source| ArchiveError::Io {
            path: path.display().to_string(),
            source,
        };
        let mut arrays = Vec::new();
        for (n, d) in &self.f32s {
            arrays.push(json!({"name": n, "kind": "f32", "len": d.len()}));
        }
        for (n, d) in &self.u64s {
            arrays.push(json!({"name": n, "kind": "u64", "len": d.len()}));
        }
        let header =
            serde_json::to_vec(&json!({"meta": self.meta, "arrays": arrays})).unwrap_or_default();
        let mut buf = Vec::with_capacity(
            16 + header.len() + self.f32s.iter().map(|(_, d)| 4 * d.len()).sum::<usize>(),
        );
        buf.extend_from_slice(MAGIC);
        buf.extend_from_slice(&(header.len() as u64).to_le_bytes());
        buf.extend_from_slice(&header);
        for (_, d) in &self.f32s {
            for v in d {
                buf.extend_from_slice(&v.to_le_bytes());
            }
        }
        for (_, d) in &self.u64s {
            for v in d {
                buf.extend_from_slice(&v.to_le_bytes());
            }
        }
        let tmp = path.with_extension("tmp");
        {
            use std::io::Write as _;
            let mut f = std::fs::File::create(&tmp).map_err(io)?;
            f.write_all(&buf).map_err(io)?;
            f.sync_all().map_err(io)?;
        }
        std::fs::rename(&tmp, path).map_err(io)
    }

    /// Reads an archive.
    ///
    /// # Errors
    /// I/O failures or a corrupt file.
    pub fn read(path: &Path) -> Result<Self, ArchiveError> {
        let p = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|source| ArchiveError::Io {
            path: p.clone(),
            source,
        })?;
        let corrupt = |msg: &str| ArchiveError::Corrupt {
            path: p.clone(),
            msg: msg.to_string(),
        };
        if bytes.len() < 16 || &bytes[..8] != MAGIC {
            return Err(corrupt("bad magic"));
        }
        let hl = usize::try_from(u64::from_le_bytes(
            bytes[8..16].try_into().map_err(|_| corrupt("header"))?,
        ))
        .map_err(|_| corrupt("header length"))?;
        let header: Value = serde_json::from_slice(
            bytes
                .get(16..16 + hl)
                .ok_or_else(|| corrupt("truncated header"))?,
        )
        .map_err(|_| corrupt("header JSON"))?;
        let mut ar = Self::new(header["meta"].clone());
        let mut off = 16 + hl;
        for a in header["arrays"]
            .as_array()
            .ok_or_else(|| corrupt("no array list"))?
        {
            let name = a["name"].as_str().ok_or_else(|| corrupt("array name"))?;
            let len = usize::try_from(a["len"].as_u64().ok_or_else(|| corrupt("array length"))?)
                .map_err(|_| corrupt("array length"))?;
            match a["kind"].as_str() {
                Some("f32") => {
                    let b = bytes
                        .get(off..off + 4 * len)
                        .ok_or_else(|| corrupt("truncated data"))?;
                    ar.put_f32(
                        name,
                        &b.chunks_exact(4)
                            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                            .collect::<Vec<_>>(),
                    );
                    off += 4 * len;
                }
                Some("u64") => {
                    let b = bytes
                        .get(off..off + 8 * len)
                        .ok_or_else(|| corrupt("truncated data"))?;
                    ar.put_u64(
                        name,
                        &b.chunks_exact(8)
                            .map(|c| u64::from_le_bytes(c.try_into().unwrap_or_default()))
                            .collect::<Vec<_>>(),
                    );
                    off += 8 * len;
                }
                _ => return Err(corrupt("array kind")),
            }
        }
        if off != bytes.len() {
            return Err(corrupt("trailing bytes"));
        }
        Ok(ar)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_corruption() {
        let dir = std::env::temp_dir().join(format!("evogs-ar-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp");
        let p = dir.join("c.bin");
        let mut a = Archive::new(json!({"iteration": 12}));
        a.put_f32("x", &[1.5, -2.0, f32::MIN_POSITIVE]);
        a.put_u64("rng", &[u64::MAX, 7]);
        a.write(&p).expect("write");
        let b = Archive::read(&p).expect("read");
        assert_eq!(a, b, "round trip");
        let mut bytes = std::fs::read(&p).expect("bytes");
        bytes.truncate(bytes.len() - 3);
        std::fs::write(&p, bytes).expect("write");
        assert!(Archive::read(&p).is_err(), "truncated file rejected");
        std::fs::remove_dir_all(dir).ok();
    }
}
