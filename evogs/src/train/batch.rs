//! A batch of views as per-view shares summed in one fixed order, in one process or over
//! several ([`Collective`]).
//!
//! With `schedule.views_per_step = K` the photometric term is the mean over K views. Each
//! view's gradient is computed into its own zeroed buffer (a [`ViewShare`]), then the K
//! shares are summed in view order: `g = g₁ + g₂ + … + g_K`, then the regularisers are
//! added once, at the first view's time. Over P processes (K a multiple of P) rank `r`
//! computes views `r·K/P .. (r+1)·K/P`, the shares are gathered on every rank in rank order
//! ([`Collective::all_gather`], an exact byte encoding) and every rank sums them in the same
//! order. So `P` processes give the same bits as one process with the same `K`, and every
//! rank holds the same parameters.

use super::collective::Collective;
use super::step::{
    ScreenStats, StepLosses, StepSettings, StepWorkspace, ViewData, loss_and_grad,
    regularizers_and_grad, view_loss_and_grad,
};
use crate::field::Gemm;
use crate::model::{Model, ModelGrad};
use evogs_splat::RenderOptions;

/// One view's part of a step: its gradient (photometric term only, weighted 1/K), its loss
/// terms and its densification statistics.
#[derive(Clone, Debug, Default)]
pub struct ViewShare<T> {
    /// The view's gradient (every parameter group).
    pub grad: Option<ModelGrad<T>>,
    /// Its loss terms (`total` weighted, the others not).
    pub losses: StepLosses,
    /// Its 2D-mean gradients and screen radii.
    pub stats: ScreenStats<T>,
}

/// Sums `shares` in order into `grad` (overwritten) and returns the batch's loss terms
/// (the weighted total, the means of L1, SSIM and MSE with `weight` = 1/K) and its merged
/// statistics (2D-mean gradients summed, the largest radius).
///
/// # Panics
/// If `shares` is empty or a share has no gradient.
pub fn reduce_shares<T: Gemm>(
    shares: &[ViewShare<T>],
    weight: f64,
    grad: &mut ModelGrad<T>,
) -> (StepLosses, ScreenStats<T>) {
    assert!(!shares.is_empty(), "a batch needs at least one view");
    let mut losses = StepLosses::default();
    let mut stats = shares[0].stats.clone();
    for (k, s) in shares.iter().enumerate() {
        let g = s.grad.as_ref().expect("a share holds its gradient");
        if k == 0 {
            grad.copy_from(g);
        } else {
            grad.add_assign(g);
            let seen = stats.grad2d.iter_mut().zip(&mut stats.radius);
            for ((a, r), (g, q)) in seen.zip(s.stats.grad2d.iter().zip(&s.stats.radius)) {
                a[0] += g[0];
                a[1] += g[1];
                *r = (*r).max(*q);
            }
        }
        let l = &s.losses;
        losses.total += l.total;
        losses.l1 += weight * l.l1;
        losses.ssim += weight * l.ssim;
        losses.mse += weight * l.mse;
        losses.timings.add(&l.timings);
    }
    (losses, stats)
}

