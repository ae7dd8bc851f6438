//! A small PLY reader and writer for vertex tables: point clouds (`points3d.ply`) and the
//! standard 3DGS Gaussian layout (`docs/splatting.md` §15).
//!
//! Reads `ascii` and `binary_little_endian` files with scalar vertex properties of any
//! numeric type (`char`…`double`, also the `int8`…`float64` spellings); list properties and
//! elements other than `vertex` are skipped when they come after the vertices (as in every
//! point-cloud file) and rejected otherwise. Writes binary little-endian `float` tables.
//! Properties are matched **by name**.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

/// A vertex table: named columns of equal length.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlyTable {
    /// Property names, in file order.
    pub names: Vec<String>,
    /// One column per property, all of length `len`.
    pub columns: Vec<Vec<f64>>,
    /// Number of vertices.
    pub len: usize,
}

/// Why a PLY file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum PlyError {
    /// The file could not be opened or read.
    #[error("{path}: cannot read: {source}")]
    Io {
        /// File.
        path: String,
        /// Cause.
        source: std::io::Error,
    },
    /// The file is not a PLY file the reader supports.
    #[error("{path}: malformed PLY: {msg}")]
    Malformed {
        /// File.
        path: String,
        /// What is wrong.
        msg: String,
    },
}

#[derive(Clone, Copy)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }
    const fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }
    fn read_le(self, b: &[u8]) -> f64 {
        match self {
            Self::I8 => f64::from(i8::from_le_bytes([b[0]])),
            Self::U8 => f64::from(b[0]),
            Self::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
            Self::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
            Self::I32 => f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Self::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Self::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Self::F64 => f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]),
        }
    }
}

impl PlyTable {
    /// The column with this property name.
    #[must_use]
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|i| self.columns[i].as_slice())
    }

    /// Reads a PLY file's vertex element.
    ///
    /// # Errors
    /// [`PlyError`] naming the file and the problem.
    pub fn read(path: &Path) -> Result<Self, PlyError> {
        let p = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|source| PlyError::Io {
            path: p.clone(),
            source,
        })?;
        Self::parse(&bytes).map_err(|msg| PlyError::Malformed { path: p, msg })
    }

    /// Parses PLY bytes (see [`read`](Self::read)).
    ///
    /// # Errors
    /// A message describing the problem.
    pub fn parse(bytes: &[u8]) -> Result<Self, String> {
        let end = find_header_end(bytes).ok_or("no `end_header` line")?;
        let header = std::str::from_utf8(&bytes[..end]).map_err(|_| "header is not UTF-8")?;
        let mut lines = header.lines();
        if lines.next().map(str::trim) != Some("ply") {
            return Err("missing the `ply` magic line".into());
        }
        let mut format = None;
        let mut n_vertex = None;
        let mut in_vertex = false;
        let mut seen_vertex = false;
        let mut props: Vec<(String, Scalar)> = Vec::new();
        for line in lines {
            let w: Vec<&str> = line.split_whitespace().collect();
            match w.as_slice() {
                ["format", f, _] => format = Some((*f).to_string()),
                ["element", name, n] => {
                    in_vertex = *name == "vertex";
                    if in_vertex {
                        n_vertex = Some(
                            n.parse::<usize>()
                                .map_err(|_| format!("bad vertex count `{n}`"))?,
                        );
                        seen_vertex = true;
                    } else if !seen_vertex {
                        return Err(format!("element `{name}` before `vertex` is not supported"));
                    }
                }
                ["property", "list", ..] if in_vertex => {
                    return Err("list properties in `vertex` are not supported".into());
                }
                ["property", ty, name] if in_vertex => {
                    let s =
                        Scalar::parse(ty).ok_or_else(|| format!("unknown property type `{ty}`"))?;
                    props.push(((*name).to_string(), s));
                }
                _ => {}
            }
        }
        let n = n_vertex.ok_or("no `element vertex`")?;
        if props.is_empty() {
            return Err("vertex element has no properties".into());
        }
        let body = &bytes[end..];
        let mut columns = vec![Vec::with_capacity(n); props.len()];
        match format.as_deref() {
            Some("ascii") => {
                let text = std::str::from_utf8(body).map_err(|_| "ASCII body is not UTF-8")?;
                let mut tokens = text.split_ascii_whitespace();
                for v in 0..n {
                    for col in &mut columns {
                        let t = tokens
                            .next()
                            .ok_or_else(|| format!("file ends at vertex {v} of {n}"))?;
                        col.push(
                            t.parse::<f64>()
                                .map_err(|_| format!("vertex {v}: `{t}` is not a number"))?,
                        );
                    }
                }
            }
            Some("binary_little_endian") => {
                let stride: usize = props.iter().map(|(_, s)| s.size()).sum();
                if body.len() < stride * n {
                    return Err(format!(
                        "binary body holds {} bytes, {n} vertices need {}",
                        body.len(),
                        stride * n
                    ));
                }
                for rec in body.chunks_exact(stride).take(n) {
                    let mut off = 0;
                    for (col, (_, s)) in columns.iter_mut().zip(&props) {
                        col.push(s.read_le(&rec[off..off + s.size()]));
                        off += s.size();
                    }
                }
            }
            Some(f) => {
                return Err(format!(
                    "format `{f}` is not supported (ascii, binary_little_endian)"
                ));
            }
            None => return Err("no `format` line".into()),
        }
        Ok(Self {
            names: props.into_iter().map(|(n, _)| n).collect(),
            columns,
            len: n,
        })
    }

    /// Writes the table as binary little-endian `float` properties.
    ///
    /// # Errors
    /// I/O errors.
    ///
    /// # Panics
    /// If a column's length differs from `len`.
    pub fn write_binary(&self, path: &Path) -> std::io::Result<()> {
        let mut header = String::from("ply\nformat binary_little_endian 1.0\n");
        let _ = writeln!(header, "element vertex {}", self.len);
        for n in &self.names {
            let _ = writeln!(header, "property float {n}");
        }
        header.push_str("end_header\n");
        let mut out = Vec::with_capacity(header.len() + 4 * self.len * self.names.len());
        out.extend_from_slice(header.as_bytes());
        for c in &self.columns {
            assert_eq!(
                c.len(),
                self.len,
                "column length differs from the table length"
            );
        }
        for v in 0..self.len {
            for c in &self.columns {
                #[allow(
                    clippy::cast_possible_truncation,
                    reason = "PLY float properties are f32"
                )]
                out.extend_from_slice(&(c[v] as f32).to_le_bytes());
            }
        }
        let tmp = path.with_extension("ply.tmp");
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(&out)?;
        f.sync_all()?;
        std::fs::rename(tmp, path)
    }
}

