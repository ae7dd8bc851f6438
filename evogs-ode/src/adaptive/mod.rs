//! Adaptive, error-controlled integration with embedded Runge–Kutta pairs, dense output and
//! the exact discrete adjoint of the accepted steps. The methods are explained in
//! `docs/adaptive.md`.
//!
//! | piece | items |
//! |---|---|
//! | pairs | [`Pair`]: Dormand–Prince 5(4), Bogacki–Shampine 3(2), exact rationals, FSAL |
//! | control | [`AdaptiveOptions`] (rtol, atol, limits), [`StepControl`] (PI controller) |
//! | solving | [`AdaptiveSolver::solve`] → [`AdaptiveSolution`] (outputs by dense output, [`Stats`]) |
//! | replaying | [`AdaptiveSolver::replay`]: the recorded [`StepSequence`], no control |
//! | gradients | [`AdaptiveSolver::adjoint`]: w.r.t. `y0`, θ and the output times |
//! | failures | [`AdaptiveError`] (never a panic on bad input or a failing solve) |
//!
//! The steps run on the crate's one Runge–Kutta core ([`Stepper`]) with the
//! pair's tableau, so every block layout works: Euclidean blocks are integrated as usual and
//! Lie-group blocks (SO(3)) by RKMK, the error estimate `h Σ (bᵢ − b̂ᵢ)Kᵢ` and the dense
//! output `yₙ ⊕ h Σ bᵢ(θ)Kᵢ` both living in the tangent coordinates of the step.
//!
//! ```
//! use evogs_ode::adaptive::{AdaptiveOptions, AdaptiveSolver, Pair};
//! use evogs_ode::{VectorField, fields::LinearField};
//! // y' = −y from y(0) = 1, reported at t = 0.3, 1.7 and 2 through dense output.
//! let mut f = LinearField::new(1, vec![-1.0]);
//! let opts = AdaptiveOptions::with_tolerances(1e-8, 1e-8);
//! let mut solver = AdaptiveSolver::new(Pair::Dopri5, f.layout(), opts);
//! let sol = solver.solve(&mut f, 0.0, 2.0, &[1.0], &[0.3, 1.7, 2.0]).unwrap();
//! for (j, t) in [0.3_f64, 1.7, 2.0].iter().enumerate() {
//!     assert!((sol.output(j)[0] - (-t).exp()).abs() < 1e-8);
//! }
//! let st = sol.stats();
//! assert_eq!(st.field_evals, 2 + 6 * (st.accepted + st.rejected));
//! ```

mod adjoint;
mod control;
mod dense;
mod pair;

pub use control::StepControl;
pub use pair::{Pair, ParsePairError, order_conditions_5, weights_order};

use crate::{Checkpointing, MAX_STAGES, StateLayout, Stepper, VectorField};
use alloc::vec;
use alloc::vec::Vec;
use control::{error_norm, initial_step_size, tangent_magnitudes, trial_step_size};
use core::fmt;
use dense::Extension;
use evogs_math::{Par, Real};

/// Tolerances, limits and controller settings of an adaptive solve.
///
/// ```
/// use evogs_ode::Checkpointing;
/// use evogs_ode::adaptive::AdaptiveOptions;
/// let o = AdaptiveOptions::with_tolerances(1e-6, 1e-9)
///     .max_steps(10_000)
///     .checkpointing(Checkpointing::Every(16));
/// assert_eq!(o.rtol, 1e-6);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveOptions<T> {
    /// Relative tolerance (default 1e-6).
    pub rtol: T,
    /// Absolute tolerance (default 1e-9).
    pub atol: T,
    /// The step-size controller.
    pub control: StepControl<T>,
    /// Most attempted steps (accepted + rejected) before [`AdaptiveError::TooManySteps`]
    /// (default 100 000).
    pub max_steps: usize,
    /// Smallest step size: a smaller one fails with [`AdaptiveError::StepSizeTooSmall`]
    /// (default 0: only steps lost in the rounding of t fail).
    pub h_min: T,
    /// Largest step size (default: the whole span).
    pub h_max: Option<T>,
    /// First step size (default: chosen by HNW's algorithm, one extra field evaluation).
    pub h_init: Option<T>,
    /// Which accepted states are kept for the adjoint (default `StoreAll`).
    pub checkpointing: Checkpointing,
}

