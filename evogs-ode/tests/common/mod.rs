//! Shared test helpers: a parameterised particle field with SO(3) blocks, tangent-space
//! perturbations of states, and linear losses with their cotangents.
#![allow(dead_code, reason = "each test binary uses a subset of the helpers")]

use evogs_math::rng::SplitMix64;
use evogs_math::so3::exp_quat;
use evogs_math::{Quat, Real, Vec3};
use evogs_ode::{Block, StateLayout, VectorField};

/// A coupled particle field on `[Euclidean(3) p, So3 R, Euclidean(2) s] × count`:
///
/// ```text
/// p' = A tanh(p) + B (R e_z) + t u
/// ω  = C p + D (R e_x) + sin(t) e          (world-frame angular velocity)
/// s' = −k ⊙ s + (R e_y)_{xy}
/// θ  = [A, B, C, D (3×3 row-major), u, e (3), k (2)]   (44 entries, shared by particles)
/// ```
///
/// Every block depends on the rotation, and the rotation's rate on position and rotation.
#[derive(Clone, Debug)]
pub(crate) struct CoupledField<T> {
    pub(crate) theta: Vec<T>,
    pub(crate) count: usize,
}

pub(crate) const N_THETA: usize = 44;

fn mat<T: Real>(th: &[T], k: usize) -> evogs_math::Mat3<T> {
    let m = &th[9 * k..9 * k + 9];
    evogs_math::Mat3::from_rows([[m[0], m[1], m[2]], [m[3], m[4], m[5]], [m[6], m[7], m[8]]])
}

impl<T: Real> CoupledField<T> {
    pub(crate) fn random(count: usize, seed: u64) -> Self {
        let mut rng = SplitMix64::new(seed);
        let theta = (0..N_THETA)
            .map(|i| {
                // Decay rates k positive, the rest of either sign.
                let v = if i >= 42 {
                    rng.uniform(0.2, 1.0)
                } else {
                    rng.uniform(-0.6, 0.6)
                };
                T::from_f64(v)
            })
            .collect();
        Self { theta, count }
    }

    pub(crate) fn layout_for(count: usize) -> StateLayout {
        StateLayout::particles(
            &[Block::Euclidean(3), Block::So3, Block::Euclidean(2)],
            count,
        )
    }
}

impl<T: Real> VectorField<T> for CoupledField<T> {
    fn dim(&self) -> usize {
        8 * self.count
    }
    fn layout(&self) -> StateLayout {
        Self::layout_for(self.count)
    }
    fn n_params(&self) -> usize {
        N_THETA
    }
    fn eval(&mut self, t: T, y: &[T], dydt: &mut [T]) {
        let th = &self.theta;
        let (a, b, c, d) = (mat(th, 0), mat(th, 1), mat(th, 2), mat(th, 3));
        let u = Vec3::from_slice(&th[36..]);
        let e = Vec3::from_slice(&th[39..]);
        for i in 0..self.count {
            let ys = &y[9 * i..];
            let out = &mut dydt[8 * i..];
            let p = Vec3::from_slice(ys);
            let q = Quat::from_slice(&ys[3..]);
            let (gx, gy, gz) = (
                q.rotate(Vec3::unit(0)),
                q.rotate(Vec3::unit(1)),
                q.rotate(Vec3::unit(2)),
            );
            let v = a.mul_vec(p.map(Real::tanh)) + b.mul_vec(gz) + u * t;
            let w = c.mul_vec(p) + d.mul_vec(gx) + e * t.sin();
            v.write_to(out);
            w.write_to(&mut out[3..]);
            out[6] = -th[42] * ys[7] + gy.x;
            out[7] = -th[43] * ys[8] + gy.y;
        }
    }
    fn vjp(&mut self, t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        let th = &self.theta;
        let (a, b, c, d) = (mat(th, 0), mat(th, 1), mat(th, 2), mat(th, 3));
        for i in 0..self.count {
            let ys = &y[9 * i..];
            let ws = &w[8 * i..];
            let p = Vec3::from_slice(ys);
            let q = Quat::from_slice(&ys[3..]);
            let (gx, gy, gz) = (
                q.rotate(Vec3::unit(0)),
                q.rotate(Vec3::unit(1)),
                q.rotate(Vec3::unit(2)),
            );
            let tp = p.map(Real::tanh);
            let (wp, ww) = (Vec3::from_slice(ws), Vec3::from_slice(&ws[3..]));
            let wg = Vec3::new(ws[6], ws[7], T::ZERO);
            // Position.
            let dtanh = a.tr_mul_vec(wp).mul_elem(tp.map(|x| T::ONE - x * x));
            let dp = dtanh + c.tr_mul_vec(ww);
            dp.add_to(&mut d_y[8 * i..]);
            // Rotation (left perturbation): ∂(R a)/∂δ = −(R a)^, VJP (R a) × ḡ.
            let drot = gz.cross(b.tr_mul_vec(wp)) + gx.cross(d.tr_mul_vec(ww)) + gy.cross(wg);
            drot.add_to(&mut d_y[8 * i + 3..]);
            // Extra block.
            d_y[8 * i + 6] -= th[42] * ws[6];
            d_y[8 * i + 7] -= th[43] * ws[7];
            // Parameters.
            for r in 0..3 {
                for col in 0..3 {
                    d_params[r * 3 + col] += wp[r] * tp[col];
                    d_params[9 + r * 3 + col] += wp[r] * gz[col];
                    d_params[18 + r * 3 + col] += ww[r] * p[col];
                    d_params[27 + r * 3 + col] += ww[r] * gx[col];
                }
            }
            (wp * t).add_to(&mut d_params[36..]);
            (ww * t.sin()).add_to(&mut d_params[39..]);
            d_params[42] -= ys[7] * ws[6];
            d_params[43] -= ys[8] * ws[7];
        }
    }
}

