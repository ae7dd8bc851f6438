//! A small PLY reader and writer for vertex tables: point clouds (`points3d.ply`) and the
//! standard 3DGS Gaussian layout (`docs/splatting.md` §15).
//!
//! Reads `ascii` and `binary_little_endian` files (format version 1.0). The `vertex` element
//! must have scalar properties of any numeric type (`char`…`double`, also the
//! `int8`…`float64` spellings); other elements, with scalar or list properties, may come
//! before or after it and are checked and skipped. Writes binary little-endian `float`
//! tables. Properties are matched **by name**.
//!
//! The reader is strict, because its input comes from other tools and a bad table otherwise
//! surfaces much later as a NaN in training:
//! - the sizes the header declares are checked against the body, with checked arithmetic,
//!   **before** anything is allocated (a header declaring 4·10⁹ vertices fails at once);
//! - a binary body must end exactly after the last element, an ASCII body must hold exactly
//!   one row per declared record, each with exactly its properties' values;
//! - integer properties must be integers within their type, and every vertex value must be
//!   finite; the positions `x`, `y`, `z` must lie within ±[`MAX_POSITION`];
//! - errors are one line naming the element, the row and the property where there is one.
//!
//! Why not a PLY crate (measured with `tools/ply-compare`, which compiles this file beside
//! the candidates and reads the same bytes with each; release build, best of 3, on the
//! project's 2-core machine):
//!
//! | reader | 1M vertices, binary (17 `float`, 68 MB) | 1M rows, ASCII (3 `float` + 3 `uchar`, 44 MB) |
//! | --- | --- | --- |
//! | this reader (columns by name) | **134 ms** | **179 ms** |
//! | `ply-rs-bw` 4.0.1, `DefaultElement` (a map per vertex) | 8200 ms | 1955 ms |
//! | `ply-rs-bw` 4.0.1, typed row (fixed 17 fields) | 200 ms | — |
//! | `ply-rs` 0.1.3, `DefaultElement` | 6980 ms | 2668 ms |
//! | `serde-ply` 0.2.2, a map per row | 6273 ms | 1615 ms |
//! | `serde-ply` 0.2.2, typed struct (fixed 17 fields) | 183 ms | — |
//!
//! - Speed: evogs needs columns found by name (the 3DGS layout has 3·(d+1)² SH columns,
//!   so the property list depends on the file). The crates' by-name paths (a map per
//!   vertex) are 47–61× slower on binary and 9–15× on ASCII; their fastest paths need the
//!   layout fixed at compile time and are still 1.4–1.5× slower.
//! - Safety: all three fail cleanly, without allocating, on a header declaring 2⁶⁴−1 or
//!   4·10⁹ vertices (binary and ASCII), and the two `ply-rs` on a list declaring 2³²−1
//!   entries: they stream and stop at the end of the body (`ply-rs-bw` also caps its
//!   pre-allocation). But all three accept trailing bytes after the last element and NaN
//!   values, so the checks above would stay as a layer on top.
//! - Maintenance: `ply-rs` has had no release since 2020; `ply-rs-bw` (its maintained fork,
//!   whose 4.x needs Rust 1.87) and `serde-ply` are recent.
//!
//! No candidate is as fast for this use, so the reader stays hand-written: small, fuzzed
//! (`fuzz/`, target `ply_parse`) and tested below and in `evogs-cli/tests/suite/hostile.rs`.

use std::fmt::Write as _;
use std::path::Path;

/// Largest magnitude accepted for the position properties `x`, `y` and `z`: scenes are
/// normalised to a few units, so anything beyond is a corrupt or foreign file.
pub const MAX_POSITION: f64 = 1e6;

/// The properties holding positions (checked against [`MAX_POSITION`]).
const POSITION_NAMES: [&str; 3] = ["x", "y", "z"];

