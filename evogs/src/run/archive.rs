//! Named one-dimensional `f32`/`u64` arrays plus a JSON metadata value, written atomically
//! (temporary file, fsync, rename) as a [safetensors](https://huggingface.co/docs/safetensors)
//! file: the checkpoint format, readable from Python with `safetensors` or `torch`
//! (docs/checkpoints.md).
//!
//! Each array is a tensor of its name, dtype `F32` or `U64` and shape `[len]`. The safetensors
//! header's `__metadata__` string map holds one entry, [`METADATA_KEY`], whose value is the
//! JSON text `{"format": "evogs archive", "meta": …}`: the metadata, whose floating-point
//! numbers come back bit for bit (`serde_json` writes the shortest text that parses back to
//! the same number, and its `float_roundtrip` feature parses it exactly). Entries written
//! before the feature was on also hold `meta_f64_bits`, the bit patterns of those numbers,
//! which is ignored. One entry rather than one per item because the safetensors crate
//! writes that map in hash order: with a single entry the file's bytes are the same from run
//! to run.
//!
//! Reading ([`Archive::from_bytes`]) takes untrusted bytes: the safetensors crate checks the
//! header length against the bytes, that the tensors' byte ranges tile the data exactly and
//! that each range matches its dtype and shape (with checked arithmetic); on top, a name
//! (or a metadata key) appearing twice in a header is refused (JSON parsers keep the last
//! one silently), every tensor must be 1-D and `F32` or `U64`, and the evogs metadata must be
//! there and parse.

use safetensors::{Dtype, SafeTensors, View};
use serde::de::{Deserialize, Deserializer, MapAccess, SeqAccess, Visitor};
use serde_json::{Value, json};
use std::borrow::Cow;
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::Path;

/// The key of the safetensors `__metadata__` entry that holds the archive's metadata.
pub const METADATA_KEY: &str = "evogs";

/// The `format` field of that entry.
const FORMAT: &str = "evogs archive";

/// Why an archive could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum ArchiveError {
    /// The path is not a regular file, or is larger than a checkpoint can be.
    #[error(transparent)]
    Read(#[from] crate::bounded::ReadError),
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
    /// The archive cannot be encoded (a safetensors header over the crate's 100 MB limit).
    #[error("{path}: cannot encode the checkpoint ({msg})")]
    Encode {
        /// File.
        path: String,
        /// What is wrong.
        msg: String,
    },
}

/// One named array.
#[derive(Clone, Debug, PartialEq)]
enum Array {
    F32(Vec<f32>),
    U64(Vec<u64>),
}

impl Array {
    const fn dtype(&self) -> Dtype {
        match self {
            Self::F32(_) => Dtype::F32,
            Self::U64(_) => Dtype::U64,
        }
    }
    fn len(&self) -> usize {
        match self {
            Self::F32(d) => d.len(),
            Self::U64(d) => d.len(),
        }
    }
}

/// An array as a safetensors tensor: shape `[len]`, little-endian bytes made on demand (the
/// crate asks once, while it writes the file's buffer).
struct Tensor<'a> {
    array: &'a Array,
    shape: [usize; 1],
}

impl View for Tensor<'_> {
    fn dtype(&self) -> Dtype {
        self.array.dtype()
    }
    fn shape(&self) -> &[usize] {
        &self.shape
    }
    fn data(&self) -> Cow<'_, [u8]> {
        Cow::Owned(match self.array {
            Array::F32(d) => d.iter().flat_map(|v| v.to_le_bytes()).collect(),
            Array::U64(d) => d.iter().flat_map(|v| v.to_le_bytes()).collect(),
        })
    }
    fn data_len(&self) -> usize {
        match self.array {
            Array::F32(d) => 4 * d.len(),
            Array::U64(d) => 8 * d.len(),
        }
    }
}

/// An in-memory archive: metadata and arrays by name (each name once, whatever its type).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Archive {
    /// Free-form metadata.
    pub meta: Value,
    arrays: BTreeMap<String, Array>,
}

