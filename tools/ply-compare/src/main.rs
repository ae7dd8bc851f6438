//! Reads the same PLY files with evogs's reader and with the PLY crates, and reports
//! (1) what each does with hostile headers (in a child process, so an abort is seen) and
//! (2) how long it takes to turn a 1M-vertex binary file and a 1M-row ASCII file into
//! columns. `cargo run --release` from this folder.

use std::collections::HashMap;
use std::io::Cursor;
use std::process::Command;
use std::time::Instant;

/// evogs's reader, compiled here as it is in the crate.
#[path = "../../../evogs/src/data/ply.rs"]
#[allow(dead_code, reason = "the writer is not compared")]
mod ply;

/// The one crate item `ply.rs` uses (by its writer).
mod atomic {
    pub fn write_atomic(path: &std::path::Path, bytes: &[u8]) -> std::io::Result<()> {
        std::fs::write(path, bytes)
    }
}

/// The 3DGS degree-0 vertex layout: 17 `float` properties.
const SPLAT: [&str; 17] = [
    "x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1",
    "scale_2", "rot_0", "rot_1", "rot_2", "rot_3",
];

fn lcg(s: &mut u64) -> f32 {
    *s = s
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*s >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
}

fn binary_file(n: usize) -> Vec<u8> {
    let mut h = format!("ply\nformat binary_little_endian 1.0\nelement vertex {n}\n");
    for p in SPLAT {
        h.push_str(&format!("property float {p}\n"));
    }
    h.push_str("end_header\n");
    let mut b = h.into_bytes();
    let mut s = 1;
    for _ in 0..n * SPLAT.len() {
        b.extend_from_slice(&lcg(&mut s).to_le_bytes());
    }
    b
}

fn ascii_file(n: usize) -> Vec<u8> {
    let mut t = format!(
        "ply\nformat ascii 1.0\nelement vertex {n}\nproperty float x\nproperty float y\n\
         property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n"
    );
    let mut s = 2;
    for i in 0..n {
        let (x, y, z) = (lcg(&mut s), lcg(&mut s), lcg(&mut s));
        t.push_str(&format!(
            "{x} {y} {z} {} {} {}\n",
            i % 256,
            (i / 7) % 256,
            (i / 13) % 256
        ));
    }
    t.into_bytes()
}

// ---- the readers, each turning the bytes into named f64 columns ----

type Columns = Vec<(String, Vec<f64>)>;

fn evogs(b: &[u8]) -> Result<Columns, String> {
    let t = ply::PlyTable::parse(b)?;
    Ok(t.names.into_iter().zip(t.columns).collect())
}

fn prop_f64_bw(p: &ply_rs_bw::ply::Property) -> f64 {
    use ply_rs_bw::ply::Property as P;
    match *p {
        P::Char(v) => v.into(),
        P::UChar(v) => v.into(),
        P::Short(v) => v.into(),
        P::UShort(v) => v.into(),
        P::Int(v) => v.into(),
        P::UInt(v) => v.into(),
        P::Float(v) => v.into(),
        P::Double(v) => v,
        _ => f64::NAN,
    }
}

fn prop_f64_rs(p: &ply_rs::ply::Property) -> f64 {
    use ply_rs::ply::Property as P;
    match *p {
        P::Char(v) => v.into(),
        P::UChar(v) => v.into(),
        P::Short(v) => v.into(),
        P::UShort(v) => v.into(),
        P::Int(v) => v.into(),
        P::UInt(v) => v.into(),
        P::Float(v) => v.into(),
        P::Double(v) => v,
        _ => f64::NAN,
    }
}

/// ply-rs-bw's map-per-vertex `DefaultElement` (the path for columns known by name).
fn bw_default(b: &[u8]) -> Result<Columns, String> {
    let p = ply_rs_bw::parser::Parser::<ply_rs_bw::ply::DefaultElement>::new();
    let ply = p.read_ply(&mut Cursor::new(b)).map_err(|e| e.to_string())?;
    let rows = ply.payload.get("vertex").ok_or("no vertex")?;
    let names: Vec<String> = ply.header.elements["vertex"]
        .properties
        .keys()
        .cloned()
        .collect();
    Ok(names
        .iter()
        .map(|n| (n.clone(), rows.iter().map(|r| prop_f64_bw(&r[n])).collect()))
        .collect())
}