/// Loss and gradient of one step on a batch of views (the released code's batch): the mean
/// of their photometric terms ([`view_loss_and_grad`], weight `1/K` each, each into its own
/// buffer, summed in view order by [`reduce_shares`]) plus the regularisers once, at the
/// first view's time. **Adds** the gradient into `grad`; the reported L1, SSIM and MSE are
/// the views' means. The densification statistics follow the released code: the views'
/// 2D-mean gradients are summed (their norm is taken later), a Gaussian counts as seen if
/// any view sees it, and its screen radius is the largest over the views. One view is
/// [`loss_and_grad`], bit for bit.
///
/// # Panics
/// If `views` is empty.
pub fn batch_loss_and_grad<T: Gemm>(
    model: &mut Model<T>,
    views: &[&ViewData<T>],
    opts: &RenderOptions<T>,
    s: &StepSettings,
    ws: &mut StepWorkspace<T>,
    grad: &mut ModelGrad<T>,
) -> (StepLosses, ScreenStats<T>) {
    assert!(!views.is_empty(), "a step needs at least one view");
    if let [view] = views {
        return loss_and_grad(model, view, opts, s, ws, grad);
    }
    let weight = 1.0 / views.len() as f64;
    let shares: Vec<ViewShare<T>> = views
        .iter()
        .map(|view| {
            let mut g = model.zero_grad();
            let (losses, stats) = view_loss_and_grad(model, view, opts, s, weight, ws, &mut g);
            ViewShare {
                grad: Some(g),
                losses,
                stats,
            }
        })
        .collect();
    let mut sum = model.zero_grad();
    let (mut losses, stats) = reduce_shares(&shares, weight, &mut sum);
    regularizers_and_grad(model, views[0].time, s, ws, &mut sum, &mut losses);
    grad.add_assign(&sum);
    (losses, stats)
}

/// Bytes of one encoded share of a model with the layout of `like` and `n` Gaussians.
fn share_bytes(like: &ModelGrad<f32>, n: usize) -> usize {
    4 * like.value_count() + 4 * 8 + n * (2 * 4 + 4) + 2 * 8
}

impl ViewShare<f32> {
    /// Appends the exact bytes of the share (gradient values, loss terms, statistics; the
    /// timings stay local).
    ///
    /// # Panics
    /// If the share has no gradient.
    pub fn encode(&self, out: &mut Vec<u8>) {
        let g = self.grad.as_ref().expect("a share holds its gradient");
        out.reserve(share_bytes(g, self.stats.radius.len()));
        g.for_each(|v| out.extend_from_slice(&v.to_bits().to_le_bytes()));
        let l = &self.losses;
        for v in [l.total, l.l1, l.ssim, l.mse] {
            out.extend_from_slice(&v.to_bits().to_le_bytes());
        }
        for (g, r) in self.stats.grad2d.iter().zip(&self.stats.radius) {
            out.extend_from_slice(&g[0].to_bits().to_le_bytes());
            out.extend_from_slice(&g[1].to_bits().to_le_bytes());
            out.extend_from_slice(&r.to_le_bytes());
        }
        for v in [self.stats.size.0, self.stats.size.1] {
            out.extend_from_slice(&(v as u64).to_le_bytes());
        }
    }

    /// Reads a share written by [`ViewShare::encode`] into `self`, whose gradient already
    /// has the model's layout; returns the bytes read.
    ///
    /// # Errors
    /// `bytes` is shorter than a share of this layout.
    pub fn decode(&mut self, bytes: &[u8], n: usize) -> Result<usize, String> {
        let g = self
            .grad
            .as_mut()
            .ok_or("a share needs a gradient buffer")?;
        let need = share_bytes(g, n);
        if bytes.len() < need {
            return Err(format!(
                "a gathered share holds {} bytes where {need} are needed: the ranks' models differ",
                bytes.len()
            ));
        }
        let mut at = 0;
        let mut word = |k: usize| {
            let mut b = [0u8; 8];
            b[..k].copy_from_slice(&bytes[at..at + k]);
            at += k;
            u64::from_le_bytes(b)
        };
        #[allow(clippy::cast_possible_truncation, reason = "4-byte words")]
        g.for_each_mut(|v| *v = f32::from_bits(word(4) as u32));
        let l = &mut self.losses;
        *l = StepLosses::default();
        for v in [&mut l.total, &mut l.l1, &mut l.ssim, &mut l.mse] {
            *v = f64::from_bits(word(8));
        }
        let s = &mut self.stats;
        s.grad2d.resize(n, [0.0; 2]);
        s.radius.resize(n, 0);
        #[allow(clippy::cast_possible_truncation, reason = "4-byte words")]
        for (g, r) in s.grad2d.iter_mut().zip(&mut s.radius) {
            g[0] = f32::from_bits(word(4) as u32);
            g[1] = f32::from_bits(word(4) as u32);
            *r = word(4) as u32;
        }
        #[allow(clippy::cast_possible_truncation, reason = "image sizes")]
        {
            s.size = (word(8) as usize, word(8) as usize);
        }
        Ok(at)
    }
}

