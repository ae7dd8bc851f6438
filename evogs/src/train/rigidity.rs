//! Neighbour rigidity priors on the Gaussians at the rendered time (`docs/losses.md` §9): the
//! local-rigidity, rotation-similarity and isometry losses of Dynamic 3D Gaussians (Luiten et
//! al. 2024), measured against the canonical Gaussians. They know nothing of a scene: they
//! only ask that neighbouring Gaussians move together, as pieces of one body do, and they
//! apply to every motion that moves Gaussians (velocity and deformation alike).
//!
//! For a sample of Gaussians drawn in local clusters (`neighbours::local_clusters`)
//! with their k nearest neighbours within the sample (canonical positions,
//! `neighbours::neighbour_pairs`), the canonical state `(p⁰, R⁰)` as the reference,
//! the state `(p, R)` at the rendered time, `M_i = R_i R_i⁰ᵀ` (Gaussian i's rotation since
//! the canonical time), `d⁰_ij = p⁰_j − p⁰_i`, a length `ℓ` (the training passes the spacing
//! the Gaussians would have if spread evenly over the field's box, `(volume / N)^⅓`), pair
//! weights `w_ij = exp(−|d⁰_ij|²/(2ℓ²))`, `W = Σ w_ij` and the robust penalty
//! `ρ(x) = 2(√(1 + x) − 1)` (`x` for small errors, `2√x` for large ones):
//!
//! ```text
//! rigidity  L_rig = Σ w_ij ρ(|(p_j − p_i) − M_i d⁰_ij|² / ℓ²) / W   neighbours keep their offsets in i's frame
//! rotation  L_rot = Σ w_ij ρ(‖M_j − M_i‖²_F) / W                     neighbours turn alike
//! isometry  L_iso = Σ w_ij ρ((|p_j − p_i| − |d⁰_ij|)² / ℓ²) / W      neighbours keep their distances
//! ```
//!
//! All three are zero for any rigid motion of the whole cloud and scale-free (a scene scaled
//! by s, with ℓ, has the same losses). Two bodies that touch make pairs that cannot stay
//! rigid: the distance weights count far pairs little and the robust penalty bounds the pull
//! of any pair. `ℓ` is not taken from the neighbour distances: a densification clone starts
//! exactly on its parent, so those distances can be zero. The neighbours, their weights and
//! `ℓ²` form a [`RigidityGraph`], built from the canonical positions when the sample is drawn
//! and constant for the step (as the coherence loss's sample points are); the positions and
//! rotations, at the rendered time and canonical, are differentiated exactly. Rotations are
//! taken from the raw quaternions as the renderer takes them (`R = R(q/|q|)`), so a
//! quaternion gradient is that of the raw quaternion.

use super::neighbours::neighbour_pairs;
use evogs_math::quat::{rotation_from_raw, rotation_from_raw_vjp};
use evogs_math::{Mat3, Quat, Real, Vec3};

/// The weights of the three priors (0 switches one off).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RigidityWeights {
    /// Weight of the local-rigidity loss.
    pub rigidity: f64,
    /// Weight of the rotation-similarity loss.
    pub rotation: f64,
    /// Weight of the isometry loss.
    pub isometry: f64,
}

impl RigidityWeights {
    /// `true` if any prior is on.
    #[must_use]
    pub fn any(&self) -> bool {
        self.rigidity > 0.0 || self.rotation > 0.0 || self.isometry > 0.0
    }
}

/// The values of the three priors, unweighted.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RigidityLosses {
    /// `L_rig`.
    pub rigidity: f64,
    /// `L_rot`.
    pub rotation: f64,
    /// `L_iso`.
    pub isometry: f64,
}

impl RigidityLosses {
    /// The weighted sum.
    #[must_use]
    pub fn weighted(&self, w: &RigidityWeights) -> f64 {
        w.rigidity * self.rigidity + w.rotation * self.rotation + w.isometry * self.isometry
    }
}

/// The neighbour pairs of a sample, with their weights and length scale (constants of a step).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RigidityGraph {
    /// `(i, j, w_ij)`, indices into the sample.
    pub pairs: Vec<(usize, usize, f64)>,
    /// `W = Σ w_ij`.
    pub sum_w: f64,
    /// `ℓ²`.
    pub len2: f64,
}

