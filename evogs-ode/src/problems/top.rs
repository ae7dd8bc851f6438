//! The torque-free rigid body (`docs/integrators.md` §7.6 and §7.7): attitude and body rates
//! coupled.

use super::ExactProblem;
use crate::{Block, StateLayout, VectorField};
use evogs_math::so3::exp_quat;
use evogs_math::{Quat, Real, Vec3};

/// The torque-free rigid body with principal moments `I = (I₁, I₂, I₃)`, θ = I.
///
/// State `[So3, Euclidean(3)]`: the attitude R (world from body, unit quaternion) and the
/// **body** angular velocity ω. The field returns the world-frame rate `R·ω` for the
/// attitude (`R' = R ω̂ = (Rω)^ R`) and Euler's equations for the rates,
///
/// ```text
/// I ω' = (I ω) × ω      i.e.   ω'ₖ = (Iᵢ − Iⱼ) ωᵢ ωⱼ / Iₖ   for (k, i, j) cyclic.
/// ```
///
/// Invariants: the energy `½ωᵀIω`, `|Iω|²`, and the **spatial** angular momentum
/// `L = R I ω`. Energy and `|L|²` cannot see attitude errors; the spatial vector can
/// (`docs/integrators.md` §7.7).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidBody<T> {
    /// Principal moments of inertia (the parameters).
    pub inertia: Vec3<T>,
}

impl<T: Real> RigidBody<T> {
    /// Energy `½ ωᵀ I ω` of a state.
    #[must_use]
    pub fn energy(&self, y: &[T]) -> T {
        let w = Vec3::from_slice(&y[4..]);
        T::HALF * w.dot(w.mul_elem(self.inertia))
    }

    /// `|I ω|²` of a state.
    #[must_use]
    pub fn momentum_squared(&self, y: &[T]) -> T {
        Vec3::from_slice(&y[4..])
            .mul_elem(self.inertia)
            .norm_squared()
    }

    /// The spatial angular momentum `R I ω` of a state.
    #[must_use]
    pub fn spatial_momentum(&self, y: &[T]) -> Vec3<T> {
        let q = Quat::from_slice(y);
        q.rotate(Vec3::from_slice(&y[4..]).mul_elem(self.inertia))
    }
}

impl<T: Real> VectorField<T> for RigidBody<T> {
    type Record = ();
    fn dim(&self) -> usize {
        6
    }
    fn layout(&self) -> StateLayout {
        StateLayout::particles(&[Block::So3, Block::Euclidean(3)], 1)
    }
    fn n_params(&self) -> usize {
        3
    }
    fn eval(&mut self, _t: T, y: &[T], dydt: &mut [T]) {
        let q = Quat::from_slice(y);
        let w = Vec3::from_slice(&y[4..]);
        q.rotate(w).write_to(dydt);
        let i = self.inertia;
        for k in 0..3 {
            let (a, b) = ((k + 1) % 3, (k + 2) % 3);
            dydt[3 + k] = (i[a] - i[b]) * w[a] * w[b] / i[k];
        }
    }
    /// Attitude part: `∂(Rω)/∂δ = −(Rω)^` (left perturbation) and `∂(Rω)/∂ω = R`;
    /// rates: `∂ω'ₖ/∂ωᵢ = (Iᵢ − Iⱼ)ωⱼ/Iₖ`, `∂ω'ₖ/∂ωⱼ = (Iᵢ − Iⱼ)ωᵢ/Iₖ`,
    /// `∂ω'ₖ/∂Iₖ = −ω'ₖ/Iₖ`, `∂ω'ₖ/∂Iᵢ = ωᵢωⱼ/Iₖ = −∂ω'ₖ/∂Iⱼ`.
    fn vjp(&mut self, _t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        let q = Quat::from_slice(y);
        let om = Vec3::from_slice(&y[4..]);
        let w_rot = Vec3::from_slice(w);
        let d_rot = q.rotate(om).cross(w_rot);
        d_rot.add_to(d_y);
        let mut d_om = q.rotate_inv(w_rot);
        let i = self.inertia;
        for k in 0..3 {
            let (a, b) = ((k + 1) % 3, (k + 2) % 3);
            let wk = w[3 + k] / i[k];
            let diff = i[a] - i[b];
            d_om[a] += wk * diff * om[b];
            d_om[b] += wk * diff * om[a];
            let p = om[a] * om[b];
            d_params[k] -= wk * diff * p / i[k];
            d_params[a] += wk * p;
            d_params[b] -= wk * p;
        }
        d_om.add_to(&mut d_y[3..]);
    }
}