impl<T: Real> Default for AdaptiveOptions<T> {
    fn default() -> Self {
        Self {
            rtol: T::from_f64(1e-6),
            atol: T::from_f64(1e-9),
            control: StepControl::default(),
            max_steps: 100_000,
            h_min: T::ZERO,
            h_max: None,
            h_init: None,
            checkpointing: Checkpointing::StoreAll,
        }
    }
}

impl<T: Real> AdaptiveOptions<T> {
    /// The defaults with these tolerances.
    #[must_use]
    pub fn with_tolerances(rtol: T, atol: T) -> Self {
        Self {
            rtol,
            atol,
            ..Self::default()
        }
    }

    /// Sets the step limit.
    #[must_use]
    pub const fn max_steps(mut self, n: usize) -> Self {
        self.max_steps = n;
        self
    }

    /// Sets the checkpointing policy.
    #[must_use]
    pub const fn checkpointing(mut self, c: Checkpointing) -> Self {
        self.checkpointing = c;
        self
    }

    /// Sets the controller.
    #[must_use]
    pub const fn control(mut self, c: StepControl<T>) -> Self {
        self.control = c;
        self
    }
}

/// Counters of a solve.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Accepted steps.
    pub accepted: usize,
    /// Rejected step attempts.
    pub rejected: usize,
    /// Field evaluations: 2 for the start (`f(t0, y0)` and the initial-step probe, 1 with
    /// a given `h_init`) plus `s − 1` per attempted step (FSAL).
    pub field_evals: usize,
}

/// Why an adaptive solve (or its replay or adjoint) failed. Times and steps are reported as
/// `f64`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum AdaptiveError {
    /// A tolerance is negative or not finite, or both are zero.
    InvalidTolerance,
    /// An option is out of range (the controller's constants, `h_min`, `h_max`, `h_init`,
    /// `Every(0)`).
    InvalidOption(&'static str),
    /// A slice has the wrong length.
    LengthMismatch {
        /// What was passed.
        what: &'static str,
        /// The length the layout and the field require.
        expected: usize,
        /// The length given.
        found: usize,
    },
    /// The field's dimension or layout differs from the solver's.
    LayoutMismatch,
    /// `t0`, `t1`, an output time or the initial state is not finite.
    NonFinite(&'static str),
    /// Output time `index` is outside `[t0, t1]` or out of order.
    OutputTime {
        /// Its index.
        index: usize,
    },
    /// The step limit was reached at time `t`.
    TooManySteps {
        /// Time reached.
        t: f64,
        /// The limit.
        max_steps: usize,
    },
    /// The controller asked for a step smaller than `h_min` (or lost in the rounding of
    /// `t`) at time `t`: the problem is stiff or singular there, or the tolerance too
    /// tight for the floating-point type.
    StepSizeTooSmall {
        /// Time reached.
        t: f64,
        /// The step asked for.
        h: f64,
    },
    /// The solution given to [`AdaptiveSolver::adjoint`] was made by another pair or for
    /// another layout.
    ForeignSolution,
}

impl fmt::Display for AdaptiveError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::InvalidTolerance => {
                f.write_str("tolerances must be finite and non-negative, not both zero")
            }
            Self::InvalidOption(what) => write!(f, "invalid option: {what}"),
            Self::LengthMismatch {
                what,
                expected,
                found,
            } => write!(f, "{what}: expected {expected} entries, found {found}"),
            Self::LayoutMismatch => f.write_str("the field's layout differs from the solver's"),
            Self::NonFinite(what) => write!(f, "{what} is not finite"),
            Self::OutputTime { index } => {
                write!(f, "output time {index} is outside [t0, t1] or out of order")
            }
            Self::TooManySteps { t, max_steps } => {
                write!(f, "more than {max_steps} steps needed (stopped at t = {t})")
            }
            Self::StepSizeTooSmall { t, h } => {
                write!(f, "step size {h:e} too small at t = {t}")
            }
            Self::ForeignSolution => {
                f.write_str("the solution was computed by another pair or layout")
            }
        }
    }
}

impl core::error::Error for AdaptiveError {}

