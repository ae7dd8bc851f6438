//! The binary forms the viewer's page reads (`docs/viewer.md`, "Binary layout"): the
//! colours and opacities once, then positions, rotations and scales per time. Every number
//! is little-endian; the arrays start on 16-byte boundaries so the page reads them as
//! `Float32Array` views without copying.

use evogs_math::sh::SH_C0;
use evogs_splat::Splats;

/// The first four bytes of a colours-and-opacities file.
pub const STATIC_MAGIC: [u8; 4] = *b"EVGS";
/// The first four bytes of a frame (one time).
pub const FRAME_MAGIC: [u8; 4] = *b"EVGF";
/// The header length of both forms: magic, count (u32), time (f64; 0 in the static form).
pub const HEADER_BYTES: usize = 16;
/// Bytes per Gaussian in a frame: position (3 f32), rotation (4 f32), scale (3 f32).
pub const FRAME_BYTES_PER_GAUSSIAN: usize = 40;
/// Bytes per Gaussian in the static form: red, green, blue, opacity as u8.
pub const STATIC_BYTES_PER_GAUSSIAN: usize = 4;

fn header(out: &mut Vec<u8>, magic: [u8; 4], n: usize, t: f64) {
    out.extend_from_slice(&magic);
    let n32 = u32::try_from(n).unwrap_or(u32::MAX);
    out.extend_from_slice(&n32.to_le_bytes());
    out.extend_from_slice(&t.to_le_bytes());
}

/// A unit interval value as a byte (rounded, clamped).
fn unit_byte(v: f32) -> u8 {
    #[allow(clippy::cast_possible_truncation, reason = "clamped to [0, 255] first")]
    let b = (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    b
}

/// The colours and opacities of `s`, which do not change with time: per Gaussian the
/// view-independent colour `max(0, SH_C0 · dc + ½)` clamped to 1 (the degree-0 term of the
/// rasterizer's colour; higher SH bands are not sent) and the opacity `sigmoid(logit)`, each
/// as a byte.
#[must_use]
pub fn encode_static(s: &Splats<f32>) -> Vec<u8> {
    let n = s.len();
    let mut out = Vec::with_capacity(HEADER_BYTES + STATIC_BYTES_PER_GAUSSIAN * n);
    header(&mut out, STATIC_MAGIC, n, 0.0);
    #[allow(
        clippy::cast_possible_truncation,
        reason = "a constant within f32 range"
    )]
    let c0 = SH_C0 as f32;
    for i in 0..n {
        let dc = s.sh_coeffs(i)[0];
        for c in dc {
            out.push(unit_byte(c0.mul_add(c, 0.5)));
        }
        let a = 1.0 / (1.0 + (-s.opacity_logits[i]).exp());
        out.push(unit_byte(a));
    }
    out
}

/// The moving part of `s` at time `t`: all positions (x, y, z), then all rotations as unit
/// quaternions in the page's order (x, y, z, w), then all scales as standard deviations
/// (`exp` of the log scales), each an f32.
#[must_use]
pub fn encode_frame(s: &Splats<f32>, t: f64) -> Vec<u8> {
    let n = s.len();
    let mut out = Vec::with_capacity(HEADER_BYTES + FRAME_BYTES_PER_GAUSSIAN * n);
    header(&mut out, FRAME_MAGIC, n, t);
    for m in &s.means {
        for v in m.to_array() {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    for q in &s.quats {
        let [w, x, y, z] = q.to_array();
        let norm = (w * w + x * x + y * y + z * z).sqrt();
        let k = if norm > 0.0 { 1.0 / norm } else { 0.0 };
        let unit = if norm > 0.0 {
            [x * k, y * k, z * k, w * k]
        } else {
            [0.0, 0.0, 0.0, 1.0]
        };
        for v in unit {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    for ls in &s.log_scales {
        for v in ls.to_array() {
            out.extend_from_slice(&v.exp().to_le_bytes());
        }
    }
    out
}

#[cfg(test)]
#[allow(
    clippy::float_cmp,
    reason = "exact values written and read back bit for bit"
)]
mod tests {
    use super::*;
    use evogs_math::{Quat, Vec3};

    fn f32_at(b: &[u8], i: usize) -> f32 {
        f32::from_le_bytes(b[i..i + 4].try_into().expect("four bytes"))
    }

    fn two() -> Splats<f32> {
        let mut s = Splats::zeros(2, 0);
        s.means = vec![Vec3::new(1.0, 2.0, 3.0), Vec3::new(-4.0, 5.0, -6.0)];
        s.quats = vec![
            Quat::from_array([2.0, 0.0, 0.0, 0.0]),
            Quat::from_array([0.0, 0.0, 3.0, 4.0]),
        ];
        s.log_scales = vec![Vec3::new(0.0, 1.0, -1.0), Vec3::new(0.5, 0.5, 0.5)];
        s.opacity_logits = vec![0.0, 100.0];
        s.sh = vec![[0.0, 10.0, -10.0], [1.0, 1.0, 1.0]];
        s
    }

    #[test]
    fn a_frame_holds_positions_then_unit_rotations_then_scales() {
        let b = encode_frame(&two(), -0.25);
        assert_eq!(b.len(), HEADER_BYTES + 2 * FRAME_BYTES_PER_GAUSSIAN);
        assert_eq!(&b[..4], b"EVGF");
        assert_eq!(u32::from_le_bytes(b[4..8].try_into().expect("u32")), 2);
        assert_eq!(f64::from_le_bytes(b[8..16].try_into().expect("f64")), -0.25);
        assert_eq!(f32_at(&b, 16 + 4 * 3), -4.0, "second position's x");
        let q = 16 + 24;
        assert_eq!(
            f32_at(&b, q + 12),
            1.0,
            "first rotation: w last, normalised"
        );
        let q2: Vec<f32> = (0..4).map(|k| f32_at(&b, q + 16 + 4 * k)).collect();
        assert!(
            (q2[1] - 0.6).abs() < 1e-6 && (q2[2] - 0.8).abs() < 1e-6,
            "{q2:?}"
        );
        let sc = q + 32;
        assert!(
            (f32_at(&b, sc + 4) - 1f32.exp()).abs() < 1e-6,
            "scales are exp(log)"
        );
    }

    #[test]
    fn static_form_has_clamped_dc_colours_and_sigmoid_opacities() {
        let b = encode_static(&two());
        assert_eq!(b.len(), HEADER_BYTES + 2 * STATIC_BYTES_PER_GAUSSIAN);
        assert_eq!(&b[..4], b"EVGS");
        assert_eq!(
            &b[16..20],
            &[128, 255, 0, 128],
            "½ grey, clamped, sigmoid(0)"
        );
        let c = ((SH_C0 + 0.5) * 255.0).round();
        assert_eq!(f64::from(b[20]), c);
        assert_eq!(b[23], 255);
    }
}