/// A random state for a layout: Euclidean entries in [−1, 1), random unit quaternions.
pub(crate) fn random_state(layout: &StateLayout, seed: u64) -> Vec<f64> {
    let mut rng = SplitMix64::new(seed);
    let mut y = vec![0.0; layout.ambient_len()];
    let pa = layout.particle_ambient_len();
    for p in 0..layout.count() {
        for sp in layout.spans() {
            let o = p * pa + sp.ambient;
            match sp.block {
                Block::Euclidean(m) => {
                    for v in &mut y[o..o + m] {
                        *v = rng.uniform(-1.0, 1.0);
                    }
                }
                Block::So3 => {
                    let phi = Vec3::new(
                        rng.uniform(-2.0, 2.0),
                        rng.uniform(-2.0, 2.0),
                        rng.uniform(-2.0, 2.0),
                    );
                    exp_quat(phi).write_to(&mut y[o..]);
                }
            }
        }
    }
    y
}

/// `y ⊕ v`: `y + v` on Euclidean entries, `Exp(v)·R` on SO(3) blocks (v tangent).
pub(crate) fn retract<T: Real>(layout: &StateLayout, y: &[T], v: &[T]) -> Vec<T> {
    let mut out = y.to_vec();
    let (pa, pt) = (layout.particle_ambient_len(), layout.particle_tangent_len());
    for p in 0..layout.count() {
        for sp in layout.spans() {
            let (o, ot) = (p * pa + sp.ambient, p * pt + sp.tangent);
            match sp.block {
                Block::Euclidean(m) => {
                    for e in 0..m {
                        out[o + e] = y[o + e] + v[ot + e];
                    }
                }
                Block::So3 => {
                    let q = Quat::from_slice(&y[o..]);
                    exp_quat(Vec3::from_slice(&v[ot..]))
                        .mul_quat(q)
                        .write_to(&mut out[o..]);
                }
            }
        }
    }
    out
}

/// A linear loss in the state: `Σ c_e y_e` over Euclidean entries plus `Σ aᵀ R b` over
/// SO(3) blocks, with fixed seeded weights.
#[derive(Clone, Debug)]
pub(crate) struct Loss {
    layout: StateLayout,
    weights: Vec<f64>,
    a: Vec<Vec3<f64>>,
    b: Vec<Vec3<f64>>,
}