impl Archive {
    /// An empty archive with metadata.
    #[must_use]
    pub fn new(meta: Value) -> Self {
        Self {
            meta,
            arrays: BTreeMap::new(),
        }
    }
    /// Adds an `f32` array, or replaces the array of that name.
    pub fn put_f32(&mut self, name: &str, data: &[f32]) {
        self.arrays
            .insert(name.to_string(), Array::F32(data.to_vec()));
    }
    /// Adds a `u64` array, or replaces the array of that name.
    pub fn put_u64(&mut self, name: &str, data: &[u64]) {
        self.arrays
            .insert(name.to_string(), Array::U64(data.to_vec()));
    }
    /// An `f32` array by name.
    #[must_use]
    pub fn f32(&self, name: &str) -> Option<&[f32]> {
        match self.arrays.get(name)? {
            Array::F32(d) => Some(d),
            Array::U64(_) => None,
        }
    }
    /// A `u64` array by name.
    #[must_use]
    pub fn u64(&self, name: &str) -> Option<&[u64]> {
        match self.arrays.get(name)? {
            Array::U64(d) => Some(d),
            Array::F32(_) => None,
        }
    }
    /// The first non-finite `f32` value (arrays in name order): its array's name and index.
    #[must_use]
    pub fn first_non_finite(&self) -> Option<(&str, usize)> {
        self.arrays.iter().find_map(|(name, a)| match a {
            Array::F32(d) => d
                .iter()
                .position(|v| !v.is_finite())
                .map(|i| (name.as_str(), i)),
            Array::U64(_) => None,
        })
    }

    /// The archive as the bytes of a safetensors file.
    ///
    /// # Errors
    /// The safetensors crate refuses to encode it (a header over its size limit).
    pub fn to_bytes(&self) -> Result<Vec<u8>, String> {
        let entry = json!({
            "format": FORMAT,
            "meta": self.meta,
        });
        let metadata = HashMap::from([(METADATA_KEY.to_string(), entry.to_string())]);
        safetensors::serialize(
            self.arrays.iter().map(|(name, array)| {
                (
                    name,
                    Tensor {
                        array,
                        shape: [array.len()],
                    },
                )
            }),
            Some(metadata),
        )
        .map_err(|e| e.to_string())
    }

    /// Writes the archive atomically as a safetensors file.
    ///
    /// # Errors
    /// I/O failures (the previous file, if any, is left intact), or an archive the
    /// safetensors crate cannot encode.
    pub fn write(&self, path: &Path) -> Result<(), ArchiveError> {
        let p = || path.display().to_string();
        let bytes = self
            .to_bytes()
            .map_err(|msg| ArchiveError::Encode { path: p(), msg })?;
        crate::atomic::write_atomic(path, &bytes)
            .map_err(|source| ArchiveError::Io { path: p(), source })
    }

    /// Reads an archive (see [`from_bytes`](Self::from_bytes)).
    ///
    /// # Errors
    /// I/O failures or a corrupt file.
    pub fn read(path: &Path) -> Result<Self, ArchiveError> {
        let p = path.display().to_string();
        let bytes = crate::bounded::read_bytes(path, crate::bounded::ARRAY_BYTES, "a checkpoint")?;
        Self::from_bytes(&bytes).map_err(|msg| ArchiveError::Corrupt { path: p, msg })
    }

