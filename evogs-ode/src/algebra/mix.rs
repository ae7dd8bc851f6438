//! The spatial blend of two fields: [`Mix`].

use super::{Edge, Mask, ParticleFrame};
use crate::{StateLayout, VectorField};
use alloc::vec;
use alloc::vec::Vec;
use evogs_math::Real;

/// `v(x) = λ(x)·a(x) + (1 − λ(x))·b(x)` per particle, with λ from a [`Mask`] evaluated at
/// the particle's position; θ = `[θ_a, θ_b]`.
///
/// The whole tangent block of particle p (position, rotation, other blocks) is blended
/// with the same `λ_p`. VJP:
///
/// ```text
/// ā = λ w,   b̄ = (1 − λ) w,   λ̄_p = Σ_{e ∈ p} w_e (a_e − b_e),   x̄_p += λ̄_p ∂λ/∂x
/// ```
///
/// The last term is zero for hard edges and explicit weights (then `a` and `b` are not
/// re-evaluated in the VJP).
///
/// ```
/// use evogs_ode::{VectorField, algebra::{Edge, Mask, Mix, ParticleFrame, Translation}};
/// use evogs_math::Vec3;
/// let frame = ParticleFrame::points(2);
/// let inject = Translation::new(frame, Vec3::new(0.0, 0.0, 1.0));
/// let base = Translation::new(frame, Vec3::new(1.0, 0.0, 0.0));
/// let mask = Mask::Sphere { center: Vec3::new(0.0, 0.0, 0.0), radius: 1.0, edge: Edge::Hard };
/// let mut f = Mix::new(mask, inject, base, frame);
/// let mut v = [0.0; 6];
/// f.eval(0.0, &[0.1, 0.0, 0.0, 5.0, 0.0, 0.0], &mut v); // first inside, second outside
/// assert_eq!(v, [0.0, 0.0, 1.0, 1.0, 0.0, 0.0]);
/// ```
#[derive(Clone, Debug)]
pub struct Mix<T, A, B> {
    mask: Mask<T>,
    a: A,
    b: B,
    frame: ParticleFrame,
    va: Vec<T>,
    vb: Vec<T>,
    w: Vec<T>,
}

impl<T: Real, A: VectorField<T>, B: VectorField<T>> Mix<T, A, B> {
    /// `λ a + (1 − λ) b` on the particles of `frame`.
    ///
    /// # Panics
    /// If `a` or `b` does not have the frame's layout, or if explicit weights do not have
    /// one entry per particle.
    #[must_use]
    pub fn new(mask: Mask<T>, a: A, b: B, frame: ParticleFrame) -> Self {
        let layout = frame.layout();
        assert_eq!(
            a.layout(),
            layout,
            "the injected field needs the frame's layout"
        );
        assert_eq!(
            b.layout(),
            layout,
            "the base field needs the frame's layout"
        );
        if let Mask::Weights(w) = &mask {
            assert_eq!(w.len(), layout.count(), "one weight per particle");
        }
        let n = layout.tangent_len();
        Self {
            mask,
            a,
            b,
            frame,
            va: vec![T::ZERO; n],
            vb: vec![T::ZERO; n],
            w: vec![T::ZERO; n],
        }
    }

    /// The mask.
    #[must_use]
    pub const fn mask(&self) -> &Mask<T> {
        &self.mask
    }

    /// The mask, mutably.
    pub const fn mask_mut(&mut self) -> &mut Mask<T> {
        &mut self.mask
    }

    /// The two fields (`a` weighted by λ, `b` by 1 − λ).
    #[must_use]
    pub const fn parts(&self) -> (&A, &B) {
        (&self.a, &self.b)
    }

    /// The two fields, mutably.
    pub const fn parts_mut(&mut self) -> (&mut A, &mut B) {
        (&mut self.a, &mut self.b)
    }

    fn differentiable_mask(&self) -> bool {
        matches!(
            self.mask,
            Mask::Sphere {
                edge: Edge::Soft { .. },
                ..
            } | Mask::Box {
                edge: Edge::Soft { .. },
                ..
            }
        )
    }
}

impl<T: Real, A: VectorField<T>, B: VectorField<T>> VectorField<T> for Mix<T, A, B> {
    type Record = ();
    fn dim(&self) -> usize {
        self.va.len()
    }
    fn layout(&self) -> StateLayout {
        self.frame.layout()
    }
    fn n_params(&self) -> usize {
        self.a.n_params() + self.b.n_params()
    }
    fn eval(&mut self, t: T, y: &[T], dydt: &mut [T]) {
        self.a.eval(t, y, &mut self.va);
        self.b.eval(t, y, &mut self.vb);
        let pt = self.frame.layout().particle_tangent_len();
        for p in 0..self.frame.layout().count() {
            let l = self.mask.weight(p, self.frame.position(y, p));
            let r = p * pt..(p + 1) * pt;
            for ((o, a), b) in dydt[r.clone()]
                .iter_mut()
                .zip(&self.va[r.clone()])
                .zip(&self.vb[r])
            {
                *o = l * *a + (T::ONE - l) * *b;
            }
        }
    }
    fn vjp(&mut self, t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        let layout = self.frame.layout();
        let pt = layout.particle_tangent_len();
        let soft = self.differentiable_mask();
        if soft {
            self.a.eval(t, y, &mut self.va);
            self.b.eval(t, y, &mut self.vb);
        }
        // Cotangent of a: λ w (then of b: (1 − λ) w); the mask's x-gradient term.
        for p in 0..layout.count() {
            let (l, dl_dx) = self.mask.weight_and_grad(p, self.frame.position(y, p));
            let r = p * pt..(p + 1) * pt;
            for (o, wi) in self.w[r.clone()].iter_mut().zip(&w[r.clone()]) {
                *o = l * *wi;
            }
            if soft {
                let lbar = w[r.clone()]
                    .iter()
                    .zip(&self.va[r.clone()])
                    .zip(&self.vb[r])
                    .fold(T::ZERO, |acc, ((wi, a), b)| acc + *wi * (*a - *b));
                (dl_dx * lbar).add_to(&mut d_y[self.frame.position_tangent(p)..]);
            }
        }
        let (da, db) = d_params.split_at_mut(self.a.n_params());
        self.a.vjp(t, y, &self.w, d_y, da);
        for (o, wi) in self.w.iter_mut().zip(w) {
            *o = *wi - *o;
        }
        self.b.vjp(t, y, &self.w, d_y, db);
    }
}
