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

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::boxed::Box;
    use alloc::vec;
    use alloc::vec::Vec;

    /// `f(t, y; a) = a·y + t`, whose VJP reads `a` from the record (so a VJP that got no
    /// record, or a record nobody wrote, shows).
    struct Affine {
        a: f64,
    }

    impl VectorField<f64> for Affine {
        type Record = f64;
        fn dim(&self) -> usize {
            2
        }
        fn n_params(&self) -> usize {
            1
        }
        fn eval(&mut self, t: f64, y: &[f64], dydt: &mut [f64]) {
            for (d, &v) in dydt.iter_mut().zip(y) {
                *d = self.a * v + t;
            }
        }
        fn vjp(&mut self, t: f64, y: &[f64], w: &[f64], d_y: &mut [f64], d_params: &mut [f64]) {
            let a = self.a;
            self.vjp_recorded(t, y, &a, w, d_y, d_params);
        }
        fn eval_recorded(&mut self, t: f64, y: &[f64], dydt: &mut [f64], record: &mut f64) {
            *record = self.a;
            self.eval(t, y, dydt);
        }
        fn vjp_recorded(
            &mut self,
            _t: f64,
            y: &[f64],
            record: &f64,
            w: &[f64],
            d_y: &mut [f64],
            d_params: &mut [f64],
        ) {
            for ((d, &v), &wi) in d_y.iter_mut().zip(y).zip(w) {
                *d += *record * wi;
                d_params[0] += v * wi;
            }
        }
    }

    /// Every method of `f`, each output starting from a sentinel.
    fn outputs<F: VectorField<f64, Record = f64>>(f: &mut F) -> Vec<f64> {
        let (t, y, w) = (0.5, [1.0, -2.0], [3.0, 0.25]);
        let mut out = vec![
            f.dim() as f64,
            f.n_params() as f64,
            f.layout().tangent_len() as f64,
        ];
        let mut dydt = [7.0; 2];
        f.eval(t, &y, &mut dydt);
        out.extend(dydt);
        let (mut d_y, mut d_p) = ([1.0; 2], [1.0]);
        f.vjp(t, &y, &w, &mut d_y, &mut d_p);
        out.extend(d_y.iter().chain(&d_p));
        let mut rec = 0.0;
        let mut dydt = [7.0; 2];
        f.eval_recorded(t, &y, &mut dydt, &mut rec);
        out.extend(dydt);
        out.push(rec);
        let (mut d_y, mut d_p) = ([1.0; 2], [1.0]);
        f.vjp_recorded(t, &y, &rec, &w, &mut d_y, &mut d_p);
        out.extend(d_y.iter().chain(&d_p));
        out
    }

    #[test]
    fn references_and_boxes_forward_every_method() {
        let direct = outputs(&mut Affine { a: 1.5 });
        assert_eq!(
            direct,
            [
                2.0, 1.0, 2.0, 2.0, -2.5, 5.5, 1.375, 3.5, 2.0, -2.5, 1.5, 5.5, 1.375, 3.5
            ],
            "the field itself"
        );
        let mut owned = Affine { a: 1.5 };
        assert_eq!(outputs(&mut &mut owned), direct, "through &mut");
        assert_eq!(
            outputs(&mut Box::new(Affine { a: 1.5 })),
            direct,
            "through Box"
        );
    }
}