/// The accepted steps of a solve: start times `tₙ` and sizes `hₙ` (negative backward in
/// time). `tₙ₊₁ = tₙ + hₙ`, except that the last step ends at `t1`.
///
/// A replay ([`AdaptiveSolver::replay`]) runs exactly these steps without error control:
/// derivatives of the solve "with the step sequence held fixed" are derivatives of the
/// replay.
#[derive(Clone, Debug, PartialEq)]
pub struct StepSequence<T> {
    t0: T,
    t1: T,
    starts: Vec<T>,
    sizes: Vec<T>,
}

impl<T: Real> StepSequence<T> {
    fn empty(t0: T, t1: T) -> Self {
        Self {
            t0,
            t1,
            starts: Vec::new(),
            sizes: Vec::new(),
        }
    }

    /// Steps of the given sizes from `t0` (`tₙ₊₁ = tₙ + hₙ`); `t1` is the last end.
    ///
    /// ```
    /// use evogs_ode::adaptive::StepSequence;
    /// let s = StepSequence::from_sizes(1.0, &[0.5, 0.25, 0.25]);
    /// assert_eq!(s.step(2), (1.75, 0.25));
    /// assert_eq!(s.t1(), 2.0);
    /// ```
    #[must_use]
    pub fn from_sizes(t0: T, sizes: &[T]) -> Self {
        let mut s = Self::empty(t0, t0);
        let mut t = t0;
        for &h in sizes {
            s.starts.push(t);
            s.sizes.push(h);
            t += h;
        }
        s.t1 = t;
        s
    }

    /// Number of steps.
    #[must_use]
    pub fn len(&self) -> usize {
        self.sizes.len()
    }

    /// `true` without steps (`t1 = t0`).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.sizes.is_empty()
    }

    /// `(tₙ, hₙ)` of step `n`.
    ///
    /// # Panics
    /// If `n ≥ len()`.
    #[must_use]
    pub fn step(&self, n: usize) -> (T, T) {
        (self.starts[n], self.sizes[n])
    }

    /// The start time.
    #[must_use]
    pub const fn t0(&self) -> T {
        self.t0
    }

    /// The end time.
    #[must_use]
    pub const fn t1(&self) -> T {
        self.t1
    }

    /// The step sizes.
    #[must_use]
    pub fn sizes(&self) -> &[T] {
        &self.sizes
    }

    /// +1 forward in time (and for a span of zero), −1 backward.
    fn direction(&self) -> T {
        if self.t1 < self.t0 { -T::ONE } else { T::ONE }
    }

    fn push(&mut self, t: T, h: T) {
        self.starts.push(t);
        self.sizes.push(h);
    }
}

/// The result of [`AdaptiveSolver::solve`]: the states at the output times, the accepted
/// steps, the checkpoints for the adjoint and the [`Stats`].
#[derive(Clone, Debug)]
pub struct AdaptiveSolution<T> {
    pair: Pair,
    layout: StateLayout,
    steps: StepSequence<T>,
    times: Vec<T>,
    outputs: Vec<T>,
    checkpointing: Checkpointing,
    /// States at the start of steps 0, k, 2k, … (ambient).
    states: Vec<T>,
    final_state: Vec<T>,
    stats: Stats,
}

impl<T: Real> AdaptiveSolution<T> {
    /// The pair that made it.
    #[must_use]
    pub const fn pair(&self) -> Pair {
        self.pair
    }

    /// The accepted steps.
    #[must_use]
    pub const fn steps(&self) -> &StepSequence<T> {
        &self.steps
    }

    /// The output times.
    #[must_use]
    pub fn times(&self) -> &[T] {
        &self.times
    }

    /// All outputs, one ambient state per output time.
    #[must_use]
    pub fn outputs(&self) -> &[T] {
        &self.outputs
    }

    /// The state at output time `j` (by dense output).
    ///
    /// # Panics
    /// If `j` is not an output index.
    #[must_use]
    pub fn output(&self, j: usize) -> &[T] {
        let len = self.final_state.len();
        &self.outputs[j * len..(j + 1) * len]
    }

    /// The state at `t1` (the last accepted step's value).
    #[must_use]
    pub fn final_state(&self) -> &[T] {
        &self.final_state
    }

    /// The counters.
    #[must_use]
    pub const fn stats(&self) -> Stats {
        self.stats
    }

