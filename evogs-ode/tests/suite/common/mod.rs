//! Shared test helpers: parameterised particle fields with SO(3) and SE(3) blocks,
//! tangent-space perturbations of states, and losses with their cotangents.
#![allow(dead_code, reason = "each test binary uses a subset of the helpers")]

use evogs_math::rng::SplitMix64;
use evogs_math::so3::exp_quat;
use evogs_math::{Quat, Real, Se3, Vec3, Vec6};
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

/// Seeded parameters of the coupled test fields: entries from 42 on (decay rates) in
/// [0.2, 1), the rest in [−0.6, 0.6).
fn random_theta<T: Real>(n: usize, seed: u64) -> Vec<T> {
    let mut rng = SplitMix64::new(seed);
    (0..n)
        .map(|i| {
            let v = if i >= 42 {
                rng.uniform(0.2, 1.0)
            } else {
                rng.uniform(-0.6, 0.6)
            };
            T::from_f64(v)
        })
        .collect()
}

fn mat<T: Real>(th: &[T], k: usize) -> evogs_math::Mat3<T> {
    let m = &th[9 * k..9 * k + 9];
    evogs_math::Mat3::from_rows([[m[0], m[1], m[2]], [m[3], m[4], m[5]], [m[6], m[7], m[8]]])
}

impl<T: Real> CoupledField<T> {
    pub(crate) fn random(count: usize, seed: u64) -> Self {
        Self {
            theta: random_theta(N_THETA, seed),
            count,
        }
    }

    pub(crate) fn layout_for(count: usize) -> StateLayout {
        StateLayout::particles(
            &[Block::Euclidean(3), Block::So3, Block::Euclidean(2)],
            count,
        )
    }
}

impl<T: Real> VectorField<T> for CoupledField<T> {
    type Record = ();
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

/// A coupled particle field on `[Euclidean(2) s, Se3 T = (R, c), Euclidean(3) v] × count`,
/// returning the world twist (ρ, φ) for T:
///
/// ```text
/// s' = (c_x, c_y) − s
/// ρ  = A tanh(c) + B (R e_z) + t u
/// φ  = C v + D (R e_x) + sin(t) e
/// v' = −κ ⊙ v + R e_y + c × v
/// θ  = [A, B, C, D (3×3 row-major), u, e, κ (3)]   (45 entries, shared by particles)
/// ```
///
/// Every block depends on the transform (rotation and translation), and the twist on the
/// translation, the rotation and the Euclidean state.
#[derive(Clone, Debug)]
pub(crate) struct CoupledSe3Field<T> {
    pub(crate) theta: Vec<T>,
    pub(crate) count: usize,
}

pub(crate) const N_THETA_SE3: usize = 45;

impl<T: Real> CoupledSe3Field<T> {
    pub(crate) fn random(count: usize, seed: u64) -> Self {
        Self {
            theta: random_theta(N_THETA_SE3, seed),
            count,
        }
    }

    pub(crate) fn layout_for(count: usize) -> StateLayout {
        StateLayout::particles(
            &[Block::Euclidean(2), Block::Se3, Block::Euclidean(3)],
            count,
        )
    }
}

impl<T: Real> VectorField<T> for CoupledSe3Field<T> {
    type Record = ();
    fn dim(&self) -> usize {
        11 * self.count
    }
    fn layout(&self) -> StateLayout {
        Self::layout_for(self.count)
    }
    fn n_params(&self) -> usize {
        N_THETA_SE3
    }
    fn eval(&mut self, t: T, y: &[T], dydt: &mut [T]) {
        let th = &self.theta;
        let (a, b, c, d) = (mat(th, 0), mat(th, 1), mat(th, 2), mat(th, 3));
        let (u, e, kappa) = (
            Vec3::from_slice(&th[36..]),
            Vec3::from_slice(&th[39..]),
            Vec3::from_slice(&th[42..]),
        );
        for i in 0..self.count {
            let ys = &y[12 * i..];
            let out = &mut dydt[11 * i..];
            let x = Se3::from_slice(&ys[2..]);
            let (pos, v) = (x.translation(), Vec3::from_slice(&ys[9..]));
            let r = x.rotation();
            let (gx, gy, gz) = (
                r.act(Vec3::unit(0)),
                r.act(Vec3::unit(1)),
                r.act(Vec3::unit(2)),
            );
            out[0] = pos.x - ys[0];
            out[1] = pos.y - ys[1];
            let rho = a.mul_vec(pos.map(Real::tanh)) + b.mul_vec(gz) + u * t;
            let phi = c.mul_vec(v) + d.mul_vec(gx) + e * t.sin();
            Vec6::new(rho, phi).write_to(&mut out[2..]);
            (gy - v.mul_elem(kappa) + pos.cross(v)).write_to(&mut out[8..]);
        }
    }
    fn vjp(&mut self, t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        let th = &self.theta;
        let (a, b, c, d) = (mat(th, 0), mat(th, 1), mat(th, 2), mat(th, 3));
        let kappa = Vec3::from_slice(&th[42..]);
        for i in 0..self.count {
            let ys = &y[12 * i..];
            let ws = &w[11 * i..];
            let dy = &mut d_y[11 * i..];
            let x = Se3::from_slice(&ys[2..]);
            let (pos, v) = (x.translation(), Vec3::from_slice(&ys[9..]));
            let r = x.rotation();
            let (gx, gy, gz) = (
                r.act(Vec3::unit(0)),
                r.act(Vec3::unit(1)),
                r.act(Vec3::unit(2)),
            );
            let tp = pos.map(Real::tanh);
            let (w_rho, w_phi, w_v) = (
                Vec3::from_slice(&ws[2..]),
                Vec3::from_slice(&ws[5..]),
                Vec3::from_slice(&ws[8..]),
            );
            // s' = (c_x, c_y) − s.
            dy[0] -= ws[0];
            dy[1] -= ws[1];
            // Gradient with respect to the position c, and the rotation part (R a ↦ δ × R a).
            let g_pos = Vec3::new(ws[0], ws[1], T::ZERO)
                + a.tr_mul_vec(w_rho).mul_elem(tp.map(|z| T::ONE - z * z))
                + v.cross(w_v);
            let g_rot =
                gz.cross(b.tr_mul_vec(w_rho)) + gx.cross(d.tr_mul_vec(w_phi)) + gy.cross(w_v);
            // c ↦ c + δ_ρ + δ_φ × c under Exp(δ)·T.
            Vec6::new(g_pos, g_rot + pos.cross(g_pos)).add_to(&mut dy[2..]);
            (c.tr_mul_vec(w_phi) - w_v.mul_elem(kappa) + w_v.cross(pos)).add_to(&mut dy[8..]);
            for row in 0..3 {
                for col in 0..3 {
                    d_params[row * 3 + col] += w_rho[row] * tp[col];
                    d_params[9 + row * 3 + col] += w_rho[row] * gz[col];
                    d_params[18 + row * 3 + col] += w_phi[row] * v[col];
                    d_params[27 + row * 3 + col] += w_phi[row] * gx[col];
                }
            }
            (w_rho * t).add_to(&mut d_params[36..]);
            (w_phi * t.sin()).add_to(&mut d_params[39..]);
            (-v.mul_elem(w_v)).add_to(&mut d_params[42..]);
        }
    }
}

/// A random unit quaternion from a rotation vector with components in [−2, 2).
fn random_rotation(rng: &mut SplitMix64) -> Quat<f64> {
    let phi = Vec3::new(
        rng.uniform(-2.0, 2.0),
        rng.uniform(-2.0, 2.0),
        rng.uniform(-2.0, 2.0),
    );
    exp_quat(phi)
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
                Block::So3 => random_rotation(&mut rng).write_to(&mut y[o..]),
                Block::Se3 => {
                    random_rotation(&mut rng).write_to(&mut y[o..]);
                    for v in &mut y[o + 4..o + 7] {
                        *v = rng.uniform(-1.0, 1.0);
                    }
                }
            }
        }
    }
    y
}

