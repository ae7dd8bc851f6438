//! The HexPlane regularisers of EvoGS/4DGS (`docs/losses.md` §6), with gradients.
//!
//! - `smoothness(P)`: the mean over all entries of `(P[h+2] − 2P[h+1] + P[h])²`, a squared
//!   **second** difference along the rows (the plane's second coordinate: y or z for spatial
//!   planes, t for space-time planes);
//! - plane TV = Σ over levels and spatial planes of smoothness; time smoothness = the same
//!   over space-time planes; L1 time = Σ over space-time planes of mean |1 − P|.
//!
//! `total = w_tv·tv + w_time·time_smooth + w_l1·l1_time`.

use super::hexplane::{HexPlane, SPACE_PLANES, TIME_PLANES};
use evogs_math::Real;

/// Weights of the three plane regularisers.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PlaneRegWeights {
    /// Weight of the spatial-plane smoothness ("plane TV").
    pub plane_tv: f64,
    /// Weight of the space-time-plane smoothness.
    pub time_smoothness: f64,
    /// Weight of the L1 of space-time planes toward 1.
    pub l1_time: f64,
}

/// The unweighted regulariser values and the weighted total.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlaneRegValues {
    /// Σ smoothness over spatial planes.
    pub plane_tv: f64,
    /// Σ smoothness over space-time planes.
    pub time_smoothness: f64,
    /// Σ mean |1 − P| over space-time planes.
    pub l1_time: f64,
    /// Weighted sum.
    pub total: f64,
}

fn smoothness<T: Real>(
    plane: &[T],
    rows: usize,
    row_len: usize,
    weight: f64,
    grad: &mut [T],
) -> f64 {
    if rows < 3 {
        return 0.0;
    }
    let count = ((rows - 2) * row_len) as f64;
    let g = T::from_f64(2.0 * weight / count);
    let mut acc = 0.0;
    for h in 0..rows - 2 {
        for k in 0..row_len {
            let (a, b, c) = (
                h * row_len + k,
                (h + 1) * row_len + k,
                (h + 2) * row_len + k,
            );
            let d = plane[c] - T::TWO * plane[b] + plane[a];
            acc += d.to_f64() * d.to_f64();
            let gd = g * d;
            grad[c] += gd;
            grad[b] -= T::TWO * gd;
            grad[a] += gd;
        }
    }
    acc / count
}

fn l1_to_one<T: Real>(plane: &[T], weight: f64, grad: &mut [T]) -> f64 {
    let count = plane.len() as f64;
    let g = T::from_f64(weight / count);
    let mut acc = 0.0;
    for (p, d) in plane.iter().zip(grad.iter_mut()) {
        let r = *p - T::ONE;
        acc += r.abs().to_f64();
        if r > T::ZERO {
            *d += g;
        } else if r < T::ZERO {
            *d -= g;
        }
    }
    acc / count
}

/// Evaluates the regularisers on the plane parameters (`params[..hex.n_params()]`) and adds
/// the weighted gradient into `d_params`.
pub fn plane_regularizers<T: Real>(
    hex: &HexPlane,
    params: &[T],
    w: &PlaneRegWeights,
    d_params: &mut [T],
) -> PlaneRegValues {
    let mut v = PlaneRegValues::default();
    let ch = hex.channels();
    for l in 0..hex.levels() {
        for p in SPACE_PLANES {
            let r = hex.plane_range(l, p);
            let (rows, cols) = hex.plane_shape(l, p);
            v.plane_tv += smoothness(
                &params[r.clone()],
                rows,
                cols * ch,
                w.plane_tv,
                &mut d_params[r],
            );
        }
        for p in TIME_PLANES {
            let r = hex.plane_range(l, p);
            let (rows, cols) = hex.plane_shape(l, p);
            v.time_smoothness += smoothness(
                &params[r.clone()],
                rows,
                cols * ch,
                w.time_smoothness,
                &mut d_params[r.clone()],
            );
            v.l1_time += l1_to_one(&params[r.clone()], w.l1_time, &mut d_params[r]);
        }
    }
    v.total =
        w.plane_tv * v.plane_tv + w.time_smoothness * v.time_smoothness + w.l1_time * v.l1_time;
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::hexplane::{HexPlaneConfig, TimeMapping};
    use evogs_math::diff::{GradCheck, central_gradient};
    use evogs_math::rng::SplitMix64;

    #[test]
    fn gradient_matches_central_differences() {
        let cfg = HexPlaneConfig {
            channels: 2,
            resolution: [3, 4, 3, 5],
            multires: vec![1],
        };
        let hex = HexPlane::new(
            &cfg,
            [-1.0; 3],
            [1.0; 3],
            TimeMapping::Normalized {
                t_min: -1.0,
                t_max: 1.0,
            },
        );
        let mut rng = SplitMix64::new(3);
        let mut x: Vec<f64> = (0..hex.n_params()).map(|_| rng.uniform(0.0, 2.0)).collect();
        let w = PlaneRegWeights {
            plane_tv: 0.7,
            time_smoothness: 1.3,
            l1_time: 0.4,
        };
        let mut g = vec![0.0; x.len()];
        let v = plane_regularizers(&hex, &x, &w, &mut g);
        assert!(v.total > 0.0, "non-trivial value");
        let mut num = vec![0.0; x.len()];
        central_gradient(
            |p: &[f64]| {
                let mut d = vec![0.0; p.len()];
                plane_regularizers(&hex, p, &w, &mut d).total
            },
            &mut x,
            &mut num,
        );
        GradCheck::new(1e-8, 1e-6)
            .check(&g, &num)
            .assert_passed("plane regularisers");
    }
}
