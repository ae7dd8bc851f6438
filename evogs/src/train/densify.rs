//! Adaptive density control of 3DGS (`docs/method.md` §7.4): clone small
//! Gaussians and split large ones whose view-averaged 2D-mean gradient is large, prune
//! transparent (and optionally huge) ones, and reset opacities periodically.
//!
//! With waypoints, every anchor state is cloned or split with its Gaussian (a split child
//! gets the same local offset `n ~ N(0, I)` in every anchor frame: `p = p_a + R_a(s_a ⊙ n)`),
//! so the Gaussians stay in one-to-one correspondence across anchors.

use super::optim::Optimizer;
use crate::config::DensifyConfig;
use crate::model::Model;
use crate::model::retain::retain_items;
use evogs_math::activation::{logit, sigmoid};
use evogs_math::rng::SplitMix64;
use evogs_math::{Quat, Vec3};

/// Per-Gaussian accumulators between densifications.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DensifyStats {
    /// Σ over visible views of the 2D-mean gradient norm (NDC units).
    pub accum: Vec<f32>,
    /// Number of views in which the Gaussian was visible.
    pub count: Vec<u32>,
    /// Largest screen radius seen (pixels).
    pub max_radius: Vec<u32>,
}

impl DensifyStats {
    /// Zeroed accumulators for `n` Gaussians.
    #[must_use]
    pub fn new(n: usize) -> Self {
        Self {
            accum: vec![0.0; n],
            count: vec![0; n],
            max_radius: vec![0; n],
        }
    }
}

/// What one densification did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DensifyReport {
    /// Gaussians cloned.
    pub cloned: usize,
    /// Gaussians split (each into two).
    pub split: usize,
    /// Gaussians removed (split parents excluded).
    pub pruned: usize,
}

/// Copies Gaussian `i` of every state of the model to the end (a clone), then moves the
/// copies' positions by `offsets[a]` and adds `d_log_scale` to their log-scales.
fn push_copy(model: &mut Model<f32>, i: usize, offsets: &[Vec3<f32>], d_log_scale: f32) {
    let k = model.canonical.coeffs_per_gaussian();
    let c = &mut model.canonical;
    let sh: Vec<[f32; 3]> = c.sh[i * k..(i + 1) * k].to_vec();
    c.push(
        c.means[i] + offsets[0],
        c.log_scales[i] + Vec3::splat(d_log_scale),
        c.quats[i],
        c.opacity_logits[i],
        &sh,
    );
    for (a, off) in model.anchors.iter_mut().zip(&offsets[1..]) {
        a.means.push(a.means[i] + *off);
        a.log_scales
            .push(a.log_scales[i] + Vec3::splat(d_log_scale));
        a.quats.push(a.quats[i]);
    }
}

/// The offset `R(q)·(exp(ŝ) ⊙ n)` of a split child in one anchor frame.
fn child_offset(log_scale: Vec3<f32>, q: Quat<f32>, n: Vec3<f32>) -> Vec3<f32> {
    q.normalize().rotate(log_scale.map(f32::exp).mul_elem(n))
}

/// Clones, splits and prunes; resizes the optimiser, puts the Gaussians back in spatial order
/// ([`Model::sort_spatially`]) and resets the statistics.
pub fn densify_and_prune(
    model: &mut Model<f32>,
    optim: &mut Optimizer,
    stats: &mut DensifyStats,
    cfg: &DensifyConfig,
    extent: f64,
    prune_big: bool,
    rng: &mut SplitMix64,
) -> DensifyReport {
    let n = model.len();
    #[allow(clippy::cast_possible_truncation, reason = "thresholds in f32")]
    let (th, big) = (
        cfg.grad_threshold as f32,
        (cfg.percent_dense * extent) as f32,
    );
    let mut rep = DensifyReport::default();
    let room = cfg.max_gaussians.saturating_sub(n);
    let mut split_parent = vec![false; n];
    let mut added = 0;
    for i in 0..n {
        if added >= room {
            break;
        }
        let avg = if stats.count[i] > 0 {
            stats.accum[i] / stats.count[i] as f32
        } else {
            0.0
        };
        if avg < th || !avg.is_finite() {
            continue;
        }
        let scale = model.canonical.log_scales[i].max_elem().exp();
        if scale <= big {
            push_copy(model, i, &vec![Vec3::zero(); 1 + model.anchors.len()], 0.0);
            rep.cloned += 1;
            added += 1;
        } else {
            split_parent[i] = true;
            for _ in 0..2 {
                #[allow(clippy::cast_possible_truncation, reason = "f32 parameters")]
                let z = Vec3::new(
                    rng.normal() as f32,
                    rng.normal() as f32,
                    rng.normal() as f32,
                );
                let mut offs = vec![child_offset(
                    model.canonical.log_scales[i],
                    model.canonical.quats[i],
                    z,
                )];
                for a in &model.anchors {
                    offs.push(child_offset(a.log_scales[i], a.quats[i], z));
                }
                push_copy(model, i, &offs, -(1.6_f32).ln());
            }
            rep.split += 1;
            added += 2;
        }
    }
    // Prune: split parents, transparent Gaussians and (optionally) huge screen footprints.
    let total = model.len();
    let mut keep = vec![true; total];
    #[allow(clippy::cast_possible_truncation, reason = "threshold in f32")]
    let min_o = cfg.min_opacity as f32;
    for i in 0..total {
        let transparent = sigmoid(model.canonical.opacity_logits[i]) < min_o;
        let huge = prune_big
            && cfg.max_screen_size > 0.0
            && i < n
            && f64::from(stats.max_radius[i]) > cfg.max_screen_size;
        if (i < n && split_parent[i]) || transparent || huge {
            keep[i] = false;
            if !(i < n && split_parent[i]) {
                rep.pruned += 1;
            }
        }
    }
    retain_gaussians(model, &keep);
    let k = model.canonical.coeffs_per_gaussian();
    // The optimiser: old entries kept per `keep[..n]`, new ones (zero moments) for the kept
    // additions.
    let kept_new = keep[n..].iter().filter(|&&b| b).count();
    optim.resize_gaussians(&keep[..n], kept_new, k);
    // Clones and splits were appended: restore the spatial order.
    let order = model.sort_spatially();
    optim.permute_gaussians(&order, k);
    *stats = DensifyStats::new(model.len());
    rep
}

/// Keeps the Gaussians flagged in `keep` in every state of the model.
pub fn retain_gaussians(model: &mut Model<f32>, keep: &[bool]) {
    let k = model.canonical.coeffs_per_gaussian();
    let c = &mut model.canonical;
    retain_items(&mut c.means, keep, 1);
    retain_items(&mut c.log_scales, keep, 1);
    retain_items(&mut c.quats, keep, 1);
    retain_items(&mut c.opacity_logits, keep, 1);
    retain_items(&mut c.sh, keep, k);
    for a in &mut model.anchors {
        a.retain(keep);
    }
}

/// Opacity reset: `ô ← logit(min(σ(ô), 0.01))`, and the opacity moments are zeroed.
pub fn reset_opacity(model: &mut Model<f32>, optim: &mut Optimizer) {
    let cap = logit(0.01_f32);
    for o in &mut model.canonical.opacity_logits {
        *o = o.min(cap);
    }
    optim.opacity.reset();
}
