//! A strict reader and writer of `NumPy` `.npy` files holding one 2-D float64 matrix (the
//! `poses_bounds.npy` of LLFF / N3DV scenes).
//!
//! The format: the magic `\x93NUMPY`, a major and minor version byte, the header length
//! (2 bytes little-endian in version 1, 4 bytes in versions 2 and 3), a Python dict literal
//! padded with spaces and ended by `\n` (`{'descr': '<f8', 'fortran_order': False, 'shape':
//! (N, 17), }`), then the raw values. Only what a float64 matrix needs is accepted: dtype
//! `<f8` (little-endian float64), a 2-D shape, and exactly `rows × cols × 8` bytes of data;
//! `fortran_order: True` (column-major data) is read too. Anything else is an error naming
//! the file and the problem.
//!
//! Why not a crate (`npyz`, `ndarray-npy`): both read far more of the format than one matrix
//! needs, `ndarray-npy` would bring `ndarray` into the data layer, and neither words its
//! errors in terms of the file the user pointed us at. The header grammar needed here is a
//! few lines, written and tested below.

use std::path::Path;

/// A row-major float64 matrix read from a `.npy` file.
#[derive(Clone, Debug, PartialEq)]
pub struct NpyMatrix {
    /// Number of rows.
    pub rows: usize,
    /// Number of columns.
    pub cols: usize,
    /// The values, row-major (`data[r * cols + c]`).
    pub data: Vec<f64>,
}

/// Why a `.npy` file could not be read or written; names the file.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {msg}")]
pub struct NpyError {
    /// File.
    pub path: String,
    /// What is wrong.
    pub msg: String,
}

const MAGIC: &[u8; 6] = b"\x93NUMPY";

impl NpyMatrix {
    /// Row `r`.
    ///
    /// # Panics
    /// If `r >= rows`.
    #[must_use]
    pub fn row(&self, r: usize) -> &[f64] {
        &self.data[r * self.cols..(r + 1) * self.cols]
    }

    /// Reads a 2-D float64 matrix.
    ///
    /// # Errors
    /// An unreadable file, a bad magic string or version, a malformed header, a dtype other
    /// than `<f8`, a shape that is not 2-D, or data shorter or longer than the shape says.
    pub fn read(path: &Path) -> Result<Self, NpyError> {
        // A pose file holds a few hundred numbers: 256 MiB is far beyond any.
        let bytes = crate::bounded::read_bytes(path, crate::bounded::METADATA_BYTES, "a .npy file")
            .map_err(|e| NpyError {
                path: path.display().to_string(),
                msg: match e {
                    crate::bounded::ReadError::Io { source, .. } => {
                        format!("cannot read: {source}")
                    }
                    other => other
                        .to_string()
                        .replacen(&format!("{}: ", path.display()), "", 1),
                },
            })?;
        Self::parse(&bytes).map_err(|msg| NpyError {
            path: path.display().to_string(),
            msg,
        })
    }

