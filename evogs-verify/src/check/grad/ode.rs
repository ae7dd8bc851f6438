//! evogs-ode: [`Stepper::step_vjp`] for every method, on the reference MLP field (a
//! Euclidean state in R³), on the torque-free rigid body (an SO(3) block and R³, RKMK) and on
//! the propelled symmetric top (an SE(3) block and R³, RKMK).
//!
//! Inputs are `[δ, θ]`: a tangent perturbation of the initial state (`Exp(δ)·R` on SO(3),
//! `Exp(δ)·T` on SE(3), `y + δ` elsewhere) and the field parameters; the output is the final
//! state in the local coordinates of the unperturbed result (`log(R₁ R̄₁ᵀ)` on SO(3),
//! `Log(T₁ T̄₁⁻¹)` on SE(3)), so that the step's tangent cotangents are exactly what central
//! differences measure at `δ = 0`.

use super::{GradRow, Kernel, kernel_reports, uniform};
use evogs_math::rng::SplitMix64;
use evogs_math::so3::{exp_quat, log_quat};
use evogs_math::{Quat, Real, Se3, Vec3, Vec6};
use evogs_ode::fields::Mlp;
use evogs_ode::problems::{PropelledTop, RigidBody};
use evogs_ode::{Block, Method, StateLayout, Stepper};

const HIDDEN: usize = 8;

/// Which field the step runs on.
#[derive(Clone, Copy, Debug)]
enum FieldKind {
    /// `Mlp` on R³ with hidden width [`HIDDEN`].
    Mlp,
    /// `RigidBody` (parameters: the principal moments).
    RigidBody,
    /// `PropelledTop` (parameters: the principal moments and the axial speed).
    PropelledTop,
}

/// The propelled top with parameters `[I₁, I₂, I₃, u]`.
fn propelled<T: Real>(theta: &[T]) -> PropelledTop<T> {
    let mut p = PropelledTop::default();
    p.top.body.inertia = Vec3::from_slice(theta);
    p.speed = theta[3];
    p
}

impl FieldKind {
    fn n_params(self) -> usize {
        match self {
            Self::Mlp => Mlp::<f64>::param_count(3, HIDDEN),
            Self::RigidBody => 3,
            Self::PropelledTop => 4,
        }
    }

    fn layout(self) -> StateLayout {
        match self {
            Self::Mlp => StateLayout::particles(&[Block::Euclidean(3)], 1),
            Self::RigidBody => StateLayout::particles(&[Block::So3, Block::Euclidean(3)], 1),
            Self::PropelledTop => StateLayout::particles(&[Block::Se3, Block::Euclidean(3)], 1),
        }
    }

    /// One step of the field with parameters `theta` from `y`.
    fn step<T: Real>(self, method: Method, theta: &[T], t: f64, h: f64, y: &mut [T]) {
        let (t, h) = (T::from_f64(t), T::from_f64(h));
        let mut st = Stepper::new(method, self.layout());
        match self {
            Self::Mlp => st.step(&mut Mlp::new(3, HIDDEN, theta.to_vec()), t, h, y),
            Self::RigidBody => st.step(
                &mut RigidBody {
                    inertia: Vec3::from_slice(theta),
                },
                t,
                h,
                y,
            ),
            Self::PropelledTop => st.step(&mut propelled(theta), t, h, y),
        }
    }

    fn step_vjp(
        self,
        method: Method,
        theta: &[f64],
        t: f64,
        h: f64,
        y: &[f64],
        lambda: &mut [f64],
        d_theta: &mut [f64],
    ) {
        let mut st = Stepper::new(method, self.layout());
        match self {
            Self::Mlp => {
                let mut f = Mlp::new(3, HIDDEN, theta.to_vec());
                st.step_vjp(&mut f, t, h, y, lambda, d_theta);
            }
            Self::RigidBody => {
                let mut f = RigidBody {
                    inertia: Vec3::from_slice(theta),
                };
                st.step_vjp(&mut f, t, h, y, lambda, d_theta);
            }
            Self::PropelledTop => st.step_vjp(&mut propelled(theta), t, h, y, lambda, d_theta),
        }
    }
}

/// `y ⊕ v`: `Exp(v)·R` on SO(3) blocks, `Exp(v)·T` on SE(3) blocks, `y + v` elsewhere.
fn retract<T: Real>(layout: &StateLayout, y: &[T], v: &[T], out: &mut [T]) {
    out.copy_from_slice(y);
    for sp in layout.spans() {
        let (o, ot) = (sp.ambient, sp.tangent);
        match sp.block {
            Block::Euclidean(m) => {
                for e in 0..m {
                    out[o + e] = y[o + e] + v[ot + e];
                }
            }
            Block::So3 => exp_quat(Vec3::from_slice(&v[ot..]))
                .mul_quat(Quat::from_slice(&y[o..]))
                .write_to(&mut out[o..]),
            Block::Se3 => (Se3::exp(Vec6::from_slice(&v[ot..])) * Se3::from_slice(&y[o..]))
                .write_to(&mut out[o..]),
        }
    }
}