impl RigidityGraph {
    /// The `k` nearest neighbours of every sample point among `positions` (the sample's
    /// canonical positions) and the length scale `length` (> 0); pair weights
    /// `w_ij = exp(−|d⁰_ij|²/(2ℓ²))`, so that pairs far apart (across a gap between bodies)
    /// count little. Empty with fewer than two points.
    #[must_use]
    pub fn new(positions: &[[f64; 3]], k: usize, length: f64) -> Self {
        if positions.len() < 2 || k == 0 {
            return Self::default();
        }
        let len2 = (length * length).max(1e-300);
        let (pairs, _) = neighbour_pairs(positions, k);
        let pairs: Vec<(usize, usize, f64)> = pairs
            .into_iter()
            .map(|(i, j, _, _)| {
                let d2: f64 = (0..3)
                    .map(|a| (positions[j][a] - positions[i][a]).powi(2))
                    .sum();
                (i, j, (-0.5 * d2 / len2).exp())
            })
            .collect();
        let sum_w = pairs.iter().map(|p| p.2).sum();
        Self { pairs, sum_w, len2 }
    }

    /// `true` if there are no pairs.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty() || self.sum_w <= 0.0
    }
}

/// The spacing of `n` points spread evenly over the box `[lo, hi]`: `(volume / n)^⅓` (the
/// length scale the training gives [`RigidityGraph::new`]).
#[must_use]
pub fn even_spacing(lo: [f64; 3], hi: [f64; 3], n: usize) -> f64 {
    let volume: f64 = (0..3).map(|a| (hi[a] - lo[a]).abs()).product();
    #[allow(
        clippy::cast_precision_loss,
        reason = "Gaussian counts are far below 2^52"
    )]
    let per_point = volume / n.max(1) as f64;
    per_point.cbrt()
}

/// A sample point: its canonical position and raw quaternion, and its position and raw
/// quaternion at the rendered time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidPoint<T> {
    /// Canonical position `p⁰`.
    pub p0: Vec3<T>,
    /// Canonical raw quaternion `q⁰`.
    pub q0: Quat<T>,
    /// Position `p` at the rendered time.
    pub p: Vec3<T>,
    /// Raw quaternion `q` at the rendered time.
    pub q: Quat<T>,
}

/// The gradient of the weighted priors with respect to one sample point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidPointGrad<T> {
    /// `∂/∂p⁰`.
    pub p0: Vec3<T>,
    /// `∂/∂q⁰`.
    pub q0: Quat<T>,
    /// `∂/∂p`.
    pub p: Vec3<T>,
    /// `∂/∂q`.
    pub q: Quat<T>,
}

impl<T: Real> RigidPointGrad<T> {
    /// Zero.
    #[must_use]
    pub fn zero() -> Self {
        Self {
            p0: Vec3::zero(),
            q0: Quat::zero(),
            p: Vec3::zero(),
            q: Quat::zero(),
        }
    }
}

/// The robust penalty `ρ(x) = 2(√(1 + x) − 1)` of a squared, normalised error `x ≥ 0`:
/// `x` for small errors, `2√x` for large ones, so a pair that is not rigid (two bodies that
/// touch) pulls with a bounded force instead of one that grows with the error.
fn robust(x: f64) -> f64 {
    2.0 * ((1.0 + x).sqrt() - 1.0)
}

/// `ρ'(x) = 1/√(1 + x)`.
fn robust_slope(x: f64) -> f64 {
    1.0 / (1.0 + x).sqrt()
}