impl Loss {
    pub(crate) fn new(layout: StateLayout, seed: u64) -> Self {
        let mut rng = SplitMix64::new(seed);
        let weights = (0..layout.ambient_len())
            .map(|_| rng.uniform(-1.0, 1.0))
            .collect();
        let blocks = layout.count() * layout.pattern().len();
        let mut v3 = || {
            Vec3::new(
                rng.uniform(-1.0, 1.0),
                rng.uniform(-1.0, 1.0),
                rng.uniform(-1.0, 1.0),
            )
        };
        let a = (0..blocks).map(|_| v3()).collect();
        let b = (0..blocks).map(|_| v3()).collect();
        Self {
            layout,
            weights,
            a,
            b,
        }
    }

    pub(crate) fn value(&self, y: &[f64]) -> f64 {
        let (pa, nb) = (
            self.layout.particle_ambient_len(),
            self.layout.pattern().len(),
        );
        let mut acc = 0.0;
        for p in 0..self.layout.count() {
            for (bi, sp) in self.layout.spans().enumerate() {
                let o = p * pa + sp.ambient;
                match sp.block {
                    Block::Euclidean(m) => {
                        acc += (o..o + m).map(|e| self.weights[e] * y[e]).sum::<f64>();
                    }
                    Block::So3 => {
                        let q = Quat::from_slice(&y[o..]).normalize();
                        let k = p * nb + bi;
                        acc += self.a[k].dot(q.rotate(self.b[k]));
                    }
                }
            }
        }
        acc
    }

    /// `∂L/∂y` in tangent coordinates: `c` on Euclidean entries, `(R b) × a` on SO(3)
    /// blocks (left perturbation: `aᵀ Exp(δ) R b ≈ aᵀRb + δ·((Rb) × a)`).
    pub(crate) fn gradient(&self, y: &[f64]) -> Vec<f64> {
        let (pa, pt, nb) = (
            self.layout.particle_ambient_len(),
            self.layout.particle_tangent_len(),
            self.layout.pattern().len(),
        );
        let mut g = vec![0.0; self.layout.tangent_len()];
        for p in 0..self.layout.count() {
            for (bi, sp) in self.layout.spans().enumerate() {
                let (o, ot) = (p * pa + sp.ambient, p * pt + sp.tangent);
                match sp.block {
                    Block::Euclidean(m) => g[ot..ot + m].copy_from_slice(&self.weights[o..o + m]),
                    Block::So3 => {
                        let q = Quat::from_slice(&y[o..]);
                        let k = p * nb + bi;
                        q.rotate(self.b[k]).cross(self.a[k]).write_to(&mut g[ot..]);
                    }
                }
            }
        }
        g
    }
}

/// The dual parts of an ambient dual state as a tangent vector: Euclidean entries as they
/// are; SO(3): `dq = ½(0, ε)⊗q` ⇒ `ε = 2 vec(dq ⊗ q*)`.
pub(crate) fn dual_tangent(layout: &StateLayout, y: &[evogs_math::Dual<f64>], out: &mut [f64]) {
    let (pa, pt) = (layout.particle_ambient_len(), layout.particle_tangent_len());
    for p in 0..layout.count() {
        for sp in layout.spans() {
            let (o, ot) = (p * pa + sp.ambient, p * pt + sp.tangent);
            match sp.block {
                Block::Euclidean(k) => {
                    for e in 0..k {
                        out[ot + e] = y[o + e].eps;
                    }
                }
                Block::So3 => {
                    let q = Quat::new(y[o].re, y[o + 1].re, y[o + 2].re, y[o + 3].re);
                    let dq = Quat::new(y[o].eps, y[o + 1].eps, y[o + 2].eps, y[o + 3].eps);
                    (dq.mul_quat(q.conj()).vec() * 2.0).write_to(&mut out[ot..]);
                }
            }
        }
    }
}

/// A field wrapper that counts evaluations.
#[derive(Clone, Debug)]
pub(crate) struct Counting<F> {
    pub(crate) inner: F,
    pub(crate) evals: usize,
}

impl<T: Real, F: VectorField<T>> VectorField<T> for Counting<F> {
    fn dim(&self) -> usize {
        self.inner.dim()
    }
    fn layout(&self) -> StateLayout {
        self.inner.layout()
    }
    fn n_params(&self) -> usize {
        self.inner.n_params()
    }
    fn eval(&mut self, t: T, y: &[T], dydt: &mut [T]) {
        self.evals += 1;
        self.inner.eval(t, y, dydt);
    }
    fn vjp(&mut self, t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        self.inner.vjp(t, y, w, d_y, d_params);
    }
}