/// This rank's part of a batch and where it lands: the K views' first time (for the
/// regularisers), the batch size K and the views this rank computes (K/P of them).
#[derive(Clone, Copy, Debug)]
pub struct BatchPart<'a> {
    /// The batch size K (all ranks together).
    pub batch: usize,
    /// The time of the batch's first view (the regularisers' time).
    pub first_time: f64,
    /// This rank's views, `rank·K/P .. (rank+1)·K/P` of the batch.
    pub mine: &'a [&'a ViewData<f32>],
}

/// The loss and gradient of a batch of K views spread over the ranks of `collective` (one
/// rank: all K here): this rank's shares into `shares[rank·K/P ..]`, the others gathered,
/// all summed in view order into `grad` (overwritten), then the regularisers. Every rank
/// returns the same bits, and one process gives the same bits as P.
///
/// # Errors
/// A gathering failed.
///
/// # Panics
/// If K is not `mine.len()·P`.
#[allow(
    clippy::too_many_arguments,
    reason = "the step's inputs, as the other step functions"
)]
pub fn shared_batch_loss_and_grad(
    model: &mut Model<f32>,
    part: BatchPart<'_>,
    collective: &dyn Collective,
    opts: &RenderOptions<f32>,
    s: &StepSettings,
    ws: &mut StepWorkspace<f32>,
    shares: &mut Vec<ViewShare<f32>>,
    grad: &mut ModelGrad<f32>,
) -> Result<(StepLosses, ScreenStats<f32>), String> {
    let (rank, size) = (collective.rank(), collective.size());
    let m = part.mine.len();
    assert_eq!(m * size, part.batch, "each rank computes K/P views");
    let weight = 1.0 / part.batch as f64;
    shares.resize_with(part.batch, ViewShare::default);
    for sh in shares.iter_mut() {
        match &mut sh.grad {
            Some(g) if g.same_shape(grad) => g.fill_zero(opts.par),
            _ => sh.grad = Some(model.zero_grad()),
        }
    }
    let mut local = super::step::StepTimings::default();
    for (j, view) in part.mine.iter().enumerate() {
        let sh = &mut shares[rank * m + j];
        let g = sh.grad.as_mut().expect("allocated above");
        let (l, st) = view_loss_and_grad(model, view, opts, s, weight, ws, g);
        local.add(&l.timings);
        sh.losses = l;
        sh.stats = st;
    }
    let clock = std::time::Instant::now();
    if size > 1 {
        let mut bytes = Vec::new();
        for sh in &shares[rank * m..(rank + 1) * m] {
            sh.encode(&mut bytes);
        }
        let all = collective.all_gather(&bytes)?;
        if all.len() != bytes.len() * size {
            return Err(format!(
                "gathered {} bytes from {size} ranks where {} were expected: the ranks' models differ",
                all.len(),
                bytes.len() * size
            ));
        }
        let n = model.len();
        // Every other rank's shares, decoded in place; this rank's own are already there
        // (the same bits as their encoding).
        let per_rank = bytes.len();
        for (r, chunk) in all.chunks_exact(per_rank).enumerate() {
            if r == rank {
                continue;
            }
            let mut at = 0;
            for sh in &mut shares[r * m..(r + 1) * m] {
                at += sh.decode(&chunk[at..], n)?;
            }
        }
    }
    let (mut losses, stats) = reduce_shares(shares, weight, grad);
    local.exchange = clock.elapsed().as_secs_f64();
    losses.timings = local;
    regularizers_and_grad(model, part.first_time, s, ws, grad, &mut losses);
    Ok((losses, stats))
}