/// The three priors of `points` over `graph`; **writes** `scale·∂(Σ weighted losses)` with
/// respect to every point into `grads`. Returns the unweighted losses (zero for an empty
/// graph).
///
/// # Panics
/// If `grads` and `points` differ in length or a pair indexes past them.
pub fn rigidity_loss_and_grad<T: Real>(
    graph: &RigidityGraph,
    points: &[RigidPoint<T>],
    weights: &RigidityWeights,
    scale: f64,
    grads: &mut [RigidPointGrad<T>],
) -> RigidityLosses {
    let m = points.len();
    assert_eq!(grads.len(), m, "rigidity: length mismatch");
    grads.fill(RigidPointGrad::zero());
    let mut out = RigidityLosses::default();
    if graph.is_empty() || !weights.any() {
        return out;
    }
    let p0: Vec<Vec3<f64>> = points.iter().map(|s| s.p0.cast()).collect();
    let p: Vec<Vec3<f64>> = points.iter().map(|s| s.p.cast()).collect();
    let r0: Vec<Mat3<f64>> = points
        .iter()
        .map(|s| rotation_from_raw(s.q0.cast()))
        .collect();
    let r: Vec<Mat3<f64>> = points
        .iter()
        .map(|s| rotation_from_raw(s.q.cast()))
        .collect();
    // M_i = R_i R_i⁰ᵀ.
    let rel: Vec<Mat3<f64>> = r
        .iter()
        .zip(&r0)
        .map(|(a, b)| a.mul_mat(b.transpose()))
        .collect();
    let (sum_w, len2) = (graph.sum_w, graph.len2);
    let mut g_p = vec![Vec3::<f64>::zero(); m];
    let mut g_p0 = vec![Vec3::<f64>::zero(); m];
    let mut g_m = vec![Mat3::<f64>::zero(); m];
    let (c_rig, c_rot, c_iso) = (
        weights.rigidity / sum_w,
        weights.rotation / sum_w,
        weights.isometry / sum_w,
    );
    for &(i, j, w) in &graph.pairs {
        let d0 = p0[j] - p0[i];
        let d = p[j] - p[i];
        // Rigidity: e = d − M_i d⁰, x = |e|²/ℓ²; ∂/∂e = 2wρ'(x)e/ℓ² =: g, so ∂/∂d = g,
        // ∂/∂d⁰ = −M_iᵀ g, ∂/∂M_i = −g d⁰ᵀ.
        let e = d - rel[i].mul_vec(d0);
        let x = e.norm_squared() / len2;
        out.rigidity += w * robust(x);
        if c_rig > 0.0 {
            let g = e * (2.0 * w * robust_slope(x) * c_rig / len2);
            g_p[j] += g;
            g_p[i] -= g;
            let g0 = rel[i].tr_mul_vec(g);
            g_p0[j] -= g0;
            g_p0[i] += g0;
            g_m[i] = g_m[i] - Mat3::outer(g, d0);
        }
        // Rotation similarity: D = M_j − M_i, x = ‖D‖²; ∂/∂M_j = 2wρ'(x)D = −∂/∂M_i.
        let dm = rel[j] - rel[i];
        let x = dm.frobenius_dot(dm);
        out.rotation += w * robust(x);
        if c_rot > 0.0 {
            let g = dm.scale(2.0 * w * robust_slope(x) * c_rot);
            g_m[j] += g;
            g_m[i] = g_m[i] - g;
        }
        // Isometry: δ = |d| − |d⁰|, x = δ²/ℓ²; ∂/∂d = 2wρ'(x)δ d/(|d| ℓ²),
        // ∂/∂d⁰ = −2wρ'(x)δ d⁰/(|d⁰| ℓ²).
        let (len, len0) = (d.norm(), d0.norm());
        let delta = len - len0;
        let x = delta * delta / len2;
        out.isometry += w * robust(x);
        if c_iso > 0.0 && len > 0.0 && len0 > 0.0 {
            let s = 2.0 * w * robust_slope(x) * delta * c_iso / len2;
            let g = d * (s / len);
            g_p[j] += g;
            g_p[i] -= g;
            let g0 = d0 * (s / len0);
            g_p0[j] -= g0;
            g_p0[i] += g0;
        }
    }
    out.rigidity /= sum_w;
    out.rotation /= sum_w;
    out.isometry /= sum_w;
    for (i, g) in grads.iter_mut().enumerate() {
        // M = R R⁰ᵀ: ∂/∂R = (∂/∂M) R⁰ and ∂/∂R⁰ = (∂/∂M)ᵀ R; then through R(q/|q|).
        let d_r = g_m[i].mul_mat(r0[i]).scale(scale);
        let d_r0 = g_m[i].transpose().mul_mat(r[i]).scale(scale);
        *g = RigidPointGrad {
            p0: (g_p0[i] * scale).cast(),
            q0: rotation_from_raw_vjp(points[i].q0.cast(), d_r0).cast(),
            p: (g_p[i] * scale).cast(),
            q: rotation_from_raw_vjp(points[i].q.cast(), d_r).cast(),
        };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use evogs_math::diff::{GradCheck, central_gradient, vjp_dot_test};
    use evogs_math::rng::SplitMix64;

    const ALL: RigidityWeights = RigidityWeights {
        rigidity: 0.7,
        rotation: 0.3,
        isometry: 0.5,
    };

    fn random_quat(rng: &mut SplitMix64) -> Quat<f64> {
        Quat::new(rng.normal(), rng.normal(), rng.normal(), rng.normal())
    }

    /// A cloud with a random non-rigid state at time t.
    fn cloud(m: usize, seed: u64) -> Vec<RigidPoint<f64>> {
        let mut rng = SplitMix64::new(seed);
        (0..m)
            .map(|_| {
                let p0 = Vec3::new(rng.normal(), rng.normal(), rng.normal());
                let p = p0 + Vec3::new(rng.normal(), rng.normal(), rng.normal()) * 0.3;
                RigidPoint {
                    p0,
                    q0: random_quat(&mut rng),
                    p,
                    q: random_quat(&mut rng),
                }
            })
            .collect()
    }

    fn graph_of(points: &[RigidPoint<f64>]) -> RigidityGraph {
        let pos: Vec<[f64; 3]> = points.iter().map(|s| s.p0.to_array()).collect();
        RigidityGraph::new(&pos, 4, 0.8)
    }

    /// Every differentiated input: `[p⁰, q⁰, p, q]` per point (14 values).
    fn flat(points: &[RigidPoint<f64>]) -> Vec<f64> {
        let mut x = Vec::new();
        for s in points {
            x.extend_from_slice(&s.p0.to_array());
            x.extend_from_slice(&s.q0.to_array());
            x.extend_from_slice(&s.p.to_array());
            x.extend_from_slice(&s.q.to_array());
        }
        x
    }

    fn from_flat(x: &[f64]) -> Vec<RigidPoint<f64>> {
        x.chunks_exact(14)
            .map(|v| RigidPoint {
                p0: Vec3::from_slice(v),
                q0: Quat::from_slice(&v[3..]),
                p: Vec3::from_slice(&v[7..]),
                q: Quat::from_slice(&v[10..]),
            })
            .collect()
    }

    fn loss_of(graph: &RigidityGraph, points: &[RigidPoint<f64>], w: &RigidityWeights) -> f64 {
        let mut g = vec![RigidPointGrad::zero(); points.len()];
        rigidity_loss_and_grad(graph, points, w, 1.0, &mut g).weighted(w)
    }

    fn gradient(
        graph: &RigidityGraph,
        points: &[RigidPoint<f64>],
        w: &RigidityWeights,
    ) -> Vec<f64> {
        let mut g = vec![RigidPointGrad::zero(); points.len()];
        let _ = rigidity_loss_and_grad(graph, points, w, 1.0, &mut g);
        g.iter()
            .flat_map(|g| {
                g.p0.to_array()
                    .into_iter()
                    .chain(g.q0.to_array())
                    .chain(g.p.to_array())
                    .chain(g.q.to_array())
            })
            .collect()
    }

    #[test]
    fn each_prior_matches_central_differences() {
        let points = cloud(24, 5);
        let graph = graph_of(&points);
        for (name, w) in [
            (
                "rigidity",
                RigidityWeights {
                    rigidity: 1.0,
                    ..RigidityWeights::default()
                },
            ),
            (
                "rotation",
                RigidityWeights {
                    rotation: 1.0,
                    ..RigidityWeights::default()
                },
            ),
            (
                "isometry",
                RigidityWeights {
                    isometry: 1.0,
                    ..RigidityWeights::default()
                },
            ),
            ("all", ALL),
        ] {
            assert!(
                loss_of(&graph, &points, &w) > 1e-3,
                "{name}: a random state costs"
            );
            let analytic = gradient(&graph, &points, &w);
            let mut x = flat(&points);
            let mut num = vec![0.0; x.len()];
            central_gradient(
                |v: &[f64]| loss_of(&graph, &from_flat(v), &w),
                &mut x,
                &mut num,
            );
            let check = GradCheck::new(1e-6, 1e-8).check(&analytic, &num);
            assert!(check.passed(), "{name}: {check:?}");
        }
    }

    #[test]
    fn the_gradient_passes_the_dot_product_test() {
        // The loss is a scalar function L(x); its VJP with cotangent c is c·∇L, so the
        // dot-product test compares ⟨∇L, v⟩ with the directional derivative along v.
        let points = cloud(16, 9);
        let graph = graph_of(&points);
        let x = flat(&points);
        let grad = gradient(&graph, &points, &ALL);
        let h = 1e-6;
        let res = vjp_dot_test(
            |v: &[f64], out: &mut [f64]| {
                let shifted =
                    |s: f64| -> Vec<f64> { x.iter().zip(v).map(|(a, b)| a + s * b).collect() };
                out[0] = (loss_of(&graph, &from_flat(&shifted(h)), &ALL)
                    - loss_of(&graph, &from_flat(&shifted(-h)), &ALL))
                    / (2.0 * h);
            },
            |c: &[f64], out: &mut [f64]| {
                for (o, g) in out.iter_mut().zip(&grad) {
                    *o = c[0] * g;
                }
            },
            x.len(),
            1,
            11,
        );
        assert!(res < 1e-7, "dot-product residual {res}");
    }

    #[test]
    fn a_rigid_motion_costs_nothing() {
        let mut points = cloud(30, 13);
        let turn = Quat::new(0.8, -0.3, 0.4, 0.2).normalize();
        let shift = Vec3::new(0.5, -1.0, 2.0);
        for s in &mut points {
            s.p = turn.rotate(s.p0) + shift;
            // Raw quaternions of any length: the priors normalise as the renderer does.
            s.q = turn.mul_quat(s.q0).scale(1.7);
        }
        let graph = graph_of(&points);
        let mut grads = vec![RigidPointGrad::zero(); points.len()];
        let l = rigidity_loss_and_grad(&graph, &points, &ALL, 1.0, &mut grads);
        assert!(l.weighted(&ALL) < 1e-20, "{l:?}");
        let g = gradient(&graph, &points, &ALL);
        assert!(g.iter().all(|v| v.abs() < 1e-9), "zero gradient");
        // A bend is not rigid.
        points[0].p += Vec3::new(0.3, 0.0, 0.0);
        assert!(loss_of(&graph, &points, &ALL) > 1e-4);
    }

    #[test]
    fn the_priors_are_scale_free() {
        let points = cloud(20, 17);
        let scaled: Vec<RigidPoint<f64>> = points
            .iter()
            .map(|s| RigidPoint {
                p0: s.p0 * 3.0,
                p: s.p * 3.0,
                ..*s
            })
            .collect();
        let pos = |c: &[RigidPoint<f64>]| -> Vec<[f64; 3]> {
            c.iter().map(|s| s.p0.to_array()).collect()
        };
        let (a, b) = (
            loss_of(&RigidityGraph::new(&pos(&points), 4, 0.5), &points, &ALL),
            loss_of(&RigidityGraph::new(&pos(&scaled), 4, 1.5), &scaled, &ALL),
        );
        assert!((a - b).abs() < 1e-12 * a.max(1.0), "{a} vs {b}");
    }

    #[test]
    fn even_spacing_is_the_cube_root_of_the_volume_per_point() {
        assert!((even_spacing([0.0; 3], [2.0; 3], 8) - 1.0).abs() < 1e-12);
        assert!((even_spacing([-1.0, 0.0, 0.0], [1.0, 4.0, 1.0], 1) - 2.0).abs() < 1e-12);
    }
}