/// The torque-free **symmetric** top (`I₁ = I₂`), in closed form (`docs/integrators.md` §7.6).
///
/// With `λ = (I₃ − I₁)ω₃/I₁`, the body rate precesses, `ω(t) = Exp(λt e₃)·ω₀`, and the
/// attitude is
///
/// ```text
/// R(t) = Exp(t L_s/I₁)·R₀·Exp(−λt e₃),     L_s = R₀ I ω₀ (constant spatial momentum).
/// ```
///
/// (Check: the body rate of this R is `Rᵀ L_s/I₁ − λe₃ = Iω(t)/I₁ − λe₃ = ω(t)`, using
/// `Rᵀ L_s = I ω(t)`.) Reference setting ([`Default`]): `I = (1, 1, 2)`,
/// `ω₀ = (0.8, −0.3, 1.1)`, `T = 5`, a fixed non-trivial `R₀`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SymmetricTop<T> {
    /// The rigid body (`inertia.x` must equal `inertia.y`).
    pub body: RigidBody<T>,
    /// Initial body rate.
    pub omega0: Vec3<T>,
    /// Initial attitude.
    pub r0: Quat<T>,
    /// End time.
    pub t_end: T,
}

impl<T: Real> Default for SymmetricTop<T> {
    fn default() -> Self {
        Self {
            body: RigidBody {
                inertia: Vec3::new(T::ONE, T::ONE, T::TWO),
            },
            omega0: Vec3::new(T::from_f64(0.8), T::from_f64(-0.3), T::from_f64(1.1)),
            r0: exp_quat(Vec3::new(
                T::from_f64(0.3),
                T::from_f64(-0.2),
                T::from_f64(0.5),
            )),
            t_end: T::from_f64(5.0),
        }
    }
}

impl<T: Real> VectorField<T> for SymmetricTop<T> {
    type Record = ();
    fn dim(&self) -> usize {
        6
    }
    fn layout(&self) -> StateLayout {
        self.body.layout()
    }
    fn n_params(&self) -> usize {
        3
    }
    fn eval(&mut self, t: T, y: &[T], dydt: &mut [T]) {
        self.body.eval(t, y, dydt);
    }
    fn vjp(&mut self, t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        self.body.vjp(t, y, w, d_y, d_params);
    }
}

impl<T: Real> ExactProblem<T> for SymmetricTop<T> {
    fn name(&self) -> &'static str {
        "symmetric-top"
    }
    fn t_end(&self) -> T {
        self.t_end
    }
    fn initial_state(&self, y0: &mut [T]) {
        self.r0.write_to(y0);
        self.omega0.write_to(&mut y0[4..]);
    }
    fn exact(&self, t: T, out: &mut [T]) {
        let i = self.body.inertia;
        let lambda = (i.z - i.x) * self.omega0.z / i.x;
        let spin = Vec3::new(T::ZERO, T::ZERO, lambda * t);
        let l_s = self.r0.rotate(self.omega0.mul_elem(i));
        exp_quat(l_s * (t / i.x))
            .mul_quat(self.r0)
            .mul_quat(exp_quat(-spin))
            .write_to(out);
        exp_quat(spin).rotate(self.omega0).write_to(&mut out[4..]);
    }
}

/// The torque-free **asymmetric** top (`docs/integrators.md` §7.7): no elementary closed form,
/// so it is checked through its invariants ([`RigidBody::energy`],
/// [`RigidBody::momentum_squared`], [`RigidBody::spatial_momentum`]).
///
/// Reference setting ([`Default`]): `I = (1, 2, 3)`, `ω₀ = (1, 0.1, 0.5)`, `R₀ = I`,
/// `T = 20`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AsymmetricTop<T> {
    /// The rigid body.
    pub body: RigidBody<T>,
    /// Initial body rate.
    pub omega0: Vec3<T>,
    /// Initial attitude.
    pub r0: Quat<T>,
    /// End time.
    pub t_end: T,
}

impl<T: Real> Default for AsymmetricTop<T> {
    fn default() -> Self {
        Self {
            body: RigidBody {
                inertia: Vec3::new(T::ONE, T::TWO, T::from_f64(3.0)),
            },
            omega0: Vec3::new(T::ONE, T::from_f64(0.1), T::HALF),
            r0: Quat::identity(),
            t_end: T::from_f64(20.0),
        }
    }
}

impl<T: Real> AsymmetricTop<T> {
    /// Writes the initial state `[R₀, ω₀]`.
    pub fn initial_state(&self, y0: &mut [T]) {
        self.r0.write_to(y0);
        self.omega0.write_to(&mut y0[4..]);
    }
}

impl<T: Real> VectorField<T> for AsymmetricTop<T> {
    type Record = ();
    fn dim(&self) -> usize {
        6
    }
    fn layout(&self) -> StateLayout {
        self.body.layout()
    }
    fn n_params(&self) -> usize {
        3
    }
    fn eval(&mut self, t: T, y: &[T], dydt: &mut [T]) {
        self.body.eval(t, y, dydt);
    }
    fn vjp(&mut self, t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        self.body.vjp(t, y, w, d_y, d_params);
    }
}
