//! Velocity coherence (`docs/losses.md` §7, the anisotropic kNN form of the released code).
//!
//! For a sample of M Gaussians at their (detached) positions `x_i` with velocities
//! `v_i = v(x_i, t)`: the k nearest neighbours of each sample point within the sample,
//! `σ = ½·mean neighbour distance`, weights `w_ij = exp(−d_ij/σ)`, and
//!
//! ```text
//! r̂ = (x_i − x_j)/max(d_ij, 1e-6),  Δv = v_i − v_j,  Δv_∥ = (Δv·r̂) r̂,  Δv_⊥ = Δv − Δv_∥
//! c_ij = |Δv_⊥|² + 0.2·|Δv_∥|²                 (sideways tearing costs 5× stretching)
//! L = Σ w_ij c_ij / (Σ w_ij + 1e-8)
//! ```
//!
//! A rigid rotation has `Δv = ω × (x_i − x_j) ≠ 0`, so this form penalises turning.
//!
//! The weights depend only on the detached positions, so the gradient flows to the
//! velocities (and from there to the field's parameters) only.
//!
//! The neighbours come from [`super::neighbours`].

use super::neighbours::neighbour_pairs;

/// Neighbours per sample point.
pub const COHERENCE_K: usize = 8;
/// Weight of the parallel (stretching) part.
const PARALLEL_WEIGHT: f64 = 0.2;

/// The anisotropic cost `|Δv_⊥|² + 0.2·|Δv_∥|²` of a difference `dv` along `r̂` and its
/// gradient with respect to `dv`.
fn anisotropic_cost(dv: &[f64; 3], r: &[f64; 3]) -> (f64, [f64; 3]) {
    // With a = Δv·r̂ and s = |r̂|² (1 unless d was clamped):
    // c = |Δv − a r̂|² + 0.2 |a r̂|² = |Δv|² + a²((1 + 0.2) s − 2),
    // ∂c/∂Δv = 2Δv + 2a((1 + 0.2) s − 2) r̂.
    let a = dv[0] * r[0] + dv[1] * r[1] + dv[2] * r[2];
    let s2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
    let f = (1.0 + PARALLEL_WEIGHT) * s2 - 2.0;
    let c = dv.iter().map(|x| x * x).sum::<f64>() + a * a * f;
    (
        c,
        core::array::from_fn(|q| 2.0 * dv[q] + 2.0 * a * f * r[q]),
    )
}

fn diff(u: &[[f64; 3]], i: usize, j: usize) -> [f64; 3] {
    core::array::from_fn(|a| u[i][a] - u[j][a])
}

/// Adds `scale·g` to `d[i]` and subtracts it from `d[j]`.
fn scatter_pair(d: &mut [[f64; 3]], i: usize, j: usize, scale: f64, g: &[f64; 3]) {
    for q in 0..3 {
        d[i][q] += scale * g[q];
        d[j][q] -= scale * g[q];
    }
}

/// The coherence loss of `velocities[i]` at `positions[i]`; adds `∂L/∂v_i` into `d_v[i]`.
///
/// # Panics
/// If the slices differ in length.
#[must_use]
pub fn coherence_loss(
    positions: &[[f64; 3]],
    velocities: &[[f64; 3]],
    k: usize,
    d_v: &mut [[f64; 3]],
) -> f64 {
    let m = positions.len();
    assert!(
        velocities.len() == m && d_v.len() == m,
        "coherence: length mismatch"
    );
    if m < 2 {
        return 0.0;
    }
    let (pairs, denom) = neighbour_pairs(positions, k);
    let mut sum_wc = 0.0;
    for &(i, j, w, r) in &pairs {
        let (c, g) = anisotropic_cost(&diff(velocities, i, j), &r);
        sum_wc += w * c;
        scatter_pair(d_v, i, j, w / denom, &g);
    }
    sum_wc / denom
}

#[cfg(test)]
mod tests {
    use super::*;
    use evogs_math::Vec3;
    use evogs_math::diff::{GradCheck, central_gradient};
    use evogs_math::rng::SplitMix64;

    #[test]
    fn gradient_matches_central_differences() {
        let mut rng = SplitMix64::new(1);
        let m = 30;
        let pos: Vec<[f64; 3]> = (0..m)
            .map(|_| {
                [
                    rng.uniform(-1.0, 1.0),
                    rng.uniform(-1.0, 1.0),
                    rng.uniform(-1.0, 1.0),
                ]
            })
            .collect();
        let vel: Vec<[f64; 3]> = (0..m)
            .map(|_| [rng.normal(), rng.normal(), rng.normal()])
            .collect();
        let mut d = vec![[0.0; 3]; m];
        let l = coherence_loss(&pos, &vel, COHERENCE_K, &mut d);
        assert!(l > 0.0, "random velocities are incoherent");
        let mut x: Vec<f64> = vel.iter().flatten().copied().collect();
        let mut num = vec![0.0; x.len()];
        central_gradient(
            |v: &[f64]| {
                let vv: Vec<[f64; 3]> = v.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
                let mut scratch = vec![[0.0; 3]; m];
                coherence_loss(&pos, &vv, COHERENCE_K, &mut scratch)
            },
            &mut x,
            &mut num,
        );
        let a: Vec<f64> = d.iter().flatten().copied().collect();
        GradCheck::new(1e-9, 1e-7)
            .check(&a, &num)
            .assert_passed("coherence gradient");
    }

    #[test]
    fn rigid_translation_costs_nothing_and_tearing_costs_more_than_stretching() {
        let pos = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
        let mut d = [[0.0; 3]; 2];
        let same = coherence_loss(&pos, &[[1.0, 2.0, 3.0], [1.0, 2.0, 3.0]], 1, &mut d);
        assert!(same.abs() < 1e-15, "a common velocity is coherent");
        let stretch = coherence_loss(&pos, &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], 1, &mut d);
        let tear = coherence_loss(&pos, &[[0.0, 0.0, 0.0], [0.0, 1.0, 0.0]], 1, &mut d);
        assert!(
            (tear / stretch - 5.0).abs() < 1e-9,
            "perpendicular costs 5x parallel: {tear} vs {stretch}"
        );
    }

    #[test]
    fn a_rigid_rotation_costs() {
        let mut rng = SplitMix64::new(3);
        let m = 40;
        let pos: Vec<[f64; 3]> = (0..m)
            .map(|_| [rng.normal(), rng.normal(), rng.normal()])
            .collect();
        let (a0, w0) = ([0.3, -0.2, 0.1], [1.0, 2.0, -0.5]);
        let vel: Vec<[f64; 3]> = pos
            .iter()
            .map(|&x| {
                (Vec3::from_array(a0) + Vec3::from_array(w0).cross(Vec3::from_array(x))).to_array()
            })
            .collect();
        let mut d = vec![[0.0; 3]; m];
        let as_velocity = coherence_loss(&pos, &vel, COHERENCE_K, &mut d);
        assert!(
            as_velocity > 0.1,
            "velocity form penalises turning: {as_velocity}"
        );
    }
}
