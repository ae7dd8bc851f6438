//! Rigid motions on SE(3) with exact solutions: a constant twist, two screws with
//! time-varying amounts, and a symmetric top propelled along its axis (SE(3) × ℝ³). Fields
//! return **world-frame twists** ξ = (ρ, φ) (`Ṫ = ξ̂·T`: `Ṙ = φ̂R`, `ṫ = φ × t + ρ`), as every
//! SE(3) block in this crate (conventions: `docs/se3.md`).

use super::{ExactProblem, SymmetricTop};
use crate::{Block, StateLayout, VectorField};
use evogs_math::se3::adjoint_mul_vjp;
use evogs_math::so3_jacobians::jl_mul;
use evogs_math::{Real, Se3, Vec3, Vec6};

fn v6<T: Real>(a: [f64; 6]) -> Vec6<T> {
    Vec6::from_array(a.map(T::from_f64))
}

/// `Ṫ = ξ̂·T` with a constant world-frame twist ξ, θ = ξ.
///
/// Exact: `T(t) = Exp(tξ)·T₀`. Every exp-based method (Lie–Euler, RKMK) reproduces it to
/// rounding for any step (`Ωᵢ ∥ ξ` commute, so `Jl⁻¹(Ωᵢ)ξ = ξ`); it pins down the
/// multiplication side (world vs body) and the twist order (ρ, φ).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConstantTwist<T> {
    /// The world-frame twist (ρ, φ).
    pub xi: Vec6<T>,
    /// Initial transform.
    pub x0: Se3<T>,
    /// End time.
    pub t_end: T,
}

impl<T: Real> Default for ConstantTwist<T> {
    fn default() -> Self {
        Self {
            xi: v6([0.4, -0.3, 0.8, 0.3, -0.5, 0.9]),
            x0: Se3::exp(v6([0.5, -1.0, 0.2, 0.2, 0.7, -0.4])),
            t_end: T::from_f64(3.0),
        }
    }
}

impl<T: Real> VectorField<T> for ConstantTwist<T> {
    type Record = ();
    fn dim(&self) -> usize {
        6
    }
    fn layout(&self) -> StateLayout {
        StateLayout::particles(&[Block::Se3], 1)
    }
    fn n_params(&self) -> usize {
        6
    }
    fn eval(&mut self, _t: T, _y: &[T], dydt: &mut [T]) {
        self.xi.write_to(dydt);
    }
    /// The twist does not depend on T; `∂f/∂ξ = I`.
    fn vjp(&mut self, _t: T, _y: &[T], w: &[T], _d_y: &mut [T], d_params: &mut [T]) {
        for (d, wi) in d_params.iter_mut().zip(w) {
            *d += *wi;
        }
    }
}

impl<T: Real> ExactProblem<T> for ConstantTwist<T> {
    fn name(&self) -> &'static str {
        "se3-constant-twist"
    }
    fn t_end(&self) -> T {
        self.t_end
    }
    fn initial_state(&self, y0: &mut [T]) {
        self.x0.write_to(y0);
    }
    fn exact(&self, t: T, out: &mut [T]) {
        (Se3::exp(self.xi * t) * self.x0).write_to(out);
    }
}

/// Two screw motions with time-varying amounts: `T(t) = T₀·Exp(a(t)ξ₁)·Exp(b(t)ξ₂)`, with
/// Problem K's `a(t) = 0.7t + 0.3 sin 2t` and `b(t) = 0.5 sin 1.3t`
/// ([`ProblemK::angles`](super::ProblemK::angles)), `T = 4`. No parameters.
///
/// Differentiating, the **body** twist is `T⁻¹Ṫ = ȧ·Ad(Exp(−bξ₂))ξ₁ + ḃ·ξ₂`
/// ([`ScrewPair::body_twist`]), so the field is the world twist
///
/// ```text
/// f(t, T) = Ad(T)·(ȧ(t)·Ad(Exp(−b(t)ξ₂))ξ₁ + ḃ(t)·ξ₂)
/// ```
///
/// which depends on the state nonlinearly (through `R` and `t × R`) and on time. The two
/// screws do not commute, so the problem separates the orders of Lie integrators:
/// Lie–Euler 1, RKMK midpoint/Heun 2, RKMK4 4.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScrewPair<T> {
    /// First screw (applied first from the base): a turn about z with pitch.
    pub xi1: Vec6<T>,
    /// Second screw: a turn about x through an offset axis.
    pub xi2: Vec6<T>,
    /// Initial transform.
    pub x0: Se3<T>,
    /// End time.
    pub t_end: T,
}

