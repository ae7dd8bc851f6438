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
///
/// A field whose VJP needs intermediate values of its forward pass (the activations of a
/// neural field) can hand them to the caller instead of recomputing them: its
/// [`Record`](Self::Record) type holds them, [`eval_recorded`](Self::eval_recorded) writes
/// one, and [`vjp_recorded`](Self::vjp_recorded) reads it back. The caller owns the records
/// and passes each back with the point it was written at (a [`StageTape`](crate::StageTape)
/// does this for the discrete adjoint). Fields without such values use `type Record = ();`
/// and keep the provided methods, which ignore the record.
pub trait VectorField<T: Real> {
    /// What one evaluation keeps for the VJP at the same point (`()` when the VJP needs
    /// nothing from the forward pass). `Default` gives an empty record that
    /// [`eval_recorded`](Self::eval_recorded) fills.
    type Record: Default;

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

    /// [`eval`](Self::eval), also writing into `record` what the VJP at this `(t, y)` needs
    /// (overwrites it; the provided method keeps nothing).
    fn eval_recorded(&mut self, t: T, y: &[T], dydt: &mut [T], record: &mut Self::Record) {
        let _ = record;
        self.eval(t, y, dydt);
    }

    /// [`vjp`](Self::vjp) at the `(t, y)` where [`eval_recorded`](Self::eval_recorded) wrote
    /// `record`, with the same parameters: the forward pass is read from the record instead
    /// of being recomputed (the provided method ignores it). Bitwise the same as `vjp`.
    fn vjp_recorded(
        &mut self,
        t: T,
        y: &[T],
        record: &Self::Record,
        w: &[T],
        d_y: &mut [T],
        d_params: &mut [T],
    ) {
        let _ = record;
        self.vjp(t, y, w, d_y, d_params);
    }
}

/// A mutable reference to a field is a field: combinators such as
/// [`Mix`](crate::algebra::Mix) can then borrow a field owned elsewhere (for example a
/// trained neural field) instead of taking it by value.
impl<T: Real, F: VectorField<T> + ?Sized> VectorField<T> for &mut F {
    type Record = F::Record;
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
    fn eval_recorded(&mut self, t: T, y: &[T], dydt: &mut [T], record: &mut Self::Record) {
        (**self).eval_recorded(t, y, dydt, record);
    }
    fn vjp_recorded(
        &mut self,
        t: T,
        y: &[T],
        record: &Self::Record,
        w: &[T],
        d_y: &mut [T],
        d_params: &mut [T],
    ) {
        (**self).vjp_recorded(t, y, record, w, d_y, d_params);
    }
}

/// A boxed field is a field (for fields chosen at run time, e.g. `Box<dyn VectorField<T, Record = ()>>`).
impl<T: Real, F: VectorField<T> + ?Sized> VectorField<T> for alloc::boxed::Box<F> {
    type Record = F::Record;
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
    fn eval_recorded(&mut self, t: T, y: &[T], dydt: &mut [T], record: &mut Self::Record) {
        (**self).eval_recorded(t, y, dydt, record);
    }
    fn vjp_recorded(
        &mut self,
        t: T,
        y: &[T],
        record: &Self::Record,
        w: &[T],
        d_y: &mut [T],
        d_params: &mut [T],
    ) {
        (**self).vjp_recorded(t, y, record, w, d_y, d_params);
    }
}