    /// Parses the bytes of a `.npy` file (see [`read`](Self::read)).
    ///
    /// # Errors
    /// A message saying what is wrong.
    pub fn parse(bytes: &[u8]) -> Result<Self, String> {
        if bytes.len() < 10 || &bytes[..6] != MAGIC {
            return Err("not a NumPy .npy file (no \\x93NUMPY magic string)".into());
        }
        let (major, minor) = (bytes[6], bytes[7]);
        let (len, start): (usize, usize) = match major {
            1 => (usize::from(u16::from_le_bytes([bytes[8], bytes[9]])), 10),
            2 | 3 => {
                if bytes.len() < 12 {
                    return Err("truncated .npy header".into());
                }
                let n = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
                (usize::try_from(n).map_err(|_| "header too long")?, 12)
            }
            _ => {
                return Err(format!(
                    ".npy format version {major}.{minor} is not supported"
                ));
            }
        };
        let end = start
            .checked_add(len)
            .filter(|&e| e <= bytes.len())
            .ok_or("truncated .npy header")?;
        let header = std::str::from_utf8(&bytes[start..end])
            .map_err(|_| "the .npy header is not text")?
            .trim_end();
        let descr = dict_value(header, "descr")?;
        let descr = descr.trim().trim_matches(|c| c == '\'' || c == '"');
        if descr != "<f8" {
            return Err(format!(
                "dtype '{descr}' is not supported (expected '<f8': little-endian float64; \
                 save with numpy.save(path, array.astype('<f8')))"
            ));
        }
        let fortran = match dict_value(header, "fortran_order")?.trim() {
            "False" => false,
            "True" => true,
            other => return Err(format!("fortran_order `{other}` is not True or False")),
        };
        let shape = parse_shape(dict_value(header, "shape")?)?;
        let [rows, cols] = shape[..] else {
            return Err(format!(
                "shape {shape:?} is not a 2-D matrix ({} dimensions)",
                shape.len()
            ));
        };
        let data = &bytes[end..];
        let want = rows
            .checked_mul(cols)
            .and_then(|n| n.checked_mul(8))
            .ok_or("shape too large")?;
        if data.len() != want {
            return Err(format!(
                "shape ({rows}, {cols}) needs {want} bytes of float64 data, the file has {}",
                data.len()
            ));
        }
        let values: Vec<f64> = data
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]))
            .collect();
        let data = if fortran {
            // Column-major on disk: value (r, c) at c * rows + r.
            let mut out = vec![0.0; values.len()];
            for r in 0..rows {
                for c in 0..cols {
                    out[r * cols + c] = values[c * rows + r];
                }
            }
            out
        } else {
            values
        };
        Ok(Self { rows, cols, data })
    }

    /// The bytes of a version 1.0 `.npy` file holding this matrix (dtype `<f8`, C order).
    ///
    /// # Panics
    /// If `data.len() != rows * cols`.
    #[must_use]
    pub fn to_bytes(&self) -> Vec<u8> {
        assert_eq!(
            self.data.len(),
            self.rows * self.cols,
            "data length matches the shape"
        );
        let mut header = format!(
            "{{'descr': '<f8', 'fortran_order': False, 'shape': ({}, {}), }}",
            self.rows, self.cols
        );
        // Pad so that magic + version + length + header is a multiple of 64, ending in '\n'.
        let total = 10 + header.len() + 1;
        header.push_str(&" ".repeat((64 - total % 64) % 64));
        header.push('\n');
        let mut out = Vec::with_capacity(10 + header.len() + 8 * self.data.len());
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&[1, 0]);
        let len = u16::try_from(header.len()).unwrap_or(u16::MAX);
        out.extend_from_slice(&len.to_le_bytes());
        out.extend_from_slice(header.as_bytes());
        for v in &self.data {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out
    }

    /// Writes the matrix as a `.npy` file ([`to_bytes`](Self::to_bytes)).
    ///
    /// # Errors
    /// I/O failures, naming the file.
    pub fn write(&self, path: &Path) -> Result<(), NpyError> {
        crate::atomic::write_atomic(path, &self.to_bytes()).map_err(|e| NpyError {
            path: path.display().to_string(),
            msg: format!("cannot write: {e}"),
        })
    }
}

/// The text of `key`'s value in the header dict: from after `'key':` to the next top-level
/// comma (commas inside parentheses belong to the value).
fn dict_value<'a>(header: &'a str, key: &str) -> Result<&'a str, String> {
    let body = header
        .strip_prefix('{')
        .and_then(|h| h.strip_suffix('}'))
        .ok_or("the .npy header is not a dict")?;
    for quote in ['\'', '"'] {
        let k = format!("{quote}{key}{quote}");
        let Some(at) = body.find(&k) else { continue };
        let rest = body[at + k.len()..].trim_start();
        let rest = rest
            .strip_prefix(':')
            .ok_or_else(|| format!("the .npy header has no value for '{key}'"))?;
        let mut depth = 0_i32;
        for (i, ch) in rest.char_indices() {
            match ch {
                '(' => depth += 1,
                ')' => depth -= 1,
                ',' if depth == 0 => return Ok(&rest[..i]),
                _ => {}
            }
        }
        return Ok(rest);
    }
    Err(format!("the .npy header has no '{key}' entry"))
}

/// `(10, 17)` → `[10, 17]`; `(5,)` → `[5]`.
fn parse_shape(s: &str) -> Result<Vec<usize>, String> {
    let inner = s
        .trim()
        .strip_prefix('(')
        .and_then(|t| t.strip_suffix(')'))
        .ok_or_else(|| format!("shape `{}` is not a tuple", s.trim()))?;
    inner
        .split(',')
        .map(str::trim)
        .filter(|t| !t.is_empty())
        .map(|t| {
            t.parse::<usize>()
                .map_err(|_| format!("shape entry `{t}` is not a whole number"))
        })
        .collect()
}

#[cfg(test)]
#[allow(
    clippy::float_cmp,
    reason = "values round-trip through their bit patterns exactly"
)]
mod tests {
    use super::*;

    fn matrix() -> NpyMatrix {
        NpyMatrix {
            rows: 2,
            cols: 3,
            data: vec![1.0, -2.5, 3.25, 1e-300, f64::MAX, 0.1],
        }
    }

