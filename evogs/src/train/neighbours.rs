//! Neighbourhoods of sampled Gaussians for the velocity coherence: the k nearest
//! neighbours of every sample point within the sample with their weights
//! `w_ij = exp(−d_ij/σ)`, `σ = ½·mean neighbour distance` (scale-free).

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