    /// The state at the start of step `n` if it was stored (every step with `StoreAll`,
    /// every k-th with `Every(k)`), and the final state for `n = len()`.
    #[must_use]
    pub fn state(&self, n: usize) -> Option<&[T]> {
        let len = self.final_state.len();
        if n == self.steps.len() {
            return Some(&self.final_state);
        }
        let k = self.checkpointing.interval();
        if n > self.steps.len() || !n.is_multiple_of(k) {
            return None;
        }
        let slot = n / k;
        Some(&self.states[slot * len..(slot + 1) * len])
    }

    /// Number of states held (checkpoints and the final state).
    #[must_use]
    pub fn stored_states(&self) -> usize {
        self.states.len() / self.final_state.len().max(1) + 1
    }
}

/// An adaptive solver for one pair and state layout; it owns every buffer, so repeated
/// solves allocate only their results.
///
/// See the [module docs](self) for an example, and [`AdaptiveSolver::adjoint`] for
/// gradients.
#[derive(Clone, Debug)]
pub struct AdaptiveSolver<T> {
    pair: Pair,
    options: AdaptiveOptions<T>,
    layout: StateLayout,
    stepper: Stepper<T>,
    ext: Extension<T>,
    /// `bᵢ − b̂ᵢ`: the error estimate's weights.
    e: [T; MAX_STAGES],
    /// The first stage of the next step (FSAL), `f(t, y)`.
    k0: Vec<T>,
    y_new: Vec<T>,
    /// Tangent scratch: the error estimate, magnitudes of `y` and of `y_new`.
    err: Vec<T>,
    m0: Vec<T>,
    m1: Vec<T>,
    /// Weights and their θ-derivatives of a dense output (s each).
    w: Vec<T>,
    dw: Vec<T>,
    /// The update weights `b` (s).
    b: Vec<T>,
}

impl<T: Real> AdaptiveSolver<T> {
    /// A solver for `pair` on states with this layout.
    #[must_use]
    pub fn new(pair: Pair, layout: StateLayout, options: AdaptiveOptions<T>) -> Self {
        let tableau = pair.tableau();
        let s = tableau.stages();
        let bhat = pair.embedded_weights();
        let mut e = [T::ZERO; MAX_STAGES];
        for i in 0..s {
            // Exact difference, rounded once.
            e[i] = T::from_f64((tableau.b(i) - bhat[i]).to_f64());
        }
        let stepper = Stepper::with_tableau(tableau, layout);
        let b = stepper.weights().to_vec();
        let n = layout.tangent_len();
        Self {
            pair,
            options,
            layout,
            stepper,
            ext: Extension::new(pair),
            e,
            k0: vec![T::ZERO; n],
            y_new: vec![T::ZERO; layout.ambient_len()],
            err: vec![T::ZERO; n],
            m0: vec![T::ZERO; n],
            m1: vec![T::ZERO; n],
            w: vec![T::ZERO; s],
            dw: vec![T::ZERO; s],
            b,
        }
    }

    /// Sets how the per-particle block updates may use threads (bitwise identical results).
    #[must_use]
    pub fn with_par(mut self, par: Par) -> Self {
        self.stepper.set_par(par);
        self
    }

    /// The pair.
    #[must_use]
    pub const fn pair(&self) -> Pair {
        self.pair
    }

    /// The options.
    #[must_use]
    pub const fn options(&self) -> &AdaptiveOptions<T> {
        &self.options
    }

    /// Changes the options (tolerances, limits, checkpointing) for later solves.
    pub const fn set_options(&mut self, options: AdaptiveOptions<T>) {
        self.options = options;
    }

    /// The state layout.
    #[must_use]
    pub const fn layout(&self) -> &StateLayout {
        &self.layout
    }

    fn check_field<F: VectorField<T> + ?Sized>(&self, field: &F) -> Result<(), AdaptiveError> {
        if field.dim() != self.layout.tangent_len() || field.layout() != self.layout {
            return Err(AdaptiveError::LayoutMismatch);
        }
        Ok(())
    }

    fn check_len(what: &'static str, expected: usize, found: usize) -> Result<(), AdaptiveError> {
        if expected == found {
            Ok(())
        } else {
            Err(AdaptiveError::LengthMismatch {
                what,
                expected,
                found,
            })
        }
    }