/// Longest excerpt of the input quoted in an error message.
const QUOTE_CHARS: usize = 40;

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
    /// The path is not a regular file, or is larger than a point cloud can be.
    #[error(transparent)]
    Read(#[from] crate::bounded::ReadError),
    /// The file is not a PLY file the reader supports, or holds values it rejects.
    #[error("{path}: malformed PLY: {msg}")]
    Malformed {
        /// File.
        path: String,
        /// What is wrong.
        msg: String,
    },
}

/// The body encodings the reader supports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Ascii,
    BinaryLittleEndian,
}

/// A PLY scalar type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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

    /// The PLY spelling.
    const fn name(self) -> &'static str {
        match self {
            Self::I8 => "char",
            Self::U8 => "uchar",
            Self::I16 => "short",
            Self::U16 => "ushort",
            Self::I32 => "int",
            Self::U32 => "uint",
            Self::F32 => "float",
            Self::F64 => "double",
        }
    }

    const fn is_integer(self) -> bool {
        !matches!(self, Self::F32 | Self::F64)
    }

    /// The value of `b`, which holds exactly [`size`](Self::size) bytes.
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

    /// An ASCII token of this type: integers must be integers within the type's range.
    fn parse_ascii(self, t: &str) -> Option<f64> {
        let int = |lo: i64, hi: i64| {
            t.parse::<i64>()
                .ok()
                .filter(|v| (lo..=hi).contains(v))
                .map(|v| v as f64)
        };
        match self {
            Self::I8 => int(i64::from(i8::MIN), i64::from(i8::MAX)),
            Self::U8 => int(0, i64::from(u8::MAX)),
            Self::I16 => int(i64::from(i16::MIN), i64::from(i16::MAX)),
            Self::U16 => int(0, i64::from(u16::MAX)),
            Self::I32 => int(i64::from(i32::MIN), i64::from(i32::MAX)),
            Self::U32 => int(0, i64::from(u32::MAX)),
            // Read as `f64` (the value the text names), but within the `float` range.
            Self::F32 => t
                .parse::<f64>()
                .ok()
                .filter(|v| !v.is_finite() || v.abs() <= f64::from(f32::MAX)),
            Self::F64 => t.parse::<f64>().ok(),
        }
    }
}

/// A property of an element.
#[derive(Clone, Debug)]
enum Property {
    /// One value.
    Scalar { name: String, ty: Scalar },
    /// A length of integer type `count`, then that many values of type `item`.
    List {
        name: String,
        count: Scalar,
        item: Scalar,
    },
}

impl Property {
    fn name(&self) -> &str {
        match self {
            Self::Scalar { name, .. } | Self::List { name, .. } => name,
        }
    }

    /// The fewest bytes a binary record of this property takes (an empty list).
    const fn min_size(&self) -> usize {
        match self {
            Self::Scalar { ty, .. } => ty.size(),
            Self::List { count, .. } => count.size(),
        }
    }
}

/// An element declared in the header.
#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
}

impl Element {
    fn has_lists(&self) -> bool {
        self.props
            .iter()
            .any(|p| matches!(p, Property::List { .. }))
    }
}

/// The parsed header.
#[derive(Debug)]
struct Header {
    format: Format,
    elements: Vec<Element>,
    /// Index of the `vertex` element in `elements`.
    vertex: usize,
    /// Offset of the body in the file.
    body_start: usize,
}

