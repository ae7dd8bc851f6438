//! [`SecondOrderField`]: the neural field read as an **acceleration** field, the right-hand
//! side of Newtonian dynamics of the Gaussians, which carry their own velocities.
//!
//! The state of Gaussian `i` is `[p (3), q̂ (4, unit), s (3), v (3), ω (3)]`
//! ([`second_order_layout`]: `[Euclidean(3), So3, Euclidean(3), Euclidean(6)]`, tangent 15)
//! and
//!
//! ```text
//! dp/dt = v,   dR/dt = ω^·R,   ds/dt = ṡ(p),   dv/dt = a(p),   dω/dt = α(p),
//! [a, α, ṡ] = MLP(HexPlane(p, t))            (the field's three heads)
//! ```
//!
//! so the field never sees the velocity: a Gaussian's motion continues by inertia and the
//! field only bends it. With an autonomous time mapping this is a learned force law of
//! position alone, the same inside the window and after it.
//!
//! VJP: for the cotangent `w = [w_p, w_δ, w_s, w_v, w_ω]` of `f`, `∂/∂v += w_p`,
//! `∂/∂ω += w_δ`, and `[w_v, w_ω, w_s]` goes through the field's VJP into `∂/∂p` and `∂/∂θ`.

use super::gemm::Gemm;
use super::neural::{Batch, BatchVjp, FieldRecord, NeuralField};
use evogs_ode::{Block, StateLayout, VectorField};

/// State entries per Gaussian: position, quaternion, log-scale, velocity, angular velocity.
pub const SECOND_ORDER_STRIDE: usize = 16;
/// Tangent entries per Gaussian.
pub const SECOND_ORDER_TANGENT: usize = 15;
/// Field outputs per Gaussian.
const OUT: usize = 9;

/// The layout of the second-order state of `count` Gaussians.
#[must_use]
pub fn second_order_layout(count: usize) -> StateLayout {
    StateLayout::particles(
        &[
            Block::Euclidean(3),
            Block::So3,
            Block::Euclidean(3),
            Block::Euclidean(6),
        ],
        count,
    )
}

/// A [`NeuralField`] borrowed as the acceleration field of `count` Gaussians.
#[derive(Debug)]
pub struct SecondOrderField<'a, T> {
    field: &'a mut NeuralField<T>,
    count: usize,
    out: Vec<T>,
    d_out: Vec<T>,
}

impl<'a, T: Gemm> SecondOrderField<'a, T> {
    /// The second-order dynamics of `count` Gaussians under `field`.
    pub fn new(field: &'a mut NeuralField<T>, count: usize) -> Self {
        Self {
            field,
            count,
            out: vec![T::ZERO; count * OUT],
            d_out: vec![T::ZERO; count * OUT],
        }
    }

    fn batch<'y>(&self, t: T, y: &'y [T]) -> Batch<'y, T> {
        Batch {
            t,
            positions: y,
            stride: SECOND_ORDER_STRIDE,
            n: self.count,
        }
    }

    fn write(&self, y: &[T], dydt: &mut [T]) {
        for i in 0..self.count {
            let s = &y[i * SECOND_ORDER_STRIDE..];
            let o = &self.out[i * OUT..];
            let d = &mut dydt[i * SECOND_ORDER_TANGENT..(i + 1) * SECOND_ORDER_TANGENT];
            d[..3].copy_from_slice(&s[10..13]);
            d[3..6].copy_from_slice(&s[13..16]);
            d[6..9].copy_from_slice(&o[6..9]);
            d[9..15].copy_from_slice(&o[..6]);
        }
    }

    fn vjp_with(
        &mut self,
        t: T,
        y: &[T],
        record: Option<&FieldRecord<T>>,
        w: &[T],
        d_y: &mut [T],
        d_params: &mut [T],
    ) {
        for i in 0..self.count {
            let wi = &w[i * SECOND_ORDER_TANGENT..(i + 1) * SECOND_ORDER_TANGENT];
            let o = &mut self.d_out[i * OUT..(i + 1) * OUT];
            o[..6].copy_from_slice(&wi[9..15]);
            o[6..9].copy_from_slice(&wi[6..9]);
            let d = &mut d_y[i * SECOND_ORDER_TANGENT..(i + 1) * SECOND_ORDER_TANGENT];
            for k in 0..6 {
                d[9 + k] += wi[k];
            }
        }
        let at = self.batch(t, y);
        self.field.vjp_batch(BatchVjp {
            at,
            record,
            d_out: &self.d_out,
            d_positions: d_y,
            d_stride: SECOND_ORDER_TANGENT,
            d_params,
        });
    }
}