    fn check_options(&self) -> Result<(), AdaptiveError> {
        let o = &self.options;
        let tol_ok = |v: T| v.is_finite() && v >= T::ZERO;
        if !tol_ok(o.rtol) || !tol_ok(o.atol) || (o.rtol == T::ZERO && o.atol == T::ZERO) {
            return Err(AdaptiveError::InvalidTolerance);
        }
        if !o.control.is_valid(self.pair.embedded_order() + 1) {
            return Err(AdaptiveError::InvalidOption(
                "controller: need 0 < safety ≤ 1, 0 < min_factor ≤ 1 ≤ max_factor, 0 ≤ β < 1/k",
            ));
        }
        if !o.h_min.is_finite() || o.h_min < T::ZERO {
            return Err(AdaptiveError::InvalidOption("h_min must be finite and ≥ 0"));
        }
        if let Some(h) = o.h_max
            && (h.is_nan() || h <= T::ZERO)
        {
            return Err(AdaptiveError::InvalidOption("h_max must be positive"));
        }
        if let Some(h) = o.h_init
            && (!h.is_finite() || h == T::ZERO)
        {
            return Err(AdaptiveError::InvalidOption(
                "h_init must be finite and non-zero",
            ));
        }
        if o.checkpointing == Checkpointing::Every(0) {
            return Err(AdaptiveError::InvalidOption(
                "checkpoint interval must be ≥ 1",
            ));
        }
        Ok(())
    }