impl<T: Real> Default for ScrewPair<T> {
    fn default() -> Self {
        Self {
            xi1: v6([0.3, 0.0, 0.5, 0.0, 0.0, 1.0]),
            xi2: v6([0.0, 0.4, -0.2, 1.0, 0.0, 0.0]),
            x0: Se3::exp(v6([0.5, -0.3, 0.8, 0.2, 0.7, -0.4])),
            t_end: T::from_f64(4.0),
        }
    }
}

impl<T: Real> ScrewPair<T> {
    /// The body twist `T⁻¹Ṫ = ȧ·Ad(Exp(−bξ₂))ξ₁ + ḃ·ξ₂` at time `t`.
    #[must_use]
    pub fn body_twist(&self, t: T) -> Vec6<T> {
        let (_, b) = super::ProblemK::angles(t);
        let a_dot = T::from_f64(0.7) + T::from_f64(0.6) * (T::TWO * t).cos();
        let b_dot = T::from_f64(0.65) * (T::from_f64(1.3) * t).cos();
        Se3::exp(self.xi2 * (-b)).adjoint_mul(self.xi1) * a_dot + self.xi2 * b_dot
    }
}

impl<T: Real> VectorField<T> for ScrewPair<T> {
    type Record = ();
    fn dim(&self) -> usize {
        6
    }
    fn layout(&self) -> StateLayout {
        StateLayout::particles(&[Block::Se3], 1)
    }
    fn n_params(&self) -> usize {
        0
    }
    fn eval(&mut self, t: T, y: &[T], dydt: &mut [T]) {
        Se3::from_slice(y)
            .adjoint_mul(self.body_twist(t))
            .write_to(dydt);
    }
    /// `∂(Ad(T)v)/∂δ` for the left perturbation `Exp(δ)·T` ([`adjoint_mul_vjp`]).
    fn vjp(&mut self, t: T, y: &[T], w: &[T], d_y: &mut [T], _d_params: &mut [T]) {
        let (d_x, _) = adjoint_mul_vjp(Se3::from_slice(y), self.body_twist(t), Vec6::from_slice(w));
        d_x.add_to(d_y);
    }
}

impl<T: Real> ExactProblem<T> for ScrewPair<T> {
    fn name(&self) -> &'static str {
        "se3-screw-pair"
    }
    fn t_end(&self) -> T {
        self.t_end
    }
    fn initial_state(&self, y0: &mut [T]) {
        self.x0.write_to(y0);
    }
    fn exact(&self, t: T, out: &mut [T]) {
        let (a, b) = super::ProblemK::angles(t);
        (self.x0 * Se3::exp(self.xi1 * a) * Se3::exp(self.xi2 * b)).write_to(out);
    }
}

/// A torque-free symmetric top (`I₁ = I₂`) that moves along its symmetry axis at a constant
/// body speed u: SE(3) × ℝ³, in closed form. θ = (I₁, I₂, I₃, u).
///
/// State `[Se3, Euclidean(3)]`: the pose `T = (R, c)` (world from body; c is the centre) and
/// the **body** angular velocity ω. The field is the world twist of `Ṙ = R ω̂`,
/// `ċ = R (u e₃)`, and Euler's equations ([`RigidBody`](super::RigidBody)):
///
/// ```text
/// φ = R ω,   ρ = ċ − φ × c = u R e₃ − (R ω) × c,   I ω' = (I ω) × ω
/// ```
///
/// Exact: the attitude and rates of [`SymmetricTop`],
/// `R(t) = Exp(tα)·R₀·Exp(−λt e₃)` with `α = L_s/I₁`, and since `Exp(−λt e₃)` fixes e₃,
/// `ċ = Exp(tα)·R₀e₃·u`, so `c(t) = c₀ + t·Jl(tα)·R₀e₃·u` (using
/// `∫₀ᵗ Exp(sα) ds = t·Jl(tα)` with the SO(3) left Jacobian). Reference setting
/// ([`Default`]): the default [`SymmetricTop`] (`I = (1, 1, 2)`, T = 5), `c₀ = (0.5, −1, 0.2)`,
/// `u = 0.7`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PropelledTop<T> {
    /// The top: inertia, initial rate and attitude, end time.
    pub top: SymmetricTop<T>,
    /// Initial position of the centre.
    pub c0: Vec3<T>,
    /// Speed along the body's symmetry axis e₃.
    pub speed: T,
}

