//! The continuous adjoint of Chen et al. (2018): [`continuous_adjoint`].

use crate::{Method, StateLayout, Stepper, TimeGrid, VectorField};
use alloc::vec;
use alloc::vec::Vec;
use core::fmt;
use evogs_math::Real;

/// Which continuous-adjoint variant to run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ContinuousVariant {
    /// Re-integrate x backward together with the adjoint (never reset).
    #[default]
    Reintegrate,
    /// Reset x to the stored forward state before every backward step.
    Checkpoint,
}

/// Why a continuous adjoint cannot run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AdjointError {
    /// The field's layout has SO(3) blocks: the augmented system here is Euclidean only
    /// (use the discrete adjoint, which handles rotations in tangent coordinates).
    NotEuclidean,
    /// A slice does not have the length the field requires.
    LengthMismatch {
        /// Which argument.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Length given.
        got: usize,
    },
}

impl fmt::Display for AdjointError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NotEuclidean => f.write_str(
                "the continuous adjoint supports Euclidean layouts only (no SO(3) blocks)",
            ),
            Self::LengthMismatch {
                what,
                expected,
                got,
            } => write!(f, "{what} has length {got}, expected {expected}"),
        }
    }
}

impl core::error::Error for AdjointError {}

/// The result of [`continuous_adjoint`].
#[derive(Clone, Debug, PartialEq)]
pub struct ContinuousAdjoint<T> {
    /// `a(t0)`, the estimate of `∂L/∂x0`.
    pub d_y0: Vec<T>,
    /// `g(t0)`, the estimate of `∂L/∂θ`.
    pub d_params: Vec<T>,
    /// The forward solution `x_N` that seeded the backward solve.
    pub final_state: Vec<T>,
    /// `|x̃(t0) − x0|` (Euclidean norm) for [`ContinuousVariant::Reintegrate`]; `None` for
    /// the checkpoint variant, whose x-part is reset at every step.
    pub reconstruction_error: Option<T>,
}

/// The augmented right-hand side `(f, −(∂f/∂x)ᵀa, −(∂f/∂θ)ᵀa)`.
struct Augmented<'a, T, F: ?Sized> {
    field: &'a mut F,
    n: usize,
    p: usize,
    dx: Vec<T>,
    dp: Vec<T>,
}

impl<T: Real, F: VectorField<T> + ?Sized> VectorField<T> for Augmented<'_, T, F> {
    type Record = ();
    fn dim(&self) -> usize {
        2 * self.n + self.p
    }
    fn n_params(&self) -> usize {
        0
    }
    fn eval(&mut self, t: T, z: &[T], dz: &mut [T]) {
        let n = self.n;
        let (x, a) = (&z[..n], &z[n..2 * n]);
        self.field.eval(t, x, &mut dz[..n]);
        self.dx.fill(T::ZERO);
        self.dp.fill(T::ZERO);
        self.field.vjp(t, x, a, &mut self.dx, &mut self.dp);
        for (o, d) in dz[n..2 * n].iter_mut().zip(&self.dx) {
            *o = -*d;
        }
        for (o, d) in dz[2 * n..].iter_mut().zip(&self.dp) {
            *o = -*d;
        }
    }
    /// Never called: the continuous adjoint only steps the augmented system forward.
    fn vjp(&mut self, _: T, _: &[T], _: &[T], _: &mut [T], _: &mut [T]) {
        unreachable!("the augmented adjoint system is never differentiated");
    }
}