    /// Integrates from `(t0, y0)` to `t1` with error control and returns the states at
    /// `output_times` (ascending in the direction of integration, inside `[t0, t1]`,
    /// repeats allowed) by dense output. The steps do not depend on the output times.
    ///
    /// `t1 < t0` integrates backward in time. `t1 = t0` takes no step (every output is
    /// `y0`).
    ///
    /// # Errors
    /// [`AdaptiveError`] for invalid input (lengths, tolerances, options, times) and for a
    /// failing solve (step limit, step size too small); never panics.
    pub fn solve<F: VectorField<T> + ?Sized>(
        &mut self,
        field: &mut F,
        t0: T,
        t1: T,
        y0: &[T],
        output_times: &[T],
    ) -> Result<AdaptiveSolution<T>, AdaptiveError> {
        self.check_field(field)?;
        Self::check_len("y0", self.layout.ambient_len(), y0.len())?;
        if !t0.is_finite() || !t1.is_finite() {
            return Err(AdaptiveError::NonFinite("t0 or t1"));
        }
        if !y0.iter().all(|v| v.is_finite()) {
            return Err(AdaptiveError::NonFinite("y0"));
        }
        self.check_options()?;
        let dir = if t1 < t0 { -T::ONE } else { T::ONE };
        let mut prev = t0;
        for (index, &tau) in output_times.iter().enumerate() {
            if !tau.is_finite() {
                return Err(AdaptiveError::NonFinite("an output time"));
            }
            if (tau - prev) * dir < T::ZERO || (tau - t1) * dir > T::ZERO {
                return Err(AdaptiveError::OutputTime { index });
            }
            prev = tau;
        }
        let len = y0.len();
        let every = self.options.checkpointing.interval();
        let mut sol = AdaptiveSolution {
            pair: self.pair,
            layout: self.layout,
            steps: StepSequence::empty(t0, t1),
            times: output_times.to_vec(),
            outputs: Vec::with_capacity(output_times.len() * len),
            checkpointing: self.options.checkpointing,
            states: Vec::new(),
            final_state: y0.to_vec(),
            stats: Stats::default(),
        };
        if t1 == t0 {
            for _ in output_times {
                sol.outputs.extend_from_slice(y0);
            }
            return Ok(sol);
        }
        let s = self.pair.stages();
        let k = self.pair.embedded_order() + 1;
        let span = (t1 - t0).abs();
        let h_max = self.options.h_max.map_or(span, |h| h.min(span));
        let (rtol, atol) = (self.options.rtol, self.options.atol);
        let control = self.options.control;

        field.eval(t0, y0, &mut self.k0);
        sol.stats.field_evals = 1;
        let mut h = match self.options.h_init {
            Some(h) => h.abs().min(h_max),
            None => {
                sol.stats.field_evals += 1;
                self.initial_step(field, t0, y0, dir, h_max)
            }
        } * dir;

        let mut y = y0.to_vec();
        let mut t = t0;
        tangent_magnitudes(&self.layout, &y, &mut self.m0);
        let mut err_prev = StepControl::<T>::initial_memory();
        let mut after_reject = false;
        let mut next_out = 0;
        let tenth = T::from_f64(0.1);
        loop {
            if sol.stats.accepted + sol.stats.rejected >= self.options.max_steps {
                return Err(AdaptiveError::TooManySteps {
                    t: t.to_f64(),
                    max_steps: self.options.max_steps,
                });
            }
            // Stretch (or cut) the step onto t1 when it is within 1% of the remaining span.
            let last = (t + T::from_f64(1.01) * h - t1) * dir >= T::ZERO;
            if last {
                h = t1 - t;
            }
            if h.abs() < self.options.h_min
                || tenth * h.abs() <= t.abs() * T::EPSILON
                || h == T::ZERO
            {
                return Err(AdaptiveError::StepSizeTooSmall {
                    t: t.to_f64(),
                    h: h.to_f64(),
                });
            }
            self.stepper.eval_stages(field, t, h, &y, Some(&self.k0), s);
            sol.stats.field_evals += s - 1;
            self.y_new.copy_from_slice(&y);
            self.stepper.advance(&self.b, h, &mut self.y_new);
            self.error_estimate(h);
            tangent_magnitudes(&self.layout, &self.y_new, &mut self.m1);
            let err = error_norm(&self.err, &self.m0, &self.m1, rtol, atol);
            if err.is_nan() || err > T::ONE {
                sol.stats.rejected += 1;
                after_reject = true;
                h *= control.reject_factor(err, k);
                continue;
            }
            // Accepted.
            let n = sol.stats.accepted;
            sol.stats.accepted += 1;
            sol.steps.push(t, h);
            if n.is_multiple_of(every) {
                sol.states.extend_from_slice(&y);
            }
            let end = t + h;
            while next_out < output_times.len()
                && (last || (output_times[next_out] - end) * dir <= T::ZERO)
            {
                let theta = sol.steps.theta(n, output_times[next_out]);
                self.ext.weights(theta, &mut self.w, &mut self.dw);
                let from = sol.outputs.len();
                sol.outputs.extend_from_slice(&y);
                let out = &mut sol.outputs[from..];
                self.stepper
                    .advance_kept(&self.w, self.ext.support(), h, out);
                next_out += 1;
            }
            self.k0.copy_from_slice(self.stepper.fsal_slope());
            core::mem::swap(&mut y, &mut self.y_new);
            core::mem::swap(&mut self.m0, &mut self.m1);
            if last {
                break;
            }
            let factor = control.accept_factor(err, err_prev, k, after_reject);
            err_prev = StepControl::remembered(err);
            after_reject = false;
            t = end;
            h = (h.abs() * factor).min(h_max) * dir;
        }
        sol.final_state = y;
        Ok(sol)
    }

    /// `err = h Σ (bᵢ − b̂ᵢ) Kᵢ` (tangent) from the stages of the last attempt.
    fn error_estimate(&mut self, h: T) {
        let n = self.err.len();
        let k = self.stepper.slopes();
        for (e, v) in self.err.iter_mut().enumerate() {
            let mut acc = T::ZERO;
            for (i, &wi) in self.e.iter().enumerate().take(self.b.len()) {
                if wi != T::ZERO {
                    acc += wi * k[i * n + e];
                }
            }
            *v = h * acc;
        }
    }