impl<T: Real> Default for PropelledTop<T> {
    fn default() -> Self {
        Self {
            top: SymmetricTop::default(),
            c0: Vec3::new(T::HALF, -T::ONE, T::from_f64(0.2)),
            speed: T::from_f64(0.7),
        }
    }
}

/// The rigid-body part of a `[q, c, ω]` state: `[q, ω]`.
fn body_state<T: Real>(y: &[T]) -> [T; 7] {
    core::array::from_fn(|i| if i < 4 { y[i] } else { y[i + 3] })
}

impl<T: Real> VectorField<T> for PropelledTop<T> {
    type Record = ();
    fn dim(&self) -> usize {
        9
    }
    fn layout(&self) -> StateLayout {
        StateLayout::particles(&[Block::Se3, Block::Euclidean(3)], 1)
    }
    fn n_params(&self) -> usize {
        4
    }
    fn eval(&mut self, t: T, y: &[T], dydt: &mut [T]) {
        let x = Se3::from_slice(y);
        let mut body = [T::ZERO; 6]; // [R ω, ω']
        self.top.body.eval(t, &body_state(y), &mut body);
        let phi = Vec3::from_slice(&body);
        let rho = x.rotation().act(Vec3::unit(2)) * self.speed - phi.cross(x.translation());
        rho.write_to(dydt);
        phi.write_to(&mut dydt[3..]);
        dydt[6..9].copy_from_slice(&body[3..]);
    }
    /// With `s = Rω`, `a = Re₃` and the left perturbation `Exp(δ)·T`:
    /// `dρ = δ_φ × ρ − (R dω) × c − s × δ_ρ`, `dφ = δ_φ × φ + R dω`; the rigid body's VJP
    /// gives the φ and ω' parts, this adds `(s × w_ρ, ρ × w_ρ, Rᵀ(w_ρ × c))` and
    /// `∂/∂u = w_ρ·a`.
    fn vjp(&mut self, t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        let x = Se3::from_slice(y);
        let c = x.translation();
        let yb = body_state(y);
        let mut body = [T::ZERO; 6];
        self.top.body.eval(t, &yb, &mut body);
        let s = Vec3::from_slice(&body);
        let a = x.rotation().act(Vec3::unit(2));
        let rho = a * self.speed - s.cross(c);
        let w_rho = Vec3::from_slice(w);
        let mut d_body = [T::ZERO; 6];
        self.top
            .body
            .vjp(t, &yb, &w[3..], &mut d_body, &mut d_params[..3]);
        s.cross(w_rho).add_to(d_y);
        (Vec3::from_slice(&d_body) + rho.cross(w_rho)).add_to(&mut d_y[3..]);
        let d_om = Vec3::from_slice(&d_body[3..]) + x.rotation().inverse().act(w_rho.cross(c));
        d_om.add_to(&mut d_y[6..]);
        d_params[3] += w_rho.dot(a);
    }
}

impl<T: Real> ExactProblem<T> for PropelledTop<T> {
    fn name(&self) -> &'static str {
        "se3-propelled-top"
    }
    fn t_end(&self) -> T {
        self.top.t_end
    }
    fn initial_state(&self, y0: &mut [T]) {
        Se3::from_quat_translation(self.top.r0, self.c0).write_to(y0);
        self.top.omega0.write_to(&mut y0[7..]);
    }
    fn exact(&self, t: T, out: &mut [T]) {
        let mut top = [T::ZERO; 7];
        self.top.exact(t, &mut top);
        let i = self.top.body.inertia;
        let alpha = self.top.r0.rotate(self.top.omega0.mul_elem(i)) * (T::ONE / i.x);
        let axis = self.top.r0.rotate(Vec3::unit(2)) * self.speed;
        let c = self.c0 + jl_mul(alpha * t, axis) * t;
        out[..4].copy_from_slice(&top[..4]);
        c.write_to(&mut out[4..]);
        out[7..10].copy_from_slice(&top[4..]);
    }
}