    /// The bytes numpy 1.x writes for `np.save(f, np.arange(6.0).reshape(2, 3))`, typed out
    /// from the format description (header padded to 64 bytes in all, ending in a newline).
    fn numpy_bytes(descr: &str, fortran: &str, shape: &str, values: &[f64]) -> Vec<u8> {
        let mut header =
            format!("{{'descr': '{descr}', 'fortran_order': {fortran}, 'shape': {shape}, }}");
        while (10 + header.len() + 1) % 64 != 0 {
            header.push(' ');
        }
        header.push('\n');
        let mut b = b"\x93NUMPY\x01\x00".to_vec();
        b.extend_from_slice(&u16::try_from(header.len()).expect("short").to_le_bytes());
        b.extend_from_slice(header.as_bytes());
        for v in values {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b
    }

    #[test]
    fn round_trip_is_exact_and_aligned() {
        let m = matrix();
        let bytes = m.to_bytes();
        let header_end = bytes.iter().position(|&b| b == b'\n').expect("newline") + 1;
        assert_eq!(header_end % 64, 0, "data starts 64-byte aligned");
        assert_eq!(NpyMatrix::parse(&bytes).expect("parses"), m, "round trip");
        assert_eq!(
            NpyMatrix::parse(&bytes).expect("parses").row(1),
            &[1e-300, f64::MAX, 0.1],
            "row access"
        );
    }

    #[test]
    fn reads_numpy_layouts_and_versions() {
        let vals = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0];
        let c = NpyMatrix::parse(&numpy_bytes("<f8", "False", "(2, 3)", &vals)).expect("C");
        assert_eq!((c.rows, c.cols, c.data.as_slice()), (2, 3, &vals[..]), "C");
        // Fortran order: the same matrix stored column by column.
        let f = NpyMatrix::parse(&numpy_bytes(
            "<f8",
            "True",
            "(2, 3)",
            &[0.0, 3.0, 1.0, 4.0, 2.0, 5.0],
        ))
        .expect("Fortran");
        assert_eq!(f, c, "Fortran order transposed back");
        // Version 2.0: a 4-byte header length.
        let v1 = numpy_bytes("<f8", "False", "(2, 3)", &vals);
        let mut v2 = b"\x93NUMPY\x02\x00".to_vec();
        let hlen = usize::from(u16::from_le_bytes([v1[8], v1[9]]));
        v2.extend_from_slice(&u32::try_from(hlen).expect("small").to_le_bytes());
        v2.extend_from_slice(&v1[10..]);
        assert_eq!(NpyMatrix::parse(&v2).expect("v2"), c, "version 2");
    }

    #[test]
    fn rejects_what_is_not_a_float64_matrix() {
        let vals = [0.0; 6];
        for (bytes, want) in [
            (b"PK\x03\x04 not npy".to_vec(), "magic"),
            (numpy_bytes(">f8", "False", "(2, 3)", &vals), "'>f8'"),
            (numpy_bytes("<f4", "False", "(2, 3)", &vals), "'<f4'"),
            (numpy_bytes("<f8", "False", "(6,)", &vals), "2-D"),
            (numpy_bytes("<f8", "False", "(1, 2, 3)", &vals), "2-D"),
            (
                numpy_bytes("<f8", "False", "(2, 4)", &vals),
                "needs 64 bytes",
            ),
            (
                numpy_bytes("<f8", "Maybe", "(2, 3)", &vals),
                "fortran_order",
            ),
            (numpy_bytes("<f8", "False", "(2, x)", &vals), "`x`"),
        ] {
            let e = NpyMatrix::parse(&bytes).expect_err(want);
            assert!(e.contains(want), "{want}: {e}");
        }
        let mut truncated = numpy_bytes("<f8", "False", "(2, 3)", &vals);
        truncated.truncate(20);
        assert!(
            NpyMatrix::parse(&truncated)
                .expect_err("truncated")
                .contains("truncated"),
            "truncated header"
        );
        let mut v9 = numpy_bytes("<f8", "False", "(2, 3)", &vals);
        v9[6] = 9;
        assert!(
            NpyMatrix::parse(&v9)
                .expect_err("version")
                .contains("version 9"),
            "unknown version"
        );
    }

    #[test]
    fn file_errors_name_the_file() {
        let dir = std::env::temp_dir().join(format!("evogs-npy-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp");
        let p = dir.join("poses_bounds.npy");
        std::fs::write(&p, b"garbage").expect("write");
        let e = NpyMatrix::read(&p).expect_err("garbage");
        assert!(e.to_string().contains("poses_bounds.npy"), "{e}");
        matrix().write(&p).expect("write");
        assert_eq!(
            NpyMatrix::read(&p).expect("read"),
            matrix(),
            "file round trip"
        );
        std::fs::remove_dir_all(dir).ok();
    }
}