fn find_header_end(bytes: &[u8]) -> Option<usize> {
    let pat = b"end_header";
    let i = bytes.windows(pat.len()).position(|w| w == pat)?;
    // Skip to the end of that line (handles \n and \r\n).
    let nl = bytes[i..].iter().position(|&b| b == b'\n')?;
    Some(i + nl + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ascii_point_cloud() {
        let t = PlyTable::parse(
            b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n\
              property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n\
              0.5 1 -2 255 0 10\n1e-3 2 3 1 2 3\n",
        )
        .expect("valid");
        assert_eq!(t.len, 2, "two vertices");
        assert_eq!(t.column("red"), Some(&[255.0, 1.0][..]), "uchar column");
        assert_eq!(t.column("x"), Some(&[0.5, 1e-3][..]), "float column");
    }

    #[test]
    fn binary_round_trip() {
        let dir = std::env::temp_dir().join(format!("evogs-ply-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp dir");
        let path = dir.join("t.ply");
        let t = PlyTable {
            names: vec!["x".into(), "opacity".into()],
            columns: vec![vec![1.5, -2.25, 3.0], vec![0.5, 0.25, -8.0]],
            len: 3,
        };
        t.write_binary(&path).expect("write");
        let back = PlyTable::read(&path).expect("read");
        assert_eq!(back, t, "binary round trip (values exact in f32)");
        std::fs::remove_dir_all(dir).ok();
    }

    #[test]
    fn malformed_inputs_are_reported() {
        for (bytes, want) in [
            (&b"plx\nend_header\n"[..], "magic"),
            (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1 2\n", "ends at vertex 2"),
            (b"ply\nformat binary_big_endian 1.0\nelement vertex 1\nproperty float x\nend_header\n", "not supported"),
            (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\nabc\n", "not a number"),
        ] {
            let e = PlyTable::parse(bytes).expect_err("must fail");
            assert!(e.contains(want), "error `{e}` should mention `{want}`");
        }
    }
}
