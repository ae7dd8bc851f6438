//! Neighbourhoods of Gaussians for the losses that compare neighbours (the velocity
//! coherence and the rigidity priors): samples drawn in local clusters, and the k nearest
//! neighbours of every sample point within the sample with their weights
//! `w_ij = exp(−d_ij/σ)`, `σ = ½·mean neighbour distance` (scale-free).

use evogs_math::Vec3;
use evogs_math::rng::SplitMix64;

/// One neighbour pair: `(i, j, w_ij, r̂_ij)`.
pub(crate) type Pair = (usize, usize, f64, [f64; 3]);

/// The k nearest neighbours of every sample point (brute force, self excluded, ties broken
/// by index for determinism) with their weights `w_ij` and unit offsets `r̂_ij`; returns the
/// pairs and `Σ w_ij + 1e-8`.
pub(crate) fn neighbour_pairs(positions: &[[f64; 3]], k: usize) -> (Vec<Pair>, f64) {
    let m = positions.len();
    let k = k.min(m - 1);
    let dist = |a: &[f64; 3], b: &[f64; 3]| {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    };
    let mut nbrs: Vec<(usize, f64)> = Vec::with_capacity(m * k);
    let mut cand: Vec<(f64, usize)> = Vec::with_capacity(m);
    for i in 0..m {
        cand.clear();
        cand.extend(
            (0..m)
                .filter(|&j| j != i)
                .map(|j| (dist(&positions[i], &positions[j]), j)),
        );
        cand.select_nth_unstable_by(k - 1, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut best: Vec<(f64, usize)> = cand[..k].to_vec();
        best.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        nbrs.extend(best.into_iter().map(|(d, j)| (j, d)));
    }
    #[allow(clippy::cast_precision_loss, reason = "counts are small")]
    let mean_d = nbrs.iter().map(|&(_, d)| d).sum::<f64>() / nbrs.len() as f64;
    let sigma = (0.5 * mean_d).max(1e-12);
    let mut sum_w = 0.0;
    let mut pairs = Vec::with_capacity(nbrs.len());
    for i in 0..m {
        for &(j, d) in &nbrs[i * k..(i + 1) * k] {
            let w = (-d / sigma).exp();
            let inv = 1.0 / d.clamp(1e-6, 10.0);
            let r: [f64; 3] = core::array::from_fn(|a| (positions[i][a] - positions[j][a]) * inv);
            sum_w += w;
            pairs.push((i, j, w, r));
        }
    }
    (pairs, sum_w + 1e-8)
}

/// About `m` Gaussians in clusters of `size`: random seeds (without replacement) each with its
/// `size − 1` nearest Gaussians of the whole cloud (brute force; ties by index), the union
/// sorted and without repeats. Deterministic for a given random state.
pub(crate) fn local_clusters(
    means: &[Vec3<f32>],
    m: usize,
    size: usize,
    rng: &mut SplitMix64,
) -> Vec<usize> {
    let n = means.len();
    let size = size.clamp(1, n);
    let seeds = (m / size).max(1).min(n);
    let mut idx: Vec<usize> = (0..n).collect();
    for i in 0..seeds {
        let j = i + rng.below(n - i);
        idx.swap(i, j);
    }
    let mut out = Vec::with_capacity(seeds * size);
    let mut cand: Vec<(f32, usize)> = Vec::with_capacity(n);
    for &s in &idx[..seeds] {
        let c = means[s];
        cand.clear();
        cand.extend(
            means
                .iter()
                .enumerate()
                .map(|(j, p)| ((*p - c).norm_squared(), j)),
        );
        let by = |a: &(f32, usize), b: &(f32, usize)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
        if size < n {
            cand.select_nth_unstable_by(size - 1, by);
        }
        out.extend(cand[..size].iter().map(|&(_, j)| j));
    }
    out.sort_unstable();
    out.dedup();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn local_clusters_are_seeds_with_their_nearest_gaussians() {
        // Two blobs far apart on a fine lattice: every cluster lies within one blob, and
        // each is a seed with its nearest lattice points (at most one diagonal away).
        let mut means = Vec::new();
        for blob in [0.0f32, 10.0] {
            for i in 0..6 {
                for j in 0..6 {
                    for k in 0..6 {
                        #[allow(clippy::cast_precision_loss, reason = "small")]
                        means.push(Vec3::new(
                            blob + 0.1 * i as f32,
                            0.1 * j as f32,
                            0.1 * k as f32,
                        ));
                    }
                }
            }
        }
        let mut rng = SplitMix64::new(3);
        let picks = local_clusters(&means, 45, 9, &mut rng);
        assert!(picks.windows(2).all(|w| w[0] < w[1]), "sorted, no repeats");
        assert!(
            picks.len() > 9 && picks.len() <= 45,
            "{} points",
            picks.len()
        );
        // Every pick has another pick within the lattice's 9-neighbourhood radius and in
        // its own blob (uniform sampling of 45 of 432 would leave most of them alone).
        for &i in &picks {
            let near = picks
                .iter()
                .filter(|&&j| j != i && (means[j] - means[i]).norm() < 0.1 * 3f32.sqrt() + 1e-4)
                .count();
            assert!(near >= 1, "point {i} has a neighbour in the sample");
        }
        let again = local_clusters(&means, 45, 9, &mut SplitMix64::new(3));
        assert_eq!(picks, again, "deterministic");
    }
}