/// `y ⊕ v`: `y + v` on Euclidean entries, `Exp(v)·R` on SO(3) and `Exp(v)·T` on SE(3)
/// blocks (v tangent).
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
                Block::Se3 => (Se3::exp(Vec6::from_slice(&v[ot..])) * Se3::from_slice(&y[o..]))
                    .write_to(&mut out[o..]),
            }
        }
    }
    out
}

/// A loss in the state: `Σ c_e y_e` over Euclidean entries, `Σ aᵀ R b` over SO(3) blocks
/// and `Σ aᵀ (T·b)` over SE(3) blocks, with fixed seeded weights.
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
                    Block::Se3 => {
                        let x = Se3::from_quat_translation(
                            Quat::from_slice(&y[o..]),
                            Vec3::from_slice(&y[o + 4..]),
                        );
                        let k = p * nb + bi;
                        acc += self.a[k].dot(x.act(self.b[k]));
                    }
                }
            }
        }
        acc
    }

    /// `∂L/∂y` in tangent coordinates: `c` on Euclidean entries, `(R b) × a` on SO(3)
    /// blocks (left perturbation: `aᵀ Exp(δ) R b ≈ aᵀRb + δ·((Rb) × a)`), and
    /// `(a, (T b) × a)` on SE(3) blocks ([`evogs_math::se3::act_vjp`]).
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
                    Block::Se3 => {
                        let k = p * nb + bi;
                        let (d_x, _) = evogs_math::se3::act_vjp(
                            Se3::from_slice(&y[o..]),
                            self.b[k],
                            self.a[k],
                        );
                        d_x.write_to(&mut g[ot..]);
                    }
                }
            }
        }
        g
    }
}

/// The dual parts of an ambient dual state as a tangent vector: Euclidean entries as they
/// are; SO(3): `dq = ½(0, ε)⊗q` ⇒ `ε = 2 vec(dq ⊗ q*)`; SE(3) under the left update
/// `Exp(δ)·T`, δ = (ρ, φ): `φ` as on SO(3) and `dt = φ × t + ρ` ⇒ `ρ = dt − φ × t`.
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
                Block::Se3 => {
                    let q = Quat::new(y[o].re, y[o + 1].re, y[o + 2].re, y[o + 3].re);
                    let dq = Quat::new(y[o].eps, y[o + 1].eps, y[o + 2].eps, y[o + 3].eps);
                    let t = Vec3::new(y[o + 4].re, y[o + 5].re, y[o + 6].re);
                    let dt = Vec3::new(y[o + 4].eps, y[o + 5].eps, y[o + 6].eps);
                    let phi = dq.mul_quat(q.conj()).vec() * 2.0;
                    (dt - phi.cross(t)).write_to(&mut out[ot..]);
                    phi.write_to(&mut out[ot + 3..]);
                }
            }
        }
    }
}

/// A field wrapper that counts evaluations and VJPs.
#[derive(Clone, Debug)]
pub(crate) struct Counting<F> {
    pub(crate) inner: F,
    pub(crate) evals: usize,
    pub(crate) vjps: usize,
}

impl<F> Counting<F> {
    pub(crate) const fn new(inner: F) -> Self {
        Self {
            inner,
            evals: 0,
            vjps: 0,
        }
    }
}

impl<T: Real, F: VectorField<T>> VectorField<T> for Counting<F> {
    type Record = ();
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
        self.vjps += 1;
        self.inner.vjp(t, y, w, d_y, d_params);
    }
}
