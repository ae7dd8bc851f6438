//! Initial Gaussians: from a point cloud (`points3d.ply`) or random points in a box
//! (`docs/method.md` §2).
//!
//! Colour: SH DC = (rgb − 0.5)/C0, higher coefficients 0 (random grey ≈ 0.5 without
//! colours). Log-scale: log √(max(d̄², 1e-7)) with d̄² the mean squared distance to the three
//! nearest neighbours, on all three axes. Quaternion (1, 0, 0, 0). Opacity logit(0.1).

use evogs_math::activation::logit;
use evogs_math::rng::SplitMix64;
use evogs_math::sh::{SH_C0, sh_coeff_count};
use evogs_math::{Quat, Vec3};
use evogs_splat::Splats;

/// Mean squared distance of each point to its `k` nearest other points (a uniform grid
/// search: exact, O(N) for evenly spread clouds).
#[must_use]
pub fn mean_sq_knn_distance(points: &[[f32; 3]], k: usize) -> Vec<f32> {
    let n = points.len();
    if n <= 1 {
        return vec![1e-2; n];
    }
    let k = k.min(n - 1);
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in points {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    // About two points per cell.
    let vol: f32 = (0..3).map(|a| (hi[a] - lo[a]).max(1e-6)).product();
    let cell = (2.0 * vol / n as f32).cbrt().max(1e-6);
    #[allow(clippy::cast_possible_truncation, reason = "grid sizes are small")]
    let dims: [usize; 3] =
        core::array::from_fn(|a| (((hi[a] - lo[a]) / cell) as usize + 1).min(1024));
    #[allow(clippy::cast_possible_truncation, reason = "clamped to the grid")]
    let cell_of = |p: &[f32; 3]| -> [usize; 3] {
        core::array::from_fn(|a| (((p[a] - lo[a]) / cell) as usize).min(dims[a] - 1))
    };
    let flat = |c: [usize; 3]| (c[2] * dims[1] + c[1]) * dims[0] + c[0];
    let mut starts = vec![0usize; dims[0] * dims[1] * dims[2] + 1];
    for p in points {
        starts[flat(cell_of(p)) + 1] += 1;
    }
    for i in 1..starts.len() {
        starts[i] += starts[i - 1];
    }
    let mut fill = starts.clone();
    let mut sorted = vec![0usize; n];
    for (i, p) in points.iter().enumerate() {
        let c = flat(cell_of(p));
        sorted[fill[c]] = i;
        fill[c] += 1;
    }
    let mut best: Vec<f32> = Vec::with_capacity(k + 1);
    let mut out = Vec::with_capacity(n);
    for (i, p) in points.iter().enumerate() {
        let c = cell_of(p);
        best.clear();
        let mut ring = 0usize;
        loop {
            // Visit the cells at Chebyshev distance `ring`.
            // Only cells inside the grid: for flat or thin clouds the grid is thin too.
            let range = |a: usize| {
                let lo = c[a].saturating_sub(ring);
                let hi = (c[a] + ring).min(dims[a] - 1);
                lo..=hi
            };
            for z in range(2) {
                for y in range(1) {
                    for x in range(0) {
                        if x.abs_diff(c[0]).max(y.abs_diff(c[1])).max(z.abs_diff(c[2])) != ring {
                            continue;
                        }
                        let f = flat([x, y, z]);
                        for &j in &sorted[starts[f]..starts[f + 1]] {
                            if j != i {
                                let d2 = (0..3).map(|a| (points[j][a] - p[a]).powi(2)).sum::<f32>();
                                if best.len() < k || d2 < best[k - 1] {
                                    let pos = best.partition_point(|&b| b <= d2);
                                    best.insert(pos, d2);
                                    best.truncate(k);
                                }
                            }
                        }
                    }
                }
            }
            // Every point outside the visited cube is farther than ring·cell.
            let reach = ring as f32 * cell;
            let done = best.len() == k && best[k - 1] <= reach * reach;
            if done || ring > dims.iter().copied().max().unwrap_or(1) {
                break;
            }
            ring += 1;
        }
        out.push(best.iter().sum::<f32>() / best.len().max(1) as f32);
    }
    out
}

/// Gaussians at `points` with optional colours in [0, 1], storage SH degree `sh_degree`.
#[must_use]
pub fn gaussians_from_points(
    points: &[[f32; 3]],
    colors: Option<&[[f32; 3]]>,
    sh_degree: usize,
    rng: &mut SplitMix64,
) -> Splats<f32> {
    let d2 = mean_sq_knn_distance(points, 3);
    let k = sh_coeff_count(sh_degree);
    let mut s = Splats::new(sh_degree);
    let mut sh = vec![[0.0_f32; 3]; k];
    #[allow(clippy::cast_possible_truncation, reason = "f32 parameters")]
    let c0 = SH_C0 as f32;
    for (i, p) in points.iter().enumerate() {
        let rgb = colors.map_or_else(
            || {
                #[allow(clippy::cast_possible_truncation, reason = "f32 parameters")]
                let g = 0.5 + rng.uniform(0.0, 1.0 / 255.0) as f32;
                [g; 3]
            },
            |c| c[i],
        );
        sh[0] = [
            (rgb[0] - 0.5) / c0,
            (rgb[1] - 0.5) / c0,
            (rgb[2] - 0.5) / c0,
        ];
        let ls = 0.5 * d2[i].max(1e-7).ln();
        s.push(
            Vec3::from_array(*p),
            Vec3::splat(ls),
            Quat::identity(),
            logit(0.1_f32),
            &sh,
        );
    }
    s
}

/// `n` points uniform in the cube `[−extent, extent]³`.
#[must_use]
pub fn random_points(n: usize, extent: f64, rng: &mut SplitMix64) -> Vec<[f32; 3]> {
    #[allow(clippy::cast_possible_truncation, reason = "f32 positions")]
    (0..n)
        .map(|_| core::array::from_fn(|_| rng.uniform(-extent, extent) as f32))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_knn_matches_brute_force() {
        let mut rng = SplitMix64::new(4);
        let pts = random_points(700, 1.3, &mut rng);
        let fast = mean_sq_knn_distance(&pts, 3);
        for i in (0..pts.len()).step_by(37) {
            let mut d: Vec<f32> = (0..pts.len())
                .filter(|&j| j != i)
                .map(|j| (0..3).map(|a| (pts[j][a] - pts[i][a]).powi(2)).sum())
                .collect();
            d.sort_by(f32::total_cmp);
            let want = (d[0] + d[1] + d[2]) / 3.0;
            assert!(
                (fast[i] - want).abs() <= 1e-6 * want.max(1e-6),
                "point {i}: {} vs {want}",
                fast[i]
            );
        }
    }

    #[test]
    fn gaussians_get_the_documented_initial_values() {
        let mut rng = SplitMix64::new(1);
        let s = gaussians_from_points(
            &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0]],
            Some(&[[1.0, 0.5, 0.0]; 3]),
            3,
            &mut rng,
        );
        assert_eq!(s.len(), 3, "three Gaussians");
        assert!(
            (s.sh_coeffs(0)[0][1]).abs() < 1e-6,
            "grey channel has zero DC"
        );
        assert!(
            (evogs_math::activation::sigmoid(s.opacity_logits[0]) - 0.1).abs() < 1e-6,
            "opacity 0.1"
        );
        // Point 0: neighbours at squared distances 1 and 4 → mean 2.5 → log-scale ½ ln 2.5.
        assert!(
            (s.log_scales[0].x - 0.5 * 2.5_f32.ln()).abs() < 1e-6,
            "knn scale"
        );
    }
}
