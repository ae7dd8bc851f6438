//! The displacement of the canonical Gaussians by a field read at one time, and its VJP:
//! `p = p₀ + Δp`, `R = Exp(Δω)·R̂₀`, `s = s₀ + Δs` with `[Δp, Δω, Δs] = field(p₀, t)`.
//!
//! The deformation motion (4DGS) renders this state; continuous waypoints
//! ([`Waypoints::Continuous`](super::Waypoints::Continuous)) start a hop of the velocity
//! field from it. Both use these two functions with their own field.

use super::{StateMut, StateRef};
use crate::field::{Batch, BatchVjp, FieldRecord, Gemm, NeuralField};
use evogs_math::activation::normalize_quat_vjp;
use evogs_math::update::{exp_update_left, exp_update_left_vjp};
use evogs_math::{Par, Quat, Vec3};
use evogs_splat::Splats;

/// Network outputs per Gaussian: `[Δp, Δω, Δs]`.
pub const OUTPUTS: usize = 9;

/// Gaussians per task of the per-Gaussian loops (a fixed number: each Gaussian's result
/// depends on it alone, so any thread count gives the same bits).
const RUN: usize = 2048;

/// The canonical positions, flat (`3N`).
#[must_use]
pub fn flat_positions<T: Gemm>(canonical: &Splats<T>) -> Vec<T> {
    canonical.means.iter().flat_map(|v| v.to_array()).collect()
}

/// Gaussian `i` of `canonical` displaced by its network outputs `o = [Δp, Δω, Δs]`:
/// `(p₀ + Δp, Exp(Δω)·q̂₀, s₀ + Δs)` (the rotation unit up to rounding, not renormalised).
#[must_use]
pub fn displaced<T: Gemm>(canonical: &Splats<T>, i: usize, o: &[T]) -> (Vec3<T>, Quat<T>, Vec3<T>) {
    (
        canonical.means[i] + Vec3::from_slice(o),
        exp_update_left(
            canonical.quats[i].normalize(),
            Vec3::from_slice(&o[3..]),
            T::ONE,
        ),
        canonical.log_scales[i] + Vec3::from_slice(&o[6..]),
    )
}

/// Writes the canonical Gaussians displaced by `field` at `t` into `out` (positions,
/// log-scales, rotations) and returns the network outputs (`N × 9`, for [`displace_vjp`]);
/// the field's activations go to `record`.
pub fn displace<T: Gemm>(
    field: &mut NeuralField<T>,
    record: &mut FieldRecord<T>,
    canonical: &Splats<T>,
    t: T,
    out: StateMut<'_, T>,
) -> Vec<T> {
    let (means, log_scales, quats) = out;
    let n = canonical.len();
    let pos = flat_positions(canonical);
    let mut net = vec![T::ZERO; n * OUTPUTS];
    let at = Batch {
        t,
        positions: &pos,
        stride: 3,
        n,
    };
    field.eval_batch(&at, &mut net, Some(record));
    let run = |first: usize, (m, s, q): StateMut<'_, T>| {
        for (j, ((m, q), s)) in m.iter_mut().zip(q).zip(s).enumerate() {
            let i = first + j;
            (*m, *q, *s) = displaced(canonical, i, &net[i * OUTPUTS..]);
        }
    };
    match field.par() {
        Par::Seq => run(0, (means, log_scales, quats)),
        #[cfg(feature = "rayon")]
        Par::Rayon => {
            use rayon::prelude::*;
            means
                .par_chunks_mut(RUN)
                .zip(log_scales.par_chunks_mut(RUN))
                .zip(quats.par_chunks_mut(RUN))
                .enumerate()
                .for_each(|(k, ((m, s), q))| run(k * RUN, (m, s, q)));
        }
    }
    net
}