/// `s` for an error message: at most [`QUOTE_CHARS`] characters.
fn quote(s: &str) -> String {
    if s.chars().count() <= QUOTE_CHARS {
        s.to_string()
    } else {
        let mut q: String = s.chars().take(QUOTE_CHARS).collect();
        q.push('…');
        q
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

    /// Reads a PLY file's vertex element (see [`parse`](Self::parse)).
    ///
    /// # Errors
    /// [`PlyError`], one line naming the file and the problem.
    pub fn read(path: &Path) -> Result<Self, PlyError> {
        let p = path.display().to_string();
        let bytes = crate::bounded::read_bytes(path, crate::bounded::ARRAY_BYTES, "a PLY file")?;
        Self::parse(&bytes).map_err(|msg| PlyError::Malformed { path: p, msg })
    }

    /// Parses PLY bytes: the header, then every element of the body, keeping the `vertex`
    /// element's columns (the checks are listed in the [module documentation](self)).
    ///
    /// # Errors
    /// A one-line message describing the problem and where it is.
    pub fn parse(bytes: &[u8]) -> Result<Self, String> {
        let h = parse_header(bytes)?;
        let body = &bytes[h.body_start..];
        let columns = match h.format {
            Format::Ascii => read_ascii(&h, body)?,
            Format::BinaryLittleEndian => read_binary(&h, body)?,
        };
        let vertex = &h.elements[h.vertex];
        Ok(Self {
            names: vertex.props.iter().map(|p| p.name().to_string()).collect(),
            columns,
            len: vertex.count,
        })
    }

    /// Writes the table as binary little-endian `float` properties.
    ///
    /// # Errors
    /// I/O errors; a property name that is empty, holds whitespace or repeats
    /// ([`std::io::ErrorKind::InvalidInput`]: the file could not be read back).
    ///
    /// # Panics
    /// If a column's length differs from `len`.
    pub fn write_binary(&self, path: &Path) -> std::io::Result<()> {
        for (i, n) in self.names.iter().enumerate() {
            if n.is_empty() || n.contains(char::is_whitespace) || self.names[..i].contains(n) {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    format!("{}: bad PLY property name `{}`", path.display(), quote(n)),
                ));
            }
        }
        let mut header = String::from("ply\nformat binary_little_endian 1.0\n");
        let _ = writeln!(header, "element vertex {}", self.len);
        for n in &self.names {
            let _ = writeln!(header, "property float {n}");
        }
        header.push_str("end_header\n");
        for c in &self.columns {
            assert_eq!(
                c.len(),
                self.len,
                "column length differs from the table length"
            );
        }
        let body = self.len.saturating_mul(4).saturating_mul(self.names.len());
        let mut out = Vec::with_capacity(header.len().saturating_add(body));
        out.extend_from_slice(header.as_bytes());
        for v in 0..self.len {
            for c in &self.columns {
                #[allow(
                    clippy::cast_possible_truncation,
                    reason = "PLY float properties are f32"
                )]
                out.extend_from_slice(&(c[v] as f32).to_le_bytes());
            }
        }
        crate::atomic::write_atomic(path, &out)
    }
}