impl<T: Gemm> VectorField<T> for SecondOrderField<'_, T> {
    type Record = FieldRecord<T>;
    fn dim(&self) -> usize {
        self.count * SECOND_ORDER_TANGENT
    }
    fn layout(&self) -> StateLayout {
        second_order_layout(self.count)
    }
    fn n_params(&self) -> usize {
        self.field.params().len()
    }
    fn eval(&mut self, t: T, y: &[T], dydt: &mut [T]) {
        let at = self.batch(t, y);
        let mut out = core::mem::take(&mut self.out);
        self.field.eval_batch(&at, &mut out, None);
        self.out = out;
        self.write(y, dydt);
    }
    fn vjp(&mut self, t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        self.vjp_with(t, y, None, w, d_y, d_params);
    }
    fn eval_recorded(&mut self, t: T, y: &[T], dydt: &mut [T], record: &mut FieldRecord<T>) {
        let at = self.batch(t, y);
        let mut out = core::mem::take(&mut self.out);
        self.field.eval_batch(&at, &mut out, Some(record));
        self.out = out;
        self.write(y, dydt);
    }
    fn vjp_recorded(
        &mut self,
        t: T,
        y: &[T],
        record: &FieldRecord<T>,
        w: &[T],
        d_y: &mut [T],
        d_params: &mut [T],
    ) {
        self.vjp_with(t, y, Some(record), w, d_y, d_params);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::{HexPlaneConfig, NeuralFieldConfig, TimeMapping};
    use evogs_math::diff::{GradCheck, central_jvp, vjp_dot_test};
    use evogs_math::rng::SplitMix64;

    fn field() -> NeuralField<f64> {
        let cfg = NeuralFieldConfig {
            hexplane: HexPlaneConfig {
                channels: 2,
                resolution: [4, 4, 4, 3],
                multires: vec![1],
            },
            width: 6,
            output_scales: [1.0, 1.0, 0.5],
            zero_init_output: false,
        };
        let time = TimeMapping::Normalized {
            t_min: 0.0,
            t_max: 1.0,
        };
        NeuralField::new(&cfg, [-1.0; 3], [1.0; 3], time, 7)
    }

    /// The VJP against central differences of `f` in the positions and velocities (the
    /// rotations and log-scales do not enter `f`), and the dot-product test.
    #[test]
    fn the_vjp_matches_central_differences() {
        let mut f = field();
        let n = 3;
        let mut rng = SplitMix64::new(5);
        let mut y = Vec::new();
        for _ in 0..n {
            let q = evogs_math::Quat::new(rng.normal(), rng.normal(), rng.normal(), rng.normal())
                .normalize();
            y.extend_from_slice(&[rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6), 0.1]);
            y.extend_from_slice(&[q.w, q.x, q.y, q.z, -2.0, -2.1, -1.9]);
            for _ in 0..6 {
                y.push(rng.uniform(-1.0, 1.0));
            }
        }
        let t = 0.4;
        let w: Vec<f64> = (0..n * SECOND_ORDER_TANGENT)
            .map(|_| rng.uniform(-1.0, 1.0))
            .collect();
        let mut d_y = vec![0.0; n * SECOND_ORDER_TANGENT];
        let mut d_p = vec![0.0; f.params().len()];
        SecondOrderField::new(&mut f, n).vjp(t, &y, &w, &mut d_y, &mut d_p);
        // Euclidean entries of the state: position (0..3), velocities (10..16) ↔ tangent
        // (0..3), (9..15).
        let pairs: Vec<(usize, usize)> = (0..n)
            .flat_map(|i| {
                (0..3)
                    .map(move |k| (i * 16 + k, i * 15 + k))
                    .chain((0..6).map(move |k| (i * 16 + 10 + k, i * 15 + 9 + k)))
            })
            .collect();
        let eval = |f: &mut NeuralField<f64>, y: &[f64]| {
            let mut out = vec![0.0; n * SECOND_ORDER_TANGENT];
            SecondOrderField::new(f, n).eval(t, y, &mut out);
            out.iter().zip(&w).map(|(a, b)| a * b).sum::<f64>()
        };
        let tol = GradCheck::new(1e-8, 1e-6);
        let mut analytic = Vec::new();
        let mut numeric = Vec::new();
        for &(ya, yt) in &pairs {
            let h = 1e-6;
            let mut yp = y.clone();
            yp[ya] += h;
            let mut ym = y.clone();
            ym[ya] -= h;
            numeric.push((eval(&mut f, &yp) - eval(&mut f, &ym)) / (2.0 * h));
            analytic.push(d_y[yt]);
        }
        for k in (0..f.params().len()).step_by(7) {
            let h = 1e-6;
            let x0 = f.params()[k];
            f.params_mut()[k] = x0 + h;
            let lp = eval(&mut f, &y);
            f.params_mut()[k] = x0 - h;
            let lm = eval(&mut f, &y);
            f.params_mut()[k] = x0;
            numeric.push((lp - lm) / (2.0 * h));
            analytic.push(d_p[k]);
        }
        let rep = tol.check(&analytic, &numeric);
        assert!(rep.passed(), "{rep:?}");
        // Dot-product test in the Euclidean state entries: ⟨w, J v⟩ = ⟨Jᵀ w, v⟩ with J v by
        // central differences.
        let x0: Vec<f64> = pairs.iter().map(|&(ya, _)| y[ya]).collect();
        let m = pairs.len();
        let np = f.params().len();
        let cell = core::cell::RefCell::new(f);
        let err = vjp_dot_test(
            |v: &[f64], o: &mut [f64]| {
                central_jvp(
                    |x: &[f64], out: &mut [f64]| {
                        let mut ys = y.clone();
                        for (&(ya, _), &xv) in pairs.iter().zip(x) {
                            ys[ya] = xv;
                        }
                        SecondOrderField::new(&mut cell.borrow_mut(), n).eval(t, &ys, out);
                    },
                    &x0,
                    v,
                    o,
                );
            },
            |w: &[f64], o: &mut [f64]| {
                let mut d_y = vec![0.0; n * SECOND_ORDER_TANGENT];
                let mut d_p = vec![0.0; np];
                SecondOrderField::new(&mut cell.borrow_mut(), n).vjp(t, &y, w, &mut d_y, &mut d_p);
                for (k, &(_, yt)) in pairs.iter().enumerate() {
                    o[k] = d_y[yt];
                }
            },
            m,
            n * SECOND_ORDER_TANGENT,
            9,
        );
        assert!(err < 1e-8, "dot-product test: {err:e}");
    }
}