    /// Parses an archive from the bytes of a safetensors file. Every length and offset is
    /// checked against the bytes before an array is copied (see the module documentation for
    /// the checks).
    ///
    /// # Errors
    /// What is wrong with the bytes (the `msg` of [`ArchiveError::Corrupt`]).
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, String> {
        let (n, header) =
            SafeTensors::read_metadata(bytes).map_err(|e| format!("safetensors: {e}"))?;
        // `read_metadata` has checked that the header's `n` bytes follow the length and that
        // the tensors' data fills the rest exactly; the slices below are checked anyway.
        let start = n.checked_add(8).ok_or("header length")?;
        let header_bytes = bytes.get(8..start).ok_or("truncated header")?;
        no_duplicate_keys(header_bytes).map_err(|e| format!("safetensors header: {e}"))?;
        let entry = header
            .metadata()
            .as_ref()
            .and_then(|m| m.get(METADATA_KEY))
            .ok_or_else(|| format!("no `{METADATA_KEY}` entry in the metadata"))?;
        no_duplicate_keys(entry.as_bytes()).map_err(|e| format!("metadata: {e}"))?;
        let entry: Value =
            serde_json::from_str(entry).map_err(|e| format!("metadata JSON: {e}"))?;
        if entry["format"] != FORMAT {
            return Err(format!("metadata format is not `{FORMAT}`"));
        }
        let meta = entry["meta"].clone();
        let data = bytes.get(start..).ok_or("truncated data")?;
        let mut ar = Self::new(meta);
        for name in header.offset_keys() {
            let info = header.info(&name).ok_or("tensor index")?;
            let &[len] = info.shape.as_slice() else {
                return Err(format!(
                    "tensor `{name}` has shape {:?}, not one dimension",
                    info.shape
                ));
            };
            let (start, end) = info.data_offsets;
            let b = data.get(start..end).ok_or("tensor offsets")?;
            let array = match info.dtype {
                Dtype::F32 => Array::F32(
                    b.chunks_exact(4)
                        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                        .collect(),
                ),
                Dtype::U64 => Array::U64(
                    b.chunks_exact(8)
                        .map(|c| u64::from_le_bytes(c.try_into().unwrap_or_default()))
                        .collect(),
                ),
                other => return Err(format!("tensor `{name}` has dtype {other:?}")),
            };
            if array.len() != len {
                return Err(format!("tensor `{name}` has the wrong byte length"));
            }
            ar.arrays.insert(name, array);
        }
        Ok(ar)
    }
}

/// Checks that no JSON object in `json` (at any depth) has a key twice.
fn no_duplicate_keys(json: &[u8]) -> Result<(), String> {
    let mut de = serde_json::Deserializer::from_slice(json);
    UniqueKeys::deserialize(&mut de).map_err(|e| e.to_string())?;
    Ok(())
}

/// A JSON value whose objects, at every depth, have distinct keys (deserializing fails on
/// the first key seen twice). Nesting is bounded by `serde_json`'s recursion limit.
struct UniqueKeys;

impl<'de> Deserialize<'de> for UniqueKeys {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(UniqueKeysVisitor)
    }
}

struct UniqueKeysVisitor;