/// The continuous adjoint of `L(x(t1))` with `∂L/∂x(t1) = d_final`: runs the forward solve
/// over `grid` from `y0` (storing every state for the checkpoint variant), then the
/// augmented backward solve below.
///
/// The continuous adjoint of Chen et al. (2018), in the two variants of the reference
/// files, for Euclidean states.
///
/// For `x' = f(t, x; θ)` and a loss `L(x(t1))`, the adjoint `a = ∂L/∂x(t)` solves
/// `a' = −(∂f/∂x)ᵀa` backward from `a(t1) = ∂L/∂x(t1)`, and `dL/dθ = ∫ aᵀ ∂f/∂θ dt`. Both
/// variants integrate the augmented state `z = (x, a, g)` as **one** ODE
///
/// ```text
/// x' = f(t, x),   a' = −(∂f/∂x)ᵀa,   g' = −(∂f/∂θ)ᵀa
/// ```
///
/// from `(x_N, ∂L/∂x_N, 0)` at `t1` back to `t0` with the forward tableau and step `−h`
/// (every stage evaluates x, a and g together; the Jacobians are taken at the stage value
/// of x). Then `dL/dx0 = a(t0)`, `dL/dθ = g(t0)`.
///
/// - [`ContinuousVariant::Reintegrate`] ("backsolve"): x is re-integrated backward and
///   never reset: O(1) memory, but a non-reversible scheme does not retrace its forward
///   path, and on dissipative dynamics a mode decaying like `e^{−λt}` forward grows like
///   `e^{λt}` backward, so the reconstruction of x — and with it the gradient — can be
///   wrong by orders of magnitude. [`ContinuousAdjoint::reconstruction_error`] reports
///   `|x̃(t0) − x0|`.
/// - [`ContinuousVariant::Checkpoint`]: before each backward step from `t_k` the x-part is
///   reset to the stored forward state `x_k` (torchdiffeq with every grid time as an
///   output time).
///
/// Either way this is "optimise, then discretise": the gradient of the exact flow,
/// approximated by a second numerical solve, which differs from the gradient of what the
/// forward solver computed by `O(hᵖ)`. The [discrete adjoint](crate::discrete_adjoint) is
/// exact.
///
/// # Errors
/// [`AdjointError::NotEuclidean`] if the field's layout has SO(3) blocks;
/// [`AdjointError::LengthMismatch`] if `y0` or `d_final` do not have the field's length.
///
/// ```
/// use evogs_ode::{ContinuousVariant, Method, TimeGrid, continuous_adjoint, fields::LinearField};
/// let mut f = LinearField::new(1, vec![-0.5]);
/// let grid = TimeGrid::uniform(0.0, 1.0, 32);
/// let r = continuous_adjoint(&mut f, Method::Rk4, &grid, &[2.0], &[1.0], ContinuousVariant::Reintegrate)
///     .unwrap();
/// // ∂x(1)/∂x0 = e^{−0.5}
/// assert!((r.d_y0[0] - (-0.5_f64).exp()).abs() < 1e-9);
/// assert!(r.reconstruction_error.unwrap() < 1e-9);
/// ```
///
/// On dissipative dynamics the re-integrating variant loses `x(t0)`, and with it every
/// gradient; [`ContinuousAdjoint::reconstruction_error`] says so (the stress test of
/// `docs/integrators.md` §7.9):
///
/// ```
/// use evogs_ode::{ContinuousVariant, Method, TimeGrid, continuous_adjoint};
/// use evogs_ode::problems::DissipativePair; // x₁' = −50x₁ + …
/// let mut f = DissipativePair::default();
/// let (x0, c) = (DissipativePair::initial_state(), DissipativePair::loss_weights());
/// let grid = TimeGrid::uniform(0.0, 1.0, 40);
/// let back = continuous_adjoint(&mut f, Method::Rk4, &grid, &x0, &c, ContinuousVariant::Reintegrate)
///     .unwrap();
/// assert!(back.reconstruction_error.unwrap() > 1e10); // x(0) is lost: gradients are garbage
/// ```
pub fn continuous_adjoint<T: Real, F: VectorField<T> + ?Sized>(
    field: &mut F,
    method: Method,
    grid: &TimeGrid<T>,
    y0: &[T],
    d_final: &[T],
    variant: ContinuousVariant,
) -> Result<ContinuousAdjoint<T>, AdjointError> {
    let layout = field.layout();
    if !layout.is_euclidean() {
        return Err(AdjointError::NotEuclidean);
    }
    let n = field.dim();
    let p = field.n_params();
    for (what, got) in [("y0", y0.len()), ("d_final", d_final.len())] {
        if got != n {
            return Err(AdjointError::LengthMismatch {
                what,
                expected: n,
                got,
            });
        }
    }
    let steps = grid.n_steps();
    // Forward solve (all states kept for the checkpoint variant).
    let mut stepper = Stepper::new(method, layout);
    let keep = matches!(variant, ContinuousVariant::Checkpoint);
    let mut states = Vec::with_capacity(if keep { (steps + 1) * n } else { 0 });
    let mut x = y0.to_vec();
    if keep {
        states.extend_from_slice(&x);
    }
    for k in 0..steps {
        let (t, h) = grid.step(k);
        stepper.step(field, t, h, &mut x);
        if keep {
            states.extend_from_slice(&x);
        }
    }
    // Backward solve of the augmented system from t1 to t0.
    let mut z = vec![T::ZERO; 2 * n + p];
    z[..n].copy_from_slice(&x);
    z[n..2 * n].copy_from_slice(d_final);
    let mut aug = Augmented {
        field,
        n,
        p,
        dx: vec![T::ZERO; n],
        dp: vec![T::ZERO; p],
    };
    let mut back = Stepper::new(method, StateLayout::euclidean(2 * n + p));
    for k in (0..steps).rev() {
        if keep {
            z[..n].copy_from_slice(&states[(k + 1) * n..(k + 2) * n]);
        }
        let h = grid.step_size(k);
        back.step(&mut aug, grid.time(k + 1), -h, &mut z);
    }
    let reconstruction_error = (!keep).then(|| {
        z[..n]
            .iter()
            .zip(y0)
            .map(|(a, b)| (*a - *b).sq())
            .fold(T::ZERO, |acc, v| acc + v)
            .sqrt()
    });
    Ok(ContinuousAdjoint {
        d_y0: z[n..2 * n].to_vec(),
        d_params: z[2 * n..].to_vec(),
        final_state: x,
        reconstruction_error,
    })
}