/// Reads the header up to and including its `end_header` line.
fn parse_header(bytes: &[u8]) -> Result<Header, String> {
    let mut pos = 0;
    let mut line_no = 0usize;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let rest = &bytes[pos..];
        let nl = rest
            .iter()
            .position(|&b| b == b'\n')
            .ok_or("no `end_header` line")?;
        let raw = &rest[..nl];
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        pos += nl + 1;
        line_no += 1;
        let line =
            std::str::from_utf8(raw).map_err(|_| format!("header line {line_no} is not UTF-8"))?;
        let w: Vec<&str> = line.split_whitespace().collect();
        if line_no == 1 {
            if w != ["ply"] {
                return Err("missing the `ply` magic line".into());
            }
            continue;
        }
        let at = |msg: String| format!("header line {line_no}: {msg}");
        match w.as_slice() {
            ["end_header"] => break,
            [] | ["comment" | "obj_info", ..] => {}
            ["format", f, version] => {
                if format.is_some() {
                    return Err(at("a second `format` line".into()));
                }
                if !matches!(*version, "1.0" | "1") {
                    return Err(at(format!("version `{}` is not 1.0", quote(version))));
                }
                format = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::BinaryLittleEndian,
                    _ => {
                        return Err(at(format!(
                            "format `{}` is not supported (ascii, binary_little_endian)",
                            quote(f)
                        )));
                    }
                });
            }
            ["element", name, n] => {
                if elements.iter().any(|e| e.name == *name) {
                    return Err(at(format!("a second element `{}`", quote(name))));
                }
                let count = n.parse::<usize>().map_err(|_| {
                    at(format!(
                        "bad count `{}` for element `{}`",
                        quote(n),
                        quote(name)
                    ))
                })?;
                elements.push(Element {
                    name: (*name).to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            ["property", "list", count, item, name] => {
                let e = elements
                    .last_mut()
                    .ok_or_else(|| at("a property before any element".into()))?;
                let ty = |t: &str| {
                    Scalar::parse(t)
                        .ok_or_else(|| at(format!("unknown property type `{}`", quote(t))))
                };
                let (count, item) = (ty(count)?, ty(item)?);
                if !count.is_integer() {
                    return Err(at("a list length must have an integer type".into()));
                }
                if e.name == "vertex" {
                    return Err(at("list properties in `vertex` are not supported".into()));
                }
                e.props.push(Property::List {
                    name: (*name).to_string(),
                    count,
                    item,
                });
            }
            ["property", ty, name] => {
                let e = elements
                    .last_mut()
                    .ok_or_else(|| at("a property before any element".into()))?;
                let ty = Scalar::parse(ty)
                    .ok_or_else(|| at(format!("unknown property type `{}`", quote(ty))))?;
                if e.props.iter().any(|p| p.name() == *name) {
                    return Err(at(format!(
                        "a second property `{}` in element `{}`",
                        quote(name),
                        quote(&e.name)
                    )));
                }
                e.props.push(Property::Scalar {
                    name: (*name).to_string(),
                    ty,
                });
            }
            _ => return Err(at(format!("unrecognised line `{}`", quote(line)))),
        }
    }
    let format = format.ok_or("no `format` line")?;
    if let Some(e) = elements.iter().find(|e| e.props.is_empty()) {
        return Err(format!("element `{}` has no properties", quote(&e.name)));
    }
    let vertex = elements
        .iter()
        .position(|e| e.name == "vertex")
        .ok_or("no `element vertex`")?;
    Ok(Header {
        format,
        elements,
        vertex,
        body_start: pos,
    })
}

/// Checks a vertex value: finite, and within ±[`MAX_POSITION`] for a position.
fn vertex_value(name: &str, row: usize, v: f64) -> Result<f64, String> {
    if !v.is_finite() {
        return Err(format!(
            "vertex {row}, property `{}`: {v} is not finite",
            quote(name)
        ));
    }
    if POSITION_NAMES.contains(&name) && v.abs() > MAX_POSITION {
        return Err(format!(
            "vertex {row}, property `{}`: {v:e} is beyond ±{MAX_POSITION:e}, not a plausible \
             position",
            quote(name)
        ));
    }
    Ok(v)
}

/// `n` empty columns, each with room for `len` values.
fn empty_columns(n: usize, len: usize) -> Vec<Vec<f64>> {
    (0..n).map(|_| Vec::with_capacity(len)).collect()
}

/// The next `n` bytes of `body` from `*pos`, advancing `*pos`.
fn take<'a>(body: &'a [u8], pos: &mut usize, n: usize) -> Option<&'a [u8]> {
    let end = pos.checked_add(n)?;
    let b = body.get(*pos..end)?;
    *pos = end;
    Some(b)
}

