//! Linear combinations of fields: [`Sum`] and [`Scaled`].

use crate::{StateLayout, VectorField};
use alloc::vec;
use alloc::vec::Vec;
use evogs_math::Real;

/// `f = a + b`; θ = `[θ_a, θ_b]`.
///
/// ```
/// use evogs_ode::{VectorField, algebra::{ParticleFrame, Sum, Translation}};
/// use evogs_math::Vec3;
/// let frame = ParticleFrame::points(2);
/// let mut f = Sum::new(
///     Translation::new(frame, Vec3::new(1.0, 0.0, 0.0)),
///     Translation::new(frame, Vec3::new(0.0, 2.0, 0.0)),
/// );
/// let mut v = [0.0; 6];
/// f.eval(0.0, &[0.0; 6], &mut v);
/// assert_eq!(v, [1.0, 2.0, 0.0, 1.0, 2.0, 0.0]);
/// assert_eq!(VectorField::<f64>::n_params(&f), 6);
/// ```
#[derive(Clone, Debug)]
pub struct Sum<T, A, B> {
    a: A,
    b: B,
    tmp: Vec<T>,
}

impl<T: Real, A: VectorField<T>, B: VectorField<T>> Sum<T, A, B> {
    /// `a + b`.
    ///
    /// # Panics
    /// If the two fields have different layouts.
    #[must_use]
    pub fn new(a: A, b: B) -> Self {
        assert_eq!(a.layout(), b.layout(), "summed fields need the same layout");
        let n = a.dim();
        Self {
            a,
            b,
            tmp: vec![T::ZERO; n],
        }
    }

    /// The two terms.
    #[must_use]
    pub const fn parts(&self) -> (&A, &B) {
        (&self.a, &self.b)
    }

    /// The two terms, mutably (e.g. to update parameters).
    pub const fn parts_mut(&mut self) -> (&mut A, &mut B) {
        (&mut self.a, &mut self.b)
    }
}

impl<T: Real, A: VectorField<T>, B: VectorField<T>> VectorField<T> for Sum<T, A, B> {
    type Record = ();
    fn dim(&self) -> usize {
        self.a.dim()
    }
    fn layout(&self) -> StateLayout {
        self.a.layout()
    }
    fn n_params(&self) -> usize {
        self.a.n_params() + self.b.n_params()
    }
    fn eval(&mut self, t: T, y: &[T], dydt: &mut [T]) {
        self.a.eval(t, y, dydt);
        self.b.eval(t, y, &mut self.tmp);
        for (o, v) in dydt.iter_mut().zip(&self.tmp) {
            *o += *v;
        }
    }
    fn vjp(&mut self, t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        let (da, db) = d_params.split_at_mut(self.a.n_params());
        self.a.vjp(t, y, w, d_y, da);
        self.b.vjp(t, y, w, d_y, db);
    }
}

/// `f = s·g` for a constant factor s; θ = `θ_g`.
#[derive(Clone, Debug)]
pub struct Scaled<T, F> {
    factor: T,
    field: F,
    tmp: Vec<T>,
}

impl<T: Real, F: VectorField<T>> Scaled<T, F> {
    /// `factor · field`.
    #[must_use]
    pub fn new(factor: T, field: F) -> Self {
        let n = field.dim();
        Self {
            factor,
            field,
            tmp: vec![T::ZERO; n],
        }
    }

    /// The factor.
    #[must_use]
    pub const fn factor(&self) -> T {
        self.factor
    }

    /// Changes the factor.
    pub const fn set_factor(&mut self, factor: T) {
        self.factor = factor;
    }

    /// The scaled field.
    #[must_use]
    pub const fn inner(&self) -> &F {
        &self.field
    }

    /// The scaled field, mutably.
    pub const fn inner_mut(&mut self) -> &mut F {
        &mut self.field
    }
}

impl<T: Real, F: VectorField<T>> VectorField<T> for Scaled<T, F> {
    type Record = ();
    fn dim(&self) -> usize {
        self.field.dim()
    }
    fn layout(&self) -> StateLayout {
        self.field.layout()
    }
    fn n_params(&self) -> usize {
        self.field.n_params()
    }
    fn eval(&mut self, t: T, y: &[T], dydt: &mut [T]) {
        self.field.eval(t, y, dydt);
        for o in dydt.iter_mut() {
            *o *= self.factor;
        }
    }
    fn vjp(&mut self, t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        for (o, v) in self.tmp.iter_mut().zip(w) {
            *o = self.factor * *v;
        }
        self.field.vjp(t, y, &self.tmp, d_y, d_params);
    }
}