/// ply-rs-bw with a typed row (the fastest path it offers: fixed 3DGS layout, no maps).
#[derive(Default)]
struct Row17([f32; 17]);
impl ply_rs_bw::ply::PropertyAccess for Row17 {
    fn new() -> Self {
        Self::default()
    }
    fn set_float(&mut self, name: &str, v: f32) -> ply_rs_bw::ply::PropertyAccessResult {
        if let Some(i) = SPLAT.iter().position(|p| *p == name) {
            self.0[i] = v;
        }
        ply_rs_bw::ply::PropertyAccessResult::Set
    }
}
fn bw_typed(b: &[u8]) -> Result<Columns, String> {
    let p = ply_rs_bw::parser::Parser::<Row17>::new();
    let ply = p.read_ply(&mut Cursor::new(b)).map_err(|e| e.to_string())?;
    let rows = ply.payload.get("vertex").ok_or("no vertex")?;
    Ok(SPLAT
        .iter()
        .enumerate()
        .map(|(i, n)| {
            (
                n.to_string(),
                rows.iter().map(|r| f64::from(r.0[i])).collect(),
            )
        })
        .collect())
}

/// ply-rs 0.1.3's `DefaultElement`.
fn rs_default(b: &[u8]) -> Result<Columns, String> {
    let p = ply_rs::parser::Parser::<ply_rs::ply::DefaultElement>::new();
    let ply = p.read_ply(&mut Cursor::new(b)).map_err(|e| e.to_string())?;
    let rows = ply.payload.get("vertex").ok_or("no vertex")?;
    let names: Vec<String> = ply.header.elements["vertex"]
        .properties
        .keys()
        .cloned()
        .collect();
    Ok(names
        .iter()
        .map(|n| (n.clone(), rows.iter().map(|r| prop_f64_rs(&r[n])).collect()))
        .collect())
}

/// serde-ply into a typed struct (its intended use; fixed 3DGS layout).
#[derive(serde::Deserialize)]
#[allow(dead_code, reason = "fields read by position below")]
struct SplatRow {
    x: f32,
    y: f32,
    z: f32,
    nx: f32,
    ny: f32,
    nz: f32,
    f_dc_0: f32,
    f_dc_1: f32,
    f_dc_2: f32,
    opacity: f32,
    scale_0: f32,
    scale_1: f32,
    scale_2: f32,
    rot_0: f32,
    rot_1: f32,
    rot_2: f32,
    rot_3: f32,
}
#[derive(serde::Deserialize)]
struct SplatFile {
    vertex: Vec<SplatRow>,
}
fn serde_typed(b: &[u8]) -> Result<Columns, String> {
    let f: SplatFile = serde_ply::from_bytes(b).map_err(|e| e.to_string())?;
    let get = |r: &SplatRow, i: usize| -> f32 {
        [
            r.x, r.y, r.z, r.nx, r.ny, r.nz, r.f_dc_0, r.f_dc_1, r.f_dc_2, r.opacity, r.scale_0,
            r.scale_1, r.scale_2, r.rot_0, r.rot_1, r.rot_2, r.rot_3,
        ][i]
    };
    Ok(SPLAT
        .iter()
        .enumerate()
        .map(|(i, n)| {
            (
                n.to_string(),
                f.vertex.iter().map(|r| f64::from(get(r, i))).collect(),
            )
        })
        .collect())
}

/// serde-ply with a map per row (columns known only by name, as evogs needs).
#[derive(serde::Deserialize)]
struct MapFile {
    vertex: Vec<HashMap<String, f64>>,
}
fn serde_map(b: &[u8]) -> Result<Columns, String> {
    let f: MapFile = serde_ply::from_bytes(b).map_err(|e| e.to_string())?;
    let mut names: Vec<String> = f
        .vertex
        .first()
        .map(|r| r.keys().cloned().collect())
        .unwrap_or_default();
    names.sort();
    Ok(names
        .iter()
        .map(|n| (n.clone(), f.vertex.iter().map(|r| r[n]).collect()))
        .collect())
}

type Reader = fn(&[u8]) -> Result<Columns, String>;
const READERS: [(&str, Reader, bool); 6] = [
    ("evogs ply.rs", evogs, true),
    ("ply-rs-bw 4.0.1 DefaultElement", bw_default, true),
    ("ply-rs-bw 4.0.1 typed row", bw_typed, false),
    ("ply-rs 0.1.3 DefaultElement", rs_default, true),
    ("serde-ply 0.2.2 typed struct", serde_typed, false),
    ("serde-ply 0.2.2 map per row", serde_map, true),
];