/// Local coordinates of `y` around `base`: `log(R R̄ᵀ)` on SO(3), `Log(T T̄⁻¹)` on SE(3),
/// `y − ȳ` elsewhere.
fn local<T: Real>(layout: &StateLayout, y: &[T], base: &[T], out: &mut [T]) {
    for sp in layout.spans() {
        let (o, ot) = (sp.ambient, sp.tangent);
        match sp.block {
            Block::Euclidean(m) => {
                for e in 0..m {
                    out[ot + e] = y[o + e] - base[o + e];
                }
            }
            Block::So3 => {
                let r = Quat::from_slice(&y[o..]).mul_quat(Quat::from_slice(&base[o..]).conj());
                log_quat(r).write_to(&mut out[ot..]);
            }
            Block::Se3 => (Se3::from_slice(&y[o..]) * Se3::from_slice(&base[o..]).inverse())
                .log()
                .write_to(&mut out[ot..]),
        }
    }
}

struct StepKernel {
    method: Method,
    kind: FieldKind,
    y0: Vec<f64>,
    y1: Vec<f64>,
    t: f64,
    h: f64,
}

impl StepKernel {
    fn new(method: Method, kind: FieldKind, y0: Vec<f64>, theta: &[f64], t: f64, h: f64) -> Self {
        let mut y1 = y0.clone();
        kind.step(method, theta, t, h, &mut y1);
        Self {
            method,
            kind,
            y0,
            y1,
            t,
            h,
        }
    }

    fn tangent(&self) -> usize {
        self.kind.layout().tangent_len()
    }
}

impl Kernel for StepKernel {
    fn n_in(&self) -> usize {
        self.tangent() + self.kind.n_params()
    }
    fn n_out(&self) -> usize {
        self.tangent()
    }
    fn eval<T: Real>(&self, x: &[T], out: &mut [T]) {
        let layout = self.kind.layout();
        let nt = self.tangent();
        let cast = |v: &[f64]| -> Vec<T> { v.iter().map(|&a| T::from_f64(a)).collect() };
        let mut y = cast(&self.y0);
        retract(&layout, &cast(&self.y0), &x[..nt], &mut y);
        self.kind
            .step(self.method, &x[nt..], self.t, self.h, &mut y);
        local(&layout, &y, &cast(&self.y1), out);
    }
    /// At `δ = 0` (where the checks run) the local coordinates have the identity derivative,
    /// so the cotangent `w` is the step's tangent cotangent at `y₁`.
    fn vjp(&self, x: &[f64], w: &[f64], d: &mut [f64]) {
        let nt = self.tangent();
        let mut lambda = w.to_vec();
        let mut d_theta = vec![0.0; self.kind.n_params()];
        self.kind.step_vjp(
            self.method,
            &x[nt..],
            self.t,
            self.h,
            &self.y0,
            &mut lambda,
            &mut d_theta,
        );
        d[..nt].copy_from_slice(&lambda);
        d[nt..].copy_from_slice(&d_theta);
    }
}

pub(super) fn rows() -> Vec<GradRow> {
    let mut out = Vec::new();
    for kind in [
        FieldKind::Mlp,
        FieldKind::RigidBody,
        FieldKind::PropelledTop,
    ] {
        for (mi, method) in Method::ALL.into_iter().enumerate() {
            let mut rng = SplitMix64::new(0x0de0 + 31 * mi as u64);
            let mut reports = Vec::new();
            let mut dots = Vec::new();
            for p in 0..3_u64 {
                let (y0, theta) = match kind {
                    FieldKind::Mlp => (
                        uniform(&mut rng, 3, -1.0, 1.0),
                        uniform(&mut rng, kind.n_params(), -0.8, 0.8),
                    ),
                    FieldKind::RigidBody => {
                        let q = exp_quat(Vec3::new(rng.normal(), rng.normal(), rng.normal()));
                        let mut y = q.to_array().to_vec();
                        y.extend(uniform(&mut rng, 3, -1.5, 1.5));
                        (y, uniform(&mut rng, 3, 0.8, 3.0))
                    }
                    FieldKind::PropelledTop => {
                        let xi = Vec6::from_slice(&uniform(&mut rng, 6, -1.5, 1.5));
                        let mut y = vec![0.0; 7];
                        Se3::exp(xi).write_to(&mut y);
                        y.extend(uniform(&mut rng, 3, -1.5, 1.5));
                        let mut theta = uniform(&mut rng, 3, 0.8, 3.0);
                        theta.extend(uniform(&mut rng, 1, -1.0, 1.0));
                        (y, theta)
                    }
                };
                let (t, h) = (rng.uniform(-0.5, 0.5), rng.uniform(-0.4, 0.4));
                let k = StepKernel::new(method, kind, y0, &theta, t, h);
                let mut x = vec![0.0; k.tangent()];
                x.extend(&theta);
                let (r, d) = kernel_reports(&k, &[x], 40 + p);
                reports.extend(r);
                dots.extend(d);
            }
            let what = match kind {
                FieldKind::Mlp => "MLP, R³",
                FieldKind::RigidBody => "rigid body, SO(3) × R³",
                FieldKind::PropelledTop => "propelled top, SE(3) × R³",
            };
            out.push(GradRow::from_reports(
                &format!("ode: step_vjp {method} ({what})"),
                &reports,
                &dots,
            ));
        }
    }
    out
}