    /// HNW's initial step (book I, §II.4, with the RMS norm of the error control): one
    /// explicit Euler probe `y₀ ⊕ h₀f₀` (an exponential update on Lie blocks), one field
    /// evaluation. Expects `f(t0, y0)` in `k0`; returns `|h|`.
    fn initial_step<F: VectorField<T> + ?Sized>(
        &mut self,
        field: &mut F,
        t0: T,
        y0: &[T],
        dir: T,
        h_max: T,
    ) -> T {
        let (rtol, atol) = (self.options.rtol, self.options.atol);
        tangent_magnitudes(&self.layout, y0, &mut self.m0);
        let d0 = error_norm(&self.m0, &self.m0, &self.m0, rtol, atol);
        let d1 = error_norm(&self.k0, &self.m0, &self.m0, rtol, atol);
        let h0 = trial_step_size(d0, d1, h_max) * dir;
        // y1 = y0 ⊕ h0 f0 through the stepper's update with weights e₀.
        self.stepper
            .eval_stages(field, t0, h0, y0, Some(&self.k0), 1);
        self.y_new.copy_from_slice(y0);
        self.w.fill(T::ZERO);
        self.w[0] = T::ONE;
        self.stepper.advance(&self.w, h0, &mut self.y_new);
        field.eval(t0 + h0, &self.y_new, &mut self.err);
        for (d, f0) in self.err.iter_mut().zip(&self.k0) {
            *d -= *f0;
        }
        let d2 = error_norm(&self.err, &self.m0, &self.m0, rtol, atol) / h0.abs();
        let k = self.pair.embedded_order() + 1;
        initial_step_size(h0, d1, d2, k, h_max)
    }

    /// Runs the recorded steps again without error control (each step from `f(tₙ, yₙ)`,
    /// bitwise the solve's steps) and writes the states at `output_times` into `outputs`
    /// (one ambient state each) through the same dense output.
    ///
    /// Output times need not be sorted; a time outside the steps' span uses the first or
    /// last step's extension (extrapolation: for differentiating at the ends). The replay
    /// is generic in the scalar, so running it in dual numbers gives exact directional
    /// derivatives of the solve with its steps held fixed.
    ///
    /// # Errors
    /// [`AdaptiveError::LengthMismatch`], [`AdaptiveError::LayoutMismatch`].
    pub fn replay<F: VectorField<T> + ?Sized>(
        &mut self,
        field: &mut F,
        steps: &StepSequence<T>,
        y0: &[T],
        output_times: &[T],
        outputs: &mut [T],
    ) -> Result<(), AdaptiveError> {
        self.check_field(field)?;
        let len = self.layout.ambient_len();
        Self::check_len("y0", len, y0.len())?;
        Self::check_len("outputs", output_times.len() * len, outputs.len())?;
        let order = output_order(steps, output_times);
        let s = self.pair.stages();
        let needed = self.stepper.needed_stages();
        let mut y = y0.to_vec();
        let mut next = 0;
        if steps.is_empty() {
            for o in outputs.chunks_exact_mut(len) {
                o.copy_from_slice(y0);
            }
            return Ok(());
        }
        for n in 0..steps.len() {
            let (t, h) = steps.step(n);
            let first = next;
            while next < order.len() && order[next].0 == n {
                next += 1;
            }
            let upto = if next > first { s } else { needed };
            self.stepper.eval_stages(field, t, h, &y, None, upto);
            for &(_, j) in &order[first..next] {
                let theta = steps.theta(n, output_times[j]);
                self.ext.weights(theta, &mut self.w, &mut self.dw);
                let out = &mut outputs[j * len..(j + 1) * len];
                out.copy_from_slice(&y);
                self.stepper
                    .advance_kept(&self.w, self.ext.support(), h, out);
            }
            self.stepper.advance(&self.b, h, &mut y);
        }
        Ok(())
    }
}

/// `(step, output index)` for every output time, sorted by step (stable: output order
/// within a step).
fn output_order<T: Real>(steps: &StepSequence<T>, times: &[T]) -> Vec<(usize, usize)> {
    let mut order: Vec<(usize, usize)> = times
        .iter()
        .enumerate()
        .filter_map(|(j, &tau)| steps.locate(tau).map(|n| (n, j)))
        .collect();
    order.sort_by_key(|&(n, _)| n);
    order
}

/// [`AdaptiveSolver::solve`] with a fresh solver.
///
/// # Errors
/// See [`AdaptiveSolver::solve`].
pub fn solve_adaptive<T: Real, F: VectorField<T> + ?Sized>(
    field: &mut F,
    pair: Pair,
    options: AdaptiveOptions<T>,
    t0: T,
    t1: T,
    y0: &[T],
    output_times: &[T],
) -> Result<AdaptiveSolution<T>, AdaptiveError> {
    AdaptiveSolver::new(pair, field.layout(), options).solve(field, t0, t1, y0, output_times)
}