/// Walks a binary little-endian body; returns the vertex columns.
fn read_binary(h: &Header, body: &[u8]) -> Result<Vec<Vec<f64>>, String> {
    let mut pos = 0;
    let mut columns = Vec::new();
    for (ei, e) in h.elements.iter().enumerate() {
        let name = quote(&e.name);
        let min = e.props.iter().map(Property::min_size).sum::<usize>();
        let rem = body.len() - pos;
        let need = e.count.checked_mul(min);
        if need.is_none_or(|n| n > rem) {
            return Err(format!(
                "{} `{name}` records need {} bytes, the binary body has {rem} left",
                e.count,
                need.map_or_else(|| "more than usize::MAX".to_string(), |n| n.to_string())
            ));
        }
        let end = |row: usize| format!("the binary body ends in `{name}` record {row}");
        if ei == h.vertex {
            // Sized above: `count · min ≤ body.len()`, so this allocation is bounded by the file.
            columns = empty_columns(e.props.len(), e.count);
            for row in 0..e.count {
                for (col, p) in columns.iter_mut().zip(&e.props) {
                    let Property::Scalar { name, ty } = p else {
                        return Err("list properties in `vertex` are not supported".into());
                    };
                    let b = take(body, &mut pos, ty.size()).ok_or_else(|| end(row))?;
                    col.push(vertex_value(name, row, ty.read_le(b))?);
                }
            }
        } else if !e.has_lists() {
            pos += need.unwrap_or(rem);
        } else {
            // Every record takes at least one byte (the properties are not empty and a list
            // has a length), so this loop is bounded by the body's size.
            for row in 0..e.count {
                for p in &e.props {
                    match p {
                        Property::Scalar { ty, .. } => {
                            take(body, &mut pos, ty.size()).ok_or_else(|| end(row))?;
                        }
                        Property::List {
                            name: pn,
                            count,
                            item,
                        } => {
                            let b = take(body, &mut pos, count.size()).ok_or_else(|| end(row))?;
                            let n = count.read_le(b);
                            let bytes = list_len(n)
                                .and_then(|n| n.checked_mul(item.size()))
                                .ok_or_else(|| {
                                    format!(
                                        "`{name}` record {row}, list `{}`: bad length {n}",
                                        quote(pn)
                                    )
                                })?;
                            take(body, &mut pos, bytes).ok_or_else(|| end(row))?;
                        }
                    }
                }
            }
        }
    }
    if pos != body.len() {
        return Err(format!(
            "{} trailing bytes after the last element",
            body.len() - pos
        ));
    }
    Ok(columns)
}

/// A list length read as `f64` from an integer type: a non-negative integer.
fn list_len(n: f64) -> Option<usize> {
    if n >= 0.0 && n <= f64::from(u32::MAX) {
        #[allow(
            clippy::cast_possible_truncation,
            reason = "an integer in [0, u32::MAX], read from an integer property"
        )]
        Some(n as usize)
    } else {
        None
    }
}

