//! A minimal binary archive of named `f32`/`u64` arrays plus a JSON metadata value, written
//! atomically (temporary file, fsync, rename): the checkpoint format.
//!
//! Layout: `b"EVOGSCK1"`, a little-endian `u64` header length, the UTF-8 JSON header
//! `{"meta": …, "arrays": [{"name", "kind", "len"}…], "meta_f64_bits": […]}`, then the
//! arrays' little-endian bytes in header order.
//!
//! `meta_f64_bits` holds the bit pattern of every floating-point number of `meta`, in the
//! order of a depth-first walk, and reading puts them back: JSON text parsed by `serde_json`'s
//! default (fast, not correctly rounded) parser can come back an ulp off, which would make a
//! resumed run drift from an uninterrupted one.

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
    /// Adds an `f32` array, or replaces the one of that name.
    pub fn put_f32(&mut self, name: &str, data: &[f32]) {
        put(&mut self.f32s, name, data);
    }
    /// Adds a `u64` array, or replaces the one of that name.
    pub fn put_u64(&mut self, name: &str, data: &[u64]) {
        put(&mut self.u64s, name, data);
    }
    fn has(&self, name: &str) -> bool {
        self.f32s.iter().any(|(n, _)| n == name) || self.u64s.iter().any(|(n, _)| n == name)
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
        let mut bits = Vec::new();
        visit_floats(&mut self.meta.clone(), &mut |x| bits.push(x.to_bits()));
        let header = serde_json::to_vec(
            &json!({"meta": self.meta, "arrays": arrays, "meta_f64_bits": bits}),
        )
        .unwrap_or_default();
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
        crate::atomic::write_atomic(path, &buf).map_err(io)
    }

    /// Reads an archive (see [`from_bytes`](Self::from_bytes)).
    ///
    /// # Errors
    /// I/O failures or a corrupt file.
    pub fn read(path: &Path) -> Result<Self, ArchiveError> {
        let p = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|source| ArchiveError::Io {
            path: p.clone(),
            source,
        })?;
        Self::from_bytes(&bytes).map_err(|msg| ArchiveError::Corrupt { path: p, msg })
    }

    /// Parses an archive from its bytes. Every length the header declares is checked against
    /// the bytes (with checked arithmetic) before the array is copied.
    ///
    /// # Errors
    /// What is wrong with the bytes (the `msg` of [`ArchiveError::Corrupt`]).
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, String> {
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
        let mut meta = header["meta"].clone();
        if let Some(bits) = header["meta_f64_bits"].as_array() {
            let bits: Vec<u64> = bits
                .iter()
                .map(|b| b.as_u64().ok_or_else(|| corrupt("metadata float bits")))
                .collect::<Result<_, _>>()?;
            let mut next = bits.iter();
            let mut missing = false;
            visit_floats(&mut meta, &mut |x| match next.next() {
                Some(&b) => *x = f64::from_bits(b),
                None => missing = true,
            });
            if missing || next.next().is_some() {
                return Err(corrupt("metadata float bits do not match the metadata"));
            }
        }
        let mut ar = Self::new(meta);
        let mut off = 16 + hl;
        for a in header["arrays"]
            .as_array()
            .ok_or_else(|| corrupt("no array list"))?
        {
            let name = a["name"].as_str().ok_or_else(|| corrupt("array name"))?;
            if ar.has(name) {
                return Err(format!("array `{name}` appears twice"));
            }
            let len = usize::try_from(a["len"].as_u64().ok_or_else(|| corrupt("array length"))?)
                .map_err(|_| corrupt("array length"))?;
            match a["kind"].as_str() {
                Some("f32") => {
                    let b =
                        array_bytes(bytes, off, len, 4).ok_or_else(|| corrupt("truncated data"))?;
                    ar.put_f32(
                        name,
                        &b.chunks_exact(4)
                            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                            .collect::<Vec<_>>(),
                    );
                    off += b.len();
                }
                Some("u64") => {
                    let b =
                        array_bytes(bytes, off, len, 8).ok_or_else(|| corrupt("truncated data"))?;
                    ar.put_u64(
                        name,
                        &b.chunks_exact(8)
                            .map(|c| u64::from_le_bytes(c.try_into().unwrap_or_default()))
                            .collect::<Vec<_>>(),
                    );
                    off += b.len();
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

fn put<T: Clone>(arrays: &mut Vec<(String, Vec<T>)>, name: &str, data: &[T]) {
    match arrays.iter_mut().find(|(n, _)| n == name) {
        Some((_, d)) => *d = data.to_vec(),
        None => arrays.push((name.to_string(), data.to_vec())),
    }
}

/// The `len · size` bytes of `bytes` from `off`, if they are all there (no overflow).
fn array_bytes(bytes: &[u8], off: usize, len: usize, size: usize) -> Option<&[u8]> {
    let end = len.checked_mul(size).and_then(|n| off.checked_add(n))?;
    bytes.get(off..end)
}

/// Calls `f` on every floating-point number of `v` (not integers), depth first, in the
/// order of the map's keys and the arrays' elements, and stores what `f` leaves.
fn visit_floats(v: &mut Value, f: &mut impl FnMut(&mut f64)) {
    match v {
        Value::Number(n) if n.is_f64() => {
            if let Some(mut x) = n.as_f64() {
                f(&mut x);
                if let Some(m) = serde_json::Number::from_f64(x) {
                    *n = m;
                }
            }
        }
        Value::Array(a) => a.iter_mut().for_each(|x| visit_floats(x, f)),
        Value::Object(o) => o.values_mut().for_each(|x| visit_floats(x, f)),
        _ => {}
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

    /// Metadata floats come back bit for bit, including values that `serde_json`'s default
    /// parser reads an ulp off (the test finds such values among random ones and checks that
    /// some are there, so it would fail if the bit patterns were not used).
    #[test]
    fn metadata_floats_round_trip_exactly() {
        let mut rng = evogs_math::rng::SplitMix64::new(7);
        let xs: Vec<f64> = (0..4000)
            .map(|_| {
                let u = rng.next_f64();
                (u - 0.5) * 10f64.powi(i32::try_from(rng.next_u64() % 12).unwrap_or(0) - 6)
            })
            .collect();
        let misread = xs
            .iter()
            .filter(|x| {
                let back: f64 =
                    serde_json::from_str(&serde_json::to_string(x).expect("json")).expect("parse");
                back.to_bits() != x.to_bits()
            })
            .count();
        assert!(
            misread > 0,
            "plain JSON reads some of these floats an ulp off"
        );
        let dir = std::env::temp_dir().join(format!("evogs-ar-bits-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp");
        let p = dir.join("c.bin");
        let a = Archive::new(json!({"aabb": [xs[..3], xs[3..6]], "n": 3, "all": xs, "t": 0.25}));
        a.write(&p).expect("write");
        let b = Archive::read(&p).expect("read");
        let back: Vec<f64> = b.meta["all"]
            .as_array()
            .expect("array")
            .iter()
            .map(|v| v.as_f64().expect("float"))
            .collect();
        assert!(
            back.iter()
                .zip(&xs)
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "{misread} of {} floats would drift through plain JSON; none may here",
            xs.len()
        );
        assert_eq!(a, b, "the whole metadata");
        assert_eq!(b.meta["n"].as_u64(), Some(3), "integers stay integers");
        std::fs::remove_dir_all(dir).ok();
    }

    /// An archive's bytes with this JSON header and data.
    fn raw(header_len: u64, header: &str, data: &[u8]) -> Vec<u8> {
        let mut b = MAGIC.to_vec();
        b.extend_from_slice(&header_len.to_le_bytes());
        b.extend_from_slice(header.as_bytes());
        b.extend_from_slice(data);
        b
    }

    /// Lengths near `usize::MAX` are reported as corrupt, not overflowed into a panic.
    #[test]
    fn huge_declared_lengths_are_corrupt() {
        let e = Archive::from_bytes(&raw(u64::MAX - 8, "{}", &[])).expect_err("header length");
        assert_eq!(e, "truncated header", "huge header length");
        for (kind, len) in [
            ("f32", u64::MAX / 4 + 1),
            ("u64", u64::MAX / 8 + 1),
            ("f32", u64::MAX),
        ] {
            let h = format!(
                r#"{{"meta": null, "arrays": [{{"name": "a", "kind": "{kind}", "len": {len}}}]}}"#
            );
            let e =
                Archive::from_bytes(&raw(h.len() as u64, &h, &[0; 16])).expect_err("array length");
            assert_eq!(e, "truncated data", "{kind} array of {len}");
        }
    }

    #[test]
    fn from_bytes_reads_what_write_wrote() {
        let dir = std::env::temp_dir().join(format!("evogs-ar-bytes-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp");
        let p = dir.join("c.bin");
        let mut a = Archive::new(json!({"t": 0.1}));
        a.put_f32("x", &[1.0, f32::NAN.copysign(-1.0)]);
        a.put_u64("n", &[3]);
        a.write(&p).expect("write");
        let bytes = std::fs::read(&p).expect("bytes");
        let b = Archive::from_bytes(&bytes).expect("parse");
        assert_eq!(b.u64("n"), Some(&[3][..]), "u64 array");
        assert_eq!(b.first_non_finite(), Some(("x", 1)), "the NaN comes back");
        let e = Archive::read(&dir.join("none.bin")).expect_err("missing file");
        assert!(matches!(e, ArchiveError::Io { .. }), "{e}");
        std::fs::remove_dir_all(dir).ok();
    }
}