impl<'de> Visitor<'de> for UniqueKeysVisitor {
    type Value = UniqueKeys;
    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("a JSON value")
    }
    fn visit_bool<E>(self, _: bool) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_i64<E>(self, _: i64) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_u64<E>(self, _: u64) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_f64<E>(self, _: f64) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_str<E>(self, _: &str) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_unit<E>(self) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<UniqueKeys, A::Error> {
        while seq.next_element::<UniqueKeys>()?.is_some() {}
        Ok(UniqueKeys)
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<UniqueKeys, A::Error> {
        let mut seen = BTreeSet::new();
        while let Some(key) = map.next_key::<String>()? {
            if !seen.insert(key.clone()) {
                return Err(serde::de::Error::custom(format!(
                    "the key `{key}` appears twice"
                )));
            }
            map.next_value::<UniqueKeys>()?;
        }
        Ok(UniqueKeys)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(tag: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("evogs-ar-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp");
        dir
    }

    #[test]
    fn round_trip_and_corruption() {
        let dir = tmp("rt");
        let p = dir.join("c.safetensors");
        let mut a = Archive::new(json!({"iteration": 12}));
        a.put_f32("x", &[1.5, -2.0, f32::MIN_POSITIVE]);
        a.put_u64("rng", &[u64::MAX, 7]);
        a.put_f32("empty", &[]);
        a.write(&p).expect("write");
        let b = Archive::read(&p).expect("read");
        assert_eq!(a, b, "round trip");
        let bytes = std::fs::read(&p).expect("bytes");
        assert_eq!(
            bytes,
            a.to_bytes().expect("bytes"),
            "the same bytes each time"
        );
        for cut in [1, 3, 8, bytes.len() - 9] {
            assert!(
                Archive::from_bytes(&bytes[..bytes.len() - cut]).is_err(),
                "truncated by {cut} bytes"
            );
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(Archive::from_bytes(&longer).is_err(), "trailing byte");
        std::fs::write(&p, &bytes[..bytes.len() - 3]).expect("write");
        assert!(Archive::read(&p).is_err(), "truncated file rejected");
        std::fs::remove_dir_all(dir).ok();
    }

    /// The file is a plain safetensors file: the crate reads it on its own, with the names,
    /// dtypes, shapes, values and metadata the archive holds.
    #[test]
    fn the_safetensors_crate_reads_the_file() {
        let dir = tmp("st");
        let p = dir.join("c.safetensors");
        let mut a = Archive::new(json!({"t": 0.1, "n": 3}));
        a.put_f32("a.x", &[1.0, -0.5, 3.25]);
        a.put_u64("b.n", &[u64::MAX, 0]);
        a.write(&p).expect("write");
        let bytes = std::fs::read(&p).expect("bytes");
        let st = SafeTensors::deserialize(&bytes).expect("a safetensors file");
        let mut names = st.names();
        names.sort_unstable();
        assert_eq!(names, ["a.x", "b.n"], "tensor names");
        let x = st.tensor("a.x").expect("a.x");
        assert_eq!((x.dtype(), x.shape()), (Dtype::F32, &[3][..]), "a.x");
        let xs: Vec<f32> = x
            .data()
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect();
        assert_eq!(xs, [1.0, -0.5, 3.25], "a.x values");
        let n = st.tensor("b.n").expect("b.n");
        assert_eq!((n.dtype(), n.shape()), (Dtype::U64, &[2][..]), "b.n");
        assert_eq!(&n.data()[..8], &u64::MAX.to_le_bytes(), "b.n values");
        let (_, header) = SafeTensors::read_metadata(&bytes).expect("header");
        let entry: Value = serde_json::from_str(
            header
                .metadata()
                .as_ref()
                .and_then(|m| m.get(METADATA_KEY))
                .expect("the evogs entry"),
        )
        .expect("JSON");
        assert_eq!(entry["format"], FORMAT, "format");
        assert_eq!(entry["meta"], json!({"t": 0.1, "n": 3}), "metadata");
        std::fs::remove_dir_all(dir).ok();
    }

    /// Metadata floats come back bit for bit: `serde_json` with `float_roundtrip` reads
    /// every float exactly (among these are values its default parser read an ulp off), and
    /// so does the archive.
    #[test]
    fn metadata_floats_round_trip_exactly() {
        let mut rng = evogs_math::rng::SplitMix64::new(7);
        let xs: Vec<f64> = (0..4000)
            .map(|_| {
                let u = rng.next_f64();
                (u - 0.5) * 10f64.powi(i32::try_from(rng.next_u64() % 12).unwrap_or(0) - 6)
            })
            .collect();
        for x in &xs {
            let back: f64 =
                serde_json::from_str(&serde_json::to_string(x).expect("json")).expect("parse");
            assert!(back.to_bits() == x.to_bits(), "{x:e} read back as {back:e}");
        }
        let a = Archive::new(json!({"aabb": [xs[..3], xs[3..6]], "n": 3, "all": xs, "t": 0.25}));
        let b = Archive::from_bytes(&a.to_bytes().expect("bytes")).expect("read");
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
            "every float exactly"
        );
        assert_eq!(a, b, "the whole metadata");
        assert_eq!(b.meta["n"].as_u64(), Some(3), "integers stay integers");
    }

    /// A safetensors file with this header (padded to 8 bytes) and data.
    fn st_raw(header: &str, data: &[u8]) -> Vec<u8> {
        let mut h = header.as_bytes().to_vec();
        h.resize(h.len().next_multiple_of(8), b' ');
        let mut b = (h.len() as u64).to_le_bytes().to_vec();
        b.extend_from_slice(&h);
        b.extend_from_slice(data);
        b
    }

    /// The `__metadata__` entry of an archive with metadata `null`.
    const META: &str =
        r#""__metadata__": {"evogs": "{\"format\": \"evogs archive\", \"meta\": null}"}"#;

    #[test]
    fn hostile_safetensors_headers_are_corrupt() {
        let ok = st_raw(
            &format!(
                r#"{{{META}, "a": {{"dtype": "F32", "shape": [1], "data_offsets": [0, 4]}}}}"#
            ),
            &[0; 4],
        );
        assert_eq!(
            Archive::from_bytes(&ok)
                .expect("the well-formed case")
                .f32("a"),
            Some(&[0.0][..]),
            "control"
        );
        let cases: [(&str, Vec<u8>); 8] = [
            ("huge header length", {
                let mut b = (u64::MAX - 8).to_le_bytes().to_vec();
                b.extend_from_slice(b"{}");
                b
            }),
            (
                "huge shape",
                st_raw(
                    &format!(
                        r#"{{{META}, "a": {{"dtype": "F32", "shape": [{}], "data_offsets": [0, 4]}}}}"#,
                        u64::MAX / 4 + 1
                    ),
                    &[0; 4],
                ),
            ),
            (
                "offsets past the end",
                st_raw(
                    &format!(
                        r#"{{{META}, "a": {{"dtype": "F32", "shape": [4], "data_offsets": [0, 16]}}}}"#
                    ),
                    &[0; 4],
                ),
            ),
            (
                "a name twice",
                st_raw(
                    &format!(
                        r#"{{{META}, "a": {{"dtype": "F32", "shape": [1], "data_offsets": [0, 4]}}, "a": {{"dtype": "F32", "shape": [1], "data_offsets": [0, 4]}}}}"#
                    ),
                    &[0; 4],
                ),
            ),
            (
                "two dimensions",
                st_raw(
                    &format!(
                        r#"{{{META}, "a": {{"dtype": "F32", "shape": [1, 1], "data_offsets": [0, 4]}}}}"#
                    ),
                    &[0; 4],
                ),
            ),
            (
                "another dtype",
                st_raw(
                    &format!(
                        r#"{{{META}, "a": {{"dtype": "I32", "shape": [1], "data_offsets": [0, 4]}}}}"#
                    ),
                    &[0; 4],
                ),
            ),
            (
                "no metadata",
                st_raw(
                    r#"{"a": {"dtype": "F32", "shape": [1], "data_offsets": [0, 4]}}"#,
                    &[0; 4],
                ),
            ),
            (
                "unparseable metadata",
                st_raw(r#"{"__metadata__": {"evogs": "{"}}"#, &[]),
            ),
        ];
        for (what, bytes) in cases {
            assert!(Archive::from_bytes(&bytes).is_err(), "{what}: refused");
        }
    }

    #[test]
    fn from_bytes_reads_what_write_wrote() {
        let dir = tmp("bytes");
        let p = dir.join("c.safetensors");
        let mut a = Archive::new(json!({"t": 0.1}));
        a.put_f32("x", &[1.0, f32::NAN.copysign(-1.0)]);
        a.put_u64("n", &[3]);
        a.put_u64("x2", &[1]);
        a.put_f32("x2", &[2.0]);
        a.write(&p).expect("write");
        let bytes = std::fs::read(&p).expect("bytes");
        let b = Archive::from_bytes(&bytes).expect("parse");
        assert_eq!(b.u64("n"), Some(&[3][..]), "u64 array");
        assert_eq!(b.f32("x2"), Some(&[2.0][..]), "replaced, whatever the type");
        assert_eq!(b.u64("x2"), None, "one array per name");
        assert_eq!(b.first_non_finite(), Some(("x", 1)), "the NaN comes back");
        let e = Archive::read(&dir.join("none.bin")).expect_err("missing file");
        assert!(matches!(e, ArchiveError::Read(_)), "{e}");
        std::fs::remove_dir_all(dir).ok();
    }
}
