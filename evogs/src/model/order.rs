//! The spatial order of the Gaussians: sorted along a Z-order (Morton) curve of their
//! canonical positions, so that Gaussians next to each other in memory are near each other
//! in space. The neural field works on consecutive Gaussians a chunk at a time; in this
//! order the HexPlane texels that a chunk reads overlap and stay in cache (`docs/performance.md`).
//! Training reorders the Gaussians when it builds the model and after every densification.

use evogs_math::{Real, Vec3};

/// Bits per axis of the Morton code (a 2¹⁰ grid over the box).
const BITS: u32 = 10;

/// Spreads the low 10 bits of `x` to every third bit.
fn spread(x: u32) -> u64 {
    (0..BITS).fold(0, |acc, b| acc | (u64::from((x >> b) & 1) << (3 * b)))
}

/// The Morton code of `p` in the box `[lo, hi]` (positions outside, or NaN, are clamped to
/// its faces).
#[must_use]
pub fn morton_code<T: Real>(p: Vec3<T>, lo: [f64; 3], hi: [f64; 3]) -> u64 {
    let cells = f64::from((1u32 << BITS) - 1);
    let q = |v: T, a: usize| {
        let u = (v.to_f64() - lo[a]) / (hi[a] - lo[a]).max(f64::MIN_POSITIVE);
        #[allow(clippy::cast_possible_truncation, reason = "clamped to [0, 1023]")]
        let cell = if u.is_nan() {
            0
        } else {
            (u * cells).round().clamp(0.0, cells) as u32
        };
        cell
    };
    spread(q(p.x, 0)) | spread(q(p.y, 1)) << 1 | spread(q(p.z, 2)) << 2
}

/// The permutation that sorts `means` along the Morton curve of the box `[lo, hi]` (ties kept
/// in index order): entry `i` is the index of the Gaussian that goes to place `i`.
#[must_use]
pub fn spatial_order<T: Real>(means: &[Vec3<T>], lo: [f64; 3], hi: [f64; 3]) -> Vec<usize> {
    let mut keyed: Vec<(u64, usize)> = means
        .iter()
        .enumerate()
        .map(|(i, &p)| (morton_code(p, lo, hi), i))
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_interleave_the_axes() {
        let (lo, hi) = ([0.0; 3], [1023.0; 3]);
        assert_eq!(morton_code(Vec3::new(1.0, 0.0, 0.0), lo, hi), 0b001);
        assert_eq!(morton_code(Vec3::new(0.0, 1.0, 0.0), lo, hi), 0b010);
        assert_eq!(morton_code(Vec3::new(0.0, 0.0, 1.0), lo, hi), 0b100);
        assert_eq!(morton_code(Vec3::new(3.0, 0.0, 0.0), lo, hi), 0b001_001);
        assert_eq!(
            morton_code(Vec3::new(-5.0, f32::NAN, 1e9), lo, hi),
            spread(1023) << 2
        );
    }

    #[test]
    fn the_order_is_a_permutation_that_groups_nearby_points() {
        // Points on a line, shuffled: the order restores the line.
        let xs = [0.9_f32, 0.1, 0.5, 0.3, 0.7, 0.0];
        let means: Vec<Vec3<f32>> = xs.iter().map(|&x| Vec3::new(x, 0.2, 0.2)).collect();
        let order = spatial_order(&means, [0.0; 3], [1.0; 3]);
        let sorted: Vec<f32> = order.iter().map(|&i| xs[i]).collect();
        assert_eq!(sorted, vec![0.0, 0.1, 0.3, 0.5, 0.7, 0.9]);
        // Equal codes keep the index order.
        let same = vec![Vec3::new(0.5_f32, 0.5, 0.5); 4];
        assert_eq!(spatial_order(&same, [0.0; 3], [1.0; 3]), vec![0, 1, 2, 3]);
    }
}
