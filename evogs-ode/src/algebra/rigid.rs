//! Rigid motions as fields: [`RigidRotation`] and [`Translation`].

use super::ParticleFrame;
use crate::{StateLayout, VectorField};
use evogs_math::{Real, Vec3};

/// Rotation about the point c with world-frame angular velocity ω: `v = ω × (x − c)` on
/// every particle's position, `ω` on its orientation (if the frame has one), zero on other
/// blocks; θ = `[ω, c]` (6 entries).
///
/// Integrated for a time T, positions follow `c + Exp(ωT)(x₀ − c)` to the stepper's order
/// and orientations follow `Exp(ωT)·R₀` exactly (to rounding: a constant world rate is
/// integrated exactly by every RKMK method).
///
/// VJP (`r = x − c`): `ω̄ += r × w_pos + w_rot`, `x̄ += w_pos × ω`, `c̄ −= w_pos × ω`.
///
/// ```
/// use evogs_ode::{VectorField, algebra::{ParticleFrame, RigidRotation}};
/// use evogs_math::Vec3;
/// let mut f = RigidRotation::new(ParticleFrame::points(1), Vec3::new(0.0, 0.0, 2.0), Vec3::zero());
/// let mut v = [0.0; 3];
/// f.eval(0.0, &[1.0, 0.0, 0.0], &mut v);
/// assert_eq!(v, [0.0, 2.0, 0.0]);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidRotation<T> {
    /// World-frame angular velocity ω.
    pub omega: Vec3<T>,
    /// Centre of rotation c.
    pub center: Vec3<T>,
    frame: ParticleFrame,
}

impl<T: Real> RigidRotation<T> {
    /// Rotation with rate ω about the point c, on the particles of `frame`.
    #[must_use]
    pub const fn new(frame: ParticleFrame, omega: Vec3<T>, center: Vec3<T>) -> Self {
        Self {
            omega,
            center,
            frame,
        }
    }

    /// The particle frame.
    #[must_use]
    pub const fn frame(&self) -> ParticleFrame {
        self.frame
    }
}

impl<T: Real> VectorField<T> for RigidRotation<T> {
    type Record = ();
    fn dim(&self) -> usize {
        self.frame.layout().tangent_len()
    }
    fn layout(&self) -> StateLayout {
        self.frame.layout()
    }
    fn n_params(&self) -> usize {
        6
    }
    fn eval(&mut self, _t: T, y: &[T], dydt: &mut [T]) {
        dydt.fill(T::ZERO);
        for p in 0..self.frame.layout().count() {
            let r = self.frame.position(y, p) - self.center;
            self.omega
                .cross(r)
                .write_to(&mut dydt[self.frame.position_tangent(p)..]);
            if let Some(o) = self.frame.rotation_tangent(p) {
                self.omega.write_to(&mut dydt[o..]);
            }
        }
    }
    fn vjp(&mut self, _t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        let (mut d_omega, mut d_center) = (Vec3::zero(), Vec3::zero());
        for p in 0..self.frame.layout().count() {
            let r = self.frame.position(y, p) - self.center;
            let o = self.frame.position_tangent(p);
            let w_pos = Vec3::from_slice(&w[o..]);
            d_omega += r.cross(w_pos);
            let dx = w_pos.cross(self.omega);
            dx.add_to(&mut d_y[o..]);
            d_center -= dx;
            if let Some(o) = self.frame.rotation_tangent(p) {
                d_omega += Vec3::from_slice(&w[o..]);
            }
        }
        d_omega.add_to(d_params);
        d_center.add_to(&mut d_params[3..]);
    }
}

/// Uniform translation: `v = u` on every particle's position, zero elsewhere; θ = `[u]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Translation<T> {
    /// The velocity u.
    pub velocity: Vec3<T>,
    frame: ParticleFrame,
}

impl<T: Real> Translation<T> {
    /// Translation with velocity u on the particles of `frame`.
    #[must_use]
    pub const fn new(frame: ParticleFrame, velocity: Vec3<T>) -> Self {
        Self { velocity, frame }
    }
}

impl<T: Real> VectorField<T> for Translation<T> {
    type Record = ();
    fn dim(&self) -> usize {
        self.frame.layout().tangent_len()
    }
    fn layout(&self) -> StateLayout {
        self.frame.layout()
    }
    fn n_params(&self) -> usize {
        3
    }
    fn eval(&mut self, _t: T, _y: &[T], dydt: &mut [T]) {
        dydt.fill(T::ZERO);
        for p in 0..self.frame.layout().count() {
            self.velocity
                .write_to(&mut dydt[self.frame.position_tangent(p)..]);
        }
    }
    /// `ū += Σ_p w_pos,p` (no dependence on the state).
    fn vjp(&mut self, _t: T, _y: &[T], w: &[T], _d_y: &mut [T], d_params: &mut [T]) {
        let mut d_u = Vec3::zero();
        for p in 0..self.frame.layout().count() {
            d_u += Vec3::from_slice(&w[self.frame.position_tangent(p)..]);
        }
        d_u.add_to(d_params);
    }
}