/// The VJP of [`displace`]: for the cotangent `d` of the displaced positions, log-scales
/// and rotations (ambient, of the unit quaternion), **adds** the gradients of the canonical
/// positions, log-scales and raw quaternions into `grad` and of the field's parameters into
/// `d_params`. `record` is the forward pass's record when it is still current (`None`
/// evaluates the field again).
#[allow(
    clippy::too_many_arguments,
    reason = "the field, its record, the state, the time, the outputs, the cotangent and two gradients"
)]
pub fn displace_vjp<T: Gemm>(
    field: &mut NeuralField<T>,
    record: Option<&FieldRecord<T>>,
    canonical: &Splats<T>,
    t: T,
    net: &[T],
    d: StateRef<'_, T>,
    grad: StateMut<'_, T>,
    d_params: &mut [T],
) {
    let (d_means, d_log_scales, d_quats) = d;
    let (g_means, g_log_scales, g_quats) = grad;
    let n = canonical.len();
    let mut d_net = vec![T::ZERO; n * OUTPUTS];
    let run = |first: usize, d_net: &mut [T], (g_means, g_log_scales, g_quats): StateMut<'_, T>| {
        for (j, dn) in d_net.chunks_exact_mut(OUTPUTS).enumerate() {
            let i = first + j;
            let q0 = canonical.quats[i];
            let o = &net[i * OUTPUTS..];
            let g = exp_update_left_vjp(
                q0.normalize(),
                Vec3::from_slice(&o[3..]),
                T::ONE,
                d_quats[i],
            );
            d_means[i].write_to(dn);
            g.omega.write_to(&mut dn[3..]);
            d_log_scales[i].write_to(&mut dn[6..]);
            g_means[j] += d_means[i];
            g_log_scales[j] += d_log_scales[i];
            g_quats[j] = g_quats[j] + normalize_quat_vjp(q0, g.q);
        }
    };
    match field.par() {
        Par::Seq => run(
            0,
            &mut d_net,
            (&mut *g_means, &mut *g_log_scales, &mut *g_quats),
        ),
        #[cfg(feature = "rayon")]
        Par::Rayon => {
            use rayon::prelude::*;
            d_net
                .par_chunks_mut(RUN * OUTPUTS)
                .zip(g_means.par_chunks_mut(RUN))
                .zip(g_log_scales.par_chunks_mut(RUN))
                .zip(g_quats.par_chunks_mut(RUN))
                .enumerate()
                .for_each(|(k, (((dn, m), s), q))| run(k * RUN, dn, (m, s, q)));
        }
    }
    let pos = flat_positions(canonical);
    let mut d_pos = vec![T::ZERO; n * 3];
    field.vjp_batch(BatchVjp {
        at: Batch {
            t,
            positions: &pos,
            stride: 3,
            n,
        },
        record,
        d_out: &d_net,
        d_positions: &mut d_pos,
        d_stride: 3,
        d_params,
    });
    for i in 0..n {
        g_means[i] += Vec3::from_slice(&d_pos[i * 3..]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::TrainConfig;
    use crate::field::TimeMapping;
    use evogs_splat::random_scene;

    /// The displacement and its VJP on the pool are bitwise the sequential ones, over more
    /// Gaussians than one run (and a ragged last run).
    #[test]
    fn the_pool_gives_the_bits_of_one_thread() {
        let n = 2 * RUN + 37;
        let (canonical, _) = random_scene::<f32>(n, 32, 4, [0.01, 0.05], [0.3, 0.9]);
        let cfg = TrainConfig::fast().field;
        let time = TimeMapping::Normalized {
            t_min: 0.0,
            t_max: 1.0,
        };
        let run = |par: Par| {
            let mut field = NeuralField::new(&cfg, [-2.0; 3], [2.0; 3], time, 7);
            // Non-zero output weights, so that the displacement moves every Gaussian.
            for (i, p) in field.params_mut().iter_mut().enumerate() {
                #[allow(clippy::cast_precision_loss, reason = "test values")]
                let v = ((i * 7919) % 1000) as f32 * 1e-3 - 0.5;
                *p = v * 0.2;
            }
            field.set_par(par);
            field.set_count(n);
            let (mut m, mut s, mut q) = (
                canonical.means.clone(),
                canonical.log_scales.clone(),
                canonical.quats.clone(),
            );
            let mut record = FieldRecord::default();
            let net = displace(
                &mut field,
                &mut record,
                &canonical,
                0.3,
                (&mut m, &mut s, &mut q),
            );
            let (dm, ds, dq) = (m.clone(), s.clone(), q.clone());
            let (mut gm, mut gs, mut gq) = (m.clone(), s.clone(), q.clone());
            let mut d_params = vec![0.0; field.params().len()];
            displace_vjp(
                &mut field,
                Some(&record),
                &canonical,
                0.3,
                &net,
                (&dm, &ds, &dq),
                (&mut gm, &mut gs, &mut gq),
                &mut d_params,
            );
            let flat = |v: Vec<f32>| v.into_iter().map(f32::to_bits).collect::<Vec<_>>();
            let vec3s = |v: &[Vec3<f32>]| flat(v.iter().flat_map(|x| x.to_array()).collect());
            let quats =
                |v: &[Quat<f32>]| flat(v.iter().flat_map(|x| [x.w, x.x, x.y, x.z]).collect());
            (
                [vec3s(&m), vec3s(&s), quats(&q)],
                [vec3s(&gm), vec3s(&gs), quats(&gq)],
                flat(d_params),
            )
        };
        let seq = run(Par::Seq);
        let before = |v: &[Vec3<f32>]| {
            v.iter()
                .flat_map(|x| x.to_array())
                .map(f32::to_bits)
                .collect::<Vec<_>>()
        };
        assert_ne!(seq.0[0], before(&canonical.means), "the Gaussians moved");
        assert_eq!(
            seq,
            run(Par::best()),
            "states, gradients and field gradient"
        );
    }
}