/// Hostile or malformed inputs: (name, bytes).
fn cases() -> Vec<(&'static str, Vec<u8>)> {
    let head = |n: &str, fmt: &str| {
        format!(
            "ply\nformat {fmt} 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
        )
    };
    let mut bin1 = head("1", "binary_little_endian").into_bytes();
    bin1.extend_from_slice(&[0; 12]);
    let mut trailing = bin1.clone();
    trailing.extend_from_slice(&[0; 5]);
    let mut nan = head("1", "binary_little_endian").into_bytes();
    for v in [f32::NAN, 0.0, 0.0] {
        nan.extend_from_slice(&v.to_le_bytes());
    }
    let mut huge = head("18446744073709551615", "binary_little_endian").into_bytes();
    huge.extend_from_slice(&[0; 12]);
    let mut big = head("4000000000", "binary_little_endian").into_bytes();
    big.extend_from_slice(&[0; 12]);
    let mut ahuge = head("18446744073709551615", "ascii").into_bytes();
    ahuge.extend_from_slice(b"0 0 0\n");
    let mut list = b"ply\nformat binary_little_endian 1.0\nelement face 1\nproperty list uint int vertex_indices\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n".to_vec();
    list.extend_from_slice(&u32::MAX.to_le_bytes());
    list.extend_from_slice(&[0; 12]);
    let mut ashort = head("2", "ascii").into_bytes();
    ashort.extend_from_slice(b"0 0 0\n1 1\n");
    vec![
        ("vertex count 2^64-1 (binary)", huge),
        ("vertex count 4e9 (binary)", big),
        ("vertex count 2^64-1 (ascii)", ahuge),
        ("list length 2^32-1", list),
        ("5 trailing bytes", trailing),
        ("ascii row short", ashort),
        ("NaN position", nan),
    ]
}

fn child(reader: usize, case: usize) {
    let (_, bytes) = &cases()[case];
    let verdict = match READERS[reader].1(bytes) {
        Ok(c) => format!("accepted ({} rows)", c.first().map_or(0, |c| c.1.len())),
        Err(e) => format!(
            "error: {}",
            e.lines()
                .next()
                .unwrap_or("")
                .chars()
                .take(60)
                .collect::<String>()
        ),
    };
    println!("{verdict}");
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() == 4 && args[1] == "child" {
        child(args[2].parse().unwrap(), args[3].parse().unwrap());
        return;
    }
    let me = std::env::current_exe().unwrap();
    println!("## Hostile and malformed inputs (each in a child process)\n");
    for (ci, (cname, _)) in cases().iter().enumerate() {
        for (ri, (rname, _, _)) in READERS.iter().enumerate() {
            if !READERS[ri].2 {
                continue; // the typed readers hold the 17-property layout, not these files'
            }
            let t = Instant::now();
            let out = Command::new(&me)
                .args(["child", &ri.to_string(), &ci.to_string()])
                .output()
                .unwrap();
            let verdict = if out.status.success() {
                String::from_utf8_lossy(&out.stdout).trim().to_string()
            } else {
                let err = String::from_utf8_lossy(&out.stderr);
                let line = err
                    .lines()
                    .find(|l| {
                        l.contains("panicked") || l.contains("memory") || l.contains("capacity")
                    })
                    .unwrap_or("")
                    .to_string();
                format!(
                    "CRASH ({}) {}",
                    out.status,
                    line.chars().take(90).collect::<String>()
                )
            };
            println!(
                "| {cname} | {rname} | {verdict} | {:.0} ms |",
                t.elapsed().as_secs_f64() * 1e3
            );
        }
    }
    let n: usize = std::env::var("N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let bin = binary_file(n);
    let asc = ascii_file(n);
    println!(
        "\n## Speed: {n} vertices; binary {:.1} MB (17 float), ascii {:.1} MB (3 float + 3 uchar); best of 3\n",
        bin.len() as f64 / 1e6,
        asc.len() as f64 / 1e6
    );
    let reference = evogs(&bin).unwrap();
    for (name, f, by_name) in READERS {
        for (label, bytes) in [("binary", &bin), ("ascii", &asc)] {
            if label == "ascii" && !by_name {
                continue; // the typed readers hold the binary file's layout
            }
            let mut best = f64::INFINITY;
            let mut rows = 0;
            for _ in 0..3 {
                let t = Instant::now();
                let c = f(bytes);
                best = best.min(t.elapsed().as_secs_f64());
                match c {
                    Ok(c) => {
                        rows = c.first().map_or(0, |c| c.1.len());
                        if label == "binary" {
                            let x = &c.iter().find(|c| c.0 == "x").unwrap().1;
                            assert_eq!(x, &reference[0].1, "{name} reads the same x");
                        }
                    }
                    Err(e) => {
                        println!("| {name} | {label} | failed: {e} |");
                        break;
                    }
                }
            }
            println!("| {name} | {label} | {:.0} ms | {rows} rows |", best * 1e3);
        }
    }
}