/// Walks an ASCII body: one non-blank line per record; returns the vertex columns.
fn read_ascii(h: &Header, body: &[u8]) -> Result<Vec<Vec<f64>>, String> {
    let text = std::str::from_utf8(body).map_err(|_| "ASCII body is not UTF-8")?;
    let rows: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
    let declared = h
        .elements
        .iter()
        .try_fold(0usize, |acc, e| acc.checked_add(e.count));
    match declared {
        Some(d) if d == rows.len() => {}
        Some(d) if d < rows.len() => {
            return Err(format!(
                "{} rows after the last element (the header declares {d})",
                rows.len() - d
            ));
        }
        _ => {
            return Err(format!(
                "the header declares {} rows, the body holds {}",
                declared.map_or_else(|| "more than usize::MAX".to_string(), |d| d.to_string()),
                rows.len()
            ));
        }
    }
    let mut rows = rows.into_iter();
    let mut columns = Vec::new();
    for (ei, e) in h.elements.iter().enumerate() {
        let name = quote(&e.name);
        if ei == h.vertex {
            // Sized above: `count` is at most the number of lines of the body.
            columns = empty_columns(e.props.len(), e.count);
        }
        for row in 0..e.count {
            let line = rows.next().ok_or("fewer rows than declared")?;
            let mut tokens = line.split_ascii_whitespace();
            let at = |msg: String| format!("`{name}` row {row}: {msg}");
            let mut value = |ty: Scalar, prop: &str| -> Result<f64, String> {
                let t = tokens.next().ok_or_else(|| {
                    at(format!("missing the value of property `{}`", quote(prop)))
                })?;
                ty.parse_ascii(t).ok_or_else(|| {
                    at(format!(
                        "`{}` is not a valid `{}` (property `{}`)",
                        quote(t),
                        ty.name(),
                        quote(prop)
                    ))
                })
            };
            for (pi, p) in e.props.iter().enumerate() {
                match p {
                    Property::Scalar { name: pn, ty } => {
                        let v = value(*ty, pn)?;
                        if ei == h.vertex {
                            columns[pi].push(vertex_value(pn, row, v)?);
                        }
                    }
                    Property::List {
                        name: pn,
                        count,
                        item,
                    } => {
                        let n = value(*count, pn)?;
                        let n = list_len(n).ok_or_else(|| {
                            at(format!("bad list length {n} (property `{}`)", quote(pn)))
                        })?;
                        for _ in 0..n {
                            value(*item, pn)?;
                        }
                    }
                }
            }
            let extra = tokens.count();
            if extra > 0 {
                return Err(at(format!(
                    "{extra} values beyond the element's {} properties",
                    e.props.len()
                )));
            }
        }
    }
    Ok(columns)
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
            (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1\n2\n", "declares 3 rows, the body holds 2"),
            (b"ply\nformat binary_big_endian 1.0\nelement vertex 1\nproperty float x\nend_header\n", "not supported"),
            (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\nabc\n", "`abc` is not a valid `float`"),
        ] {
            let e = PlyTable::parse(bytes).expect_err("must fail");
            assert!(e.contains(want), "error `{e}` should mention `{want}`");
        }
    }

    /// A binary header for `n` vertices of one `float x` property, with `body` after it.
    fn binary_x(n: &str, body: &[u8]) -> Vec<u8> {
        let mut b = format!(
            "ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty float x\nend_header\n"
        )
        .into_bytes();
        b.extend_from_slice(body);
        b
    }

    fn expect_err(bytes: &[u8], want: &str) {
        let e = PlyTable::parse(bytes).expect_err("must fail");
        assert!(e.contains(want), "error `{e}` should mention `{want}`");
        assert!(!e.contains('\n'), "error `{e}` must be one line");
    }

    #[test]
    fn huge_vertex_count_fails_before_allocating() {
        for n in ["4000000000", "18446744073709551615"] {
            expect_err(&binary_x(n, &[0; 8]), "`vertex` records need");
            let ascii = format!(
                "ply\nformat ascii 1.0\nelement vertex {n}\nproperty float x\nend_header\n1\n"
            );
            expect_err(ascii.as_bytes(), "rows");
        }
    }

    #[test]
    fn trailing_bytes_after_binary_body_are_rejected() {
        let ok = binary_x("1", &1.5f32.to_le_bytes());
        assert_eq!(
            PlyTable::parse(&ok).expect("exact body").column("x"),
            Some(&[1.5][..]),
            "one vertex"
        );
        let mut extra = ok;
        extra.push(0);
        expect_err(&extra, "trailing");
    }

    #[test]
    fn ascii_rows_must_have_every_column_and_no_more() {
        let head = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nend_header\n";
        expect_err(format!("{head}1 2 3\n4\n").as_bytes(), "row 0");
        expect_err(format!("{head}1\n2 3\n").as_bytes(), "row 0");
        expect_err(
            format!("{head}1 2\n3 4\n5 6\n").as_bytes(),
            "after the last element",
        );
    }

    #[test]
    fn non_finite_values_are_rejected_with_row_and_column() {
        let head = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float red\nend_header\n";
        expect_err(
            format!("{head}1 2\n3 nan\n").as_bytes(),
            "vertex 1, property `red`",
        );
        expect_err(
            format!("{head}inf 2\n3 4\n").as_bytes(),
            "vertex 0, property `x`",
        );
        expect_err(&binary_x("1", &f32::NAN.to_le_bytes()), "not finite");
    }

    #[test]
    fn absurd_positions_are_rejected_with_row_and_column() {
        let head = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float z\nend_header\n";
        expect_err(
            format!("{head}1 2\n3 -2e6\n").as_bytes(),
            "vertex 1, property `z`",
        );
        assert!(
            PlyTable::parse(format!("{head}1 2\n3 -1e6\n").as_bytes()).is_ok(),
            "1e6 is still a position"
        );
    }

    #[test]
    fn read_names_the_file_in_one_line() {
        let dir = std::env::temp_dir().join(format!("evogs-ply-err-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp dir");
        let path = dir.join("bad.ply");
        std::fs::write(&path, binary_x("4000000000", &[])).expect("write");
        let e = PlyTable::read(&path).expect_err("must fail").to_string();
        assert!(
            e.starts_with(&path.display().to_string()),
            "`{e}` names the file"
        );
        assert!(!e.contains('\n'), "`{e}` is one line");
        std::fs::remove_dir_all(dir).ok();
    }

    #[test]
    fn other_elements_are_walked_and_checked() {
        // A face element with lists after the vertices, and a scalar element before them.
        let ascii = "ply\nformat ascii 1.0\ncomment made by hand\nelement camera 1\nproperty float f\n\
                     element vertex 2\nproperty float x\nproperty uchar red\n\
                     element face 2\nproperty list uchar int vertex_indices\nend_header\n\
                     0.5\n1 2\n3 4\n3 0 1 1\n0\n";
        let t = PlyTable::parse(ascii.as_bytes()).expect("valid");
        assert_eq!(
            t.column("x"),
            Some(&[1.0, 3.0][..]),
            "vertex column after a camera"
        );
        expect_err(
            ascii.replace("\n3 0 1 1\n", "\n3 0 1\n").as_bytes(),
            "`face` row 0",
        );
        expect_err(ascii.replace("\n0\n", "\n0 7\n").as_bytes(), "`face` row 1");
        expect_err(
            ascii.replace("1 2\n", "1 256\n").as_bytes(),
            "`256` is not a valid `uchar`",
        );
        expect_err(
            ascii.replace("3 0 1 1", "-1 0 1 1").as_bytes(),
            "`face` row 0",
        );

        let mut bin =
            b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty double x\n\
                        element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                .to_vec();
        bin.extend_from_slice(&2.5f64.to_le_bytes());
        bin.push(2);
        bin.extend_from_slice(&[0; 8]);
        assert_eq!(
            PlyTable::parse(&bin).expect("valid").column("x"),
            Some(&[2.5][..]),
            "vertex column before a face list"
        );
        let mut long = bin.clone();
        long.push(0);
        expect_err(&long, "1 trailing bytes");
        bin.pop();
        expect_err(&bin, "ends in `face` record 0");
    }

    #[test]
    fn header_lines_are_checked() {
        let body = "end_header\n1\n";
        for (head, want) in [
            (
                "ply\nformat ascii 2.0\nelement vertex 1\nproperty float x\n",
                "version",
            ),
            (
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float x\n",
                "a second property `x`",
            ),
            (
                "ply\nformat ascii 1.0\nproperty float x\nelement vertex 1\n",
                "before any element",
            ),
            (
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty half x\n",
                "unknown property type",
            ),
            (
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nbogus\n",
                "unrecognised line",
            ),
            (
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty list float int x\n",
                "integer type",
            ),
            (
                "ply\nformat ascii 1.0\nelement vertex -1\nproperty float x\n",
                "bad count",
            ),
            (
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nelement e 0\n",
                "no properties",
            ),
        ] {
            expect_err(format!("{head}{body}").as_bytes(), want);
        }
        let crlf = "ply\r\nformat ascii 1.0\r\nelement vertex 1\r\nproperty float x\r\nend_header\r\n1\r\n";
        assert!(PlyTable::parse(crlf.as_bytes()).is_ok(), "CRLF line ends");
    }

    #[test]
    fn write_refuses_names_it_could_not_read_back() {
        let dir = std::env::temp_dir().join(format!("evogs-ply-names-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp dir");
        for names in [
            vec!["a b".to_string()],
            vec![String::new()],
            vec!["x".into(), "x".into()],
        ] {
            let t = PlyTable {
                columns: vec![vec![1.0]; names.len()],
                names,
                len: 1,
            };
            let e = t.write_binary(&dir.join("t.ply")).expect_err("bad name");
            assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput, "{e}");
        }
        std::fs::remove_dir_all(dir).ok();
    }
}
