//! The [`VectorField`] trait: the right-hand side `dy/dt = f(t, y; θ)` and its VJP.

use crate::StateLayout;
use evogs_math::Real;

/// A parameterised vector field `dy/dt = f(t, y; θ)` on a state with a [`StateLayout`].
///
/// - `y` has `layout().ambient_len()` entries (SO(3) blocks as unit quaternions);
/// - `dydt`, `w`, `d_y` have `dim() = layout().tangent_len()` entries: for SO(3) blocks,
///   `f` returns a **world-frame angular velocity** and `d_y` is the cotangent with respect
///   to a **left** perturbation `R ↦ Exp(δ)·R`;
/// - θ has `n_params()` entries, owned by the field.
///
/// One field can carry many particles and batch them internally (the neural field of
/// evogs-cli evaluates every Gaussian in one call).
///
/// Methods take `&mut self` so that implementations can keep scratch buffers and never
/// allocate per call.
pub trait VectorField<T: Real> {
    /// Tangent dimension: the length of `dydt`, `w` and `d_y`.
    fn dim(&self) -> usize;

    /// The state layout. Defaults to a Euclidean state of dimension [`dim`](Self::dim).
    fn layout(&self) -> StateLayout {
        StateLayout::euclidean(self.dim())
    }

    /// Number of parameters θ.
    fn n_params(&self) -> usize;

    /// Writes `f(t, y; θ)` into `dydt` (overwrites).
    fn eval(&mut self, t: T, y: &[T], dydt: &mut [T]);

    /// **Adds** `(∂f/∂y)ᵀ w` into `d_y` and `(∂f/∂θ)ᵀ w` into `d_params`, at `(t, y)`.
    ///
    /// For SO(3) blocks, `(∂f/∂y)ᵀ w` is taken with respect to the left perturbation of the
    /// rotation at `y` (a 3-vector).
    fn vjp(&mut self, t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]);
}

/// A mutable reference to a field is a field: combinators such as
/// [`Mix`](crate::algebra::Mix) can then borrow a field owned elsewhere (for example a
/// trained neural field) instead of taking it by value.
impl<T: Real, F: VectorField<T> + ?Sized> VectorField<T> for &mut F {
    fn dim(&self) -> usize {
        (**self).dim()
    }
    fn layout(&self) -> StateLayout {
        (**self).layout()
    }
    fn n_params(&self) -> usize {
        (**self).n_params()
    }
    fn eval(&mut self, t: T, y: &[T], dydt: &mut [T]) {
        (**self).eval(t, y, dydt);
    }
    fn vjp(&mut self, t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        (**self).vjp(t, y, w, d_y, d_params);
    }
}

/// A boxed field is a field (for fields chosen at run time, e.g. `Box<dyn VectorField<T>>`).
impl<T: Real, F: VectorField<T> + ?Sized> VectorField<T> for alloc::boxed::Box<F> {
    fn dim(&self) -> usize {
        (**self).dim()
    }
    fn layout(&self) -> StateLayout {
        (**self).layout()
    }
    fn n_params(&self) -> usize {
        (**self).n_params()
    }
    fn eval(&mut self, t: T, y: &[T], dydt: &mut [T]) {
        (**self).eval(t, y, dydt);
    }
    fn vjp(&mut self, t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        (**self).vjp(t, y, w, d_y, d_params);
    }
}
