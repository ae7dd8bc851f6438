//! The gradient-check toolkit: central differences, a tolerance report, the VJP
//! dot-product test and forward-mode (dual-number) JVPs.
//!
//! Every hand-written VJP in evogs is checked three ways with these tools:
//!
//! 1. against **central differences** ([`central_gradient`], [`central_jacobian`]) in
//!    `f64`, with the step `h = ε^(1/3)·max(1, |x|)` ([`default_step`]; about 6e-6 in f64),
//!    the optimum balancing truncation `O(h²)` against rounding `O(ε/h)`;
//! 2. by the **dot-product test** ⟨J v, w⟩ = ⟨v, Jᵀ w⟩ for random `v`, `w`
//!    ([`vjp_dot_test`]), which catches a transposed or mis-indexed VJP without any step
//!    size;
//! 3. against **forward mode** ([`dual_jvp`]): the same generic kernel evaluated on
//!    [`Dual`] numbers gives `J v` exactly (to rounding).
//!
//! [`GradCheck`] compares analytic and numeric values with the rule
//! `|a − n| ≤ abs_tol + rel_tol·max(|a|, |n|)` and returns a [`GradReport`] with the worst
//! index, the worst absolute and relative errors and every failure.
//!
//! ```
//! use evogs_math::diff::{central_gradient, GradCheck};
//! // f(x) = x0² x1, ∇f = (2 x0 x1, x0²)
//! let mut x = [1.5, -0.5];
//! let mut num = [0.0; 2];
//! central_gradient(|v: &[f64]| v[0] * v[0] * v[1], &mut x, &mut num);
//! let report = GradCheck::new(1e-9, 1e-8).check(&[-1.5, 2.25], &num);
//! assert!(report.passed(), "{report}");
//! ```

use crate::rng::SplitMix64;
use crate::{Dual, Real};
use alloc::vec;
use alloc::vec::Vec;
use core::fmt;

/// The default central-difference step for a coordinate of value `x`:
/// `ε^(1/3)·max(1, |x|)` (≈ 6.1e-6 in f64, ≈ 4.9e-3 in f32).
#[inline]
#[must_use]
pub fn default_step<T: Real>(x: T) -> T {
    T::EPSILON.cbrt() * x.abs().max(T::ONE)
}

/// Central-difference gradient of a scalar function, with [`default_step`].
///
/// `x` is perturbed in place and restored exactly; `out[i] ≈ ∂f/∂x_i`.
///
/// # Panics
/// If `out.len() != x.len()`.
pub fn central_gradient<T: Real>(f: impl FnMut(&[T]) -> T, x: &mut [T], out: &mut [T]) {
    central_gradient_with_step(f, x, default_step, out);
}

/// Central-difference gradient with a caller-chosen step rule `step(x_i)`.
///
/// # Panics
/// If `out.len() != x.len()`.
pub fn central_gradient_with_step<T: Real>(
    mut f: impl FnMut(&[T]) -> T,
    x: &mut [T],
    step: impl Fn(T) -> T,
    out: &mut [T],
) {
    assert_eq!(out.len(), x.len(), "gradient buffer has the wrong length");
    for i in 0..x.len() {
        let xi = x[i];
        let h = step(xi);
        x[i] = xi + h;
        let fp = f(x);
        x[i] = xi - h;
        let fm = f(x);
        x[i] = xi;
        // Divide by the step actually taken (x ± h rounded), not by the nominal 2h.
        out[i] = (fp - fm) / ((xi + h) - (xi - h));
    }
}

/// Central-difference Jacobian of `f: Rⁿ → Rᵐ`, row-major `out[i·n + j] = ∂f_i/∂x_j`.
///
/// `plus` and `minus` are caller-provided scratch buffers of length `m`.
///
/// # Panics
/// If the buffer lengths do not match `m = plus.len()` and `n = x.len()`.
pub fn central_jacobian<T: Real>(
    mut f: impl FnMut(&[T], &mut [T]),
    x: &mut [T],
    out: &mut [T],
    plus: &mut [T],
    minus: &mut [T],
) {
    let n = x.len();
    let m = plus.len();
    assert_eq!(minus.len(), m, "scratch buffers differ in length");
    assert_eq!(out.len(), m * n, "Jacobian buffer must hold m·n entries");
    for j in 0..n {
        let xj = x[j];
        let h = default_step(xj);
        x[j] = xj + h;
        f(x, plus);
        x[j] = xj - h;
        f(x, minus);
        x[j] = xj;
        let inv = T::ONE / ((xj + h) - (xj - h));
        for i in 0..m {
            out[i * n + j] = (plus[i] - minus[i]) * inv;
        }
    }
}

/// Central-difference Jacobian, allocating (`m` outputs); row-major `m × n`.
pub fn central_jacobian_vec<T: Real>(f: impl FnMut(&[T], &mut [T]), x: &[T], m: usize) -> Vec<T> {
    let mut xs = x.to_vec();
    let mut out = vec![T::ZERO; m * x.len()];
    let mut plus = vec![T::ZERO; m];
    let mut minus = vec![T::ZERO; m];
    central_jacobian(f, &mut xs, &mut out, &mut plus, &mut minus);
    out
}

/// Central-difference directional derivative `J v ≈ (f(x + h v) − f(x − h v))/(2h)`.
pub fn central_jvp<T: Real>(mut f: impl FnMut(&[T], &mut [T]), x: &[T], v: &[T], out: &mut [T]) {
    let scale = x.iter().fold(T::ONE, |a, &b| a.max(b.abs()));
    let vn = v
        .iter()
        .fold(T::ZERO, |a, &b| a.max(b.abs()))
        .max(T::EPSILON);
    let h = T::EPSILON.cbrt() * scale / vn;
    let xp: Vec<T> = x.iter().zip(v).map(|(&a, &b)| a + h * b).collect();
    let xm: Vec<T> = x.iter().zip(v).map(|(&a, &b)| a - h * b).collect();
    let mut fm = vec![T::ZERO; out.len()];
    f(&xp, out);
    f(&xm, &mut fm);
    let inv = T::ONE / (h + h);
    for (o, m) in out.iter_mut().zip(&fm) {
        *o = (*o - *m) * inv;
    }
}

/// Forward-mode directional derivative `J v` of a function written for dual numbers.
///
/// Evaluates `f` once at `x + v ε`; the dual parts of the outputs are `J v`, exact to
/// rounding. `out.len()` is the number of outputs.
///
/// ```
/// use evogs_math::{Dual, Real, diff::dual_jvp};
/// let f = |x: &[Dual<f64>], y: &mut [Dual<f64>]| {
///     y[0] = x[0] * x[1];
///     y[1] = x[0].sin();
/// };
/// let mut jv = [0.0; 2];
/// dual_jvp(f, &[2.0, 3.0], &[1.0, 0.0], &mut jv);
/// assert_eq!(jv[0], 3.0);
/// assert!((jv[1] - 2.0_f64.cos()).abs() < 1e-16);
/// ```
pub fn dual_jvp<T: Real>(
    mut f: impl FnMut(&[Dual<T>], &mut [Dual<T>]),
    x: &[T],
    v: &[T],
    out: &mut [T],
) {
    let xd: Vec<Dual<T>> = x.iter().zip(v).map(|(&a, &b)| Dual::new(a, b)).collect();
    let mut yd = vec![Dual::<T>::ZERO; out.len()];
    f(&xd, &mut yd);
    for (o, y) in out.iter_mut().zip(&yd) {
        *o = y.eps;
    }
}

/// The dot-product test: returns the relative mismatch of ⟨J v, w⟩ and ⟨v, Jᵀ w⟩ for
/// seeded random `v ∈ Rⁿ`, `w ∈ Rᵐ` (entries in [−1, 1)).
///
/// `jvp(v, out)` writes `J v` (m values); `vjp(w, out)` writes `Jᵀ w` (n values). With an
/// exact JVP (dual numbers) the mismatch of a correct VJP is ~1e-15; with a
/// finite-difference JVP, ~1e-9.
///
/// ```
/// use evogs_math::diff::vjp_dot_test;
/// // J = [[1, 2], [3, 4], [5, 6]]
/// let j = [[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]];
/// let r = vjp_dot_test(
///     |v: &[f64], o: &mut [f64]| for i in 0..3 { o[i] = j[i][0] * v[0] + j[i][1] * v[1] },
///     |w: &[f64], o: &mut [f64]| for k in 0..2 { o[k] = (0..3).map(|i| j[i][k] * w[i]).sum() },
///     2, 3, 1,
/// );
/// assert!(r < 1e-15);
/// ```
pub fn vjp_dot_test<T: Real>(
    mut jvp: impl FnMut(&[T], &mut [T]),
    mut vjp: impl FnMut(&[T], &mut [T]),
    n_in: usize,
    n_out: usize,
    seed: u64,
) -> f64 {
    let mut rng = SplitMix64::new(seed);
    let v: Vec<T> = (0..n_in)
        .map(|_| T::from_f64(rng.uniform(-1.0, 1.0)))
        .collect();
    let w: Vec<T> = (0..n_out)
        .map(|_| T::from_f64(rng.uniform(-1.0, 1.0)))
        .collect();
    let mut jv = vec![T::ZERO; n_out];
    let mut jtw = vec![T::ZERO; n_in];
    jvp(&v, &mut jv);
    vjp(&w, &mut jtw);
    let a: f64 = jv
        .iter()
        .zip(&w)
        .map(|(x, y)| x.to_f64() * y.to_f64())
        .sum();
    let b: f64 = v
        .iter()
        .zip(&jtw)
        .map(|(x, y)| x.to_f64() * y.to_f64())
        .sum();
    let scale_a: f64 = jv
        .iter()
        .zip(&w)
        .map(|(x, y)| (x.to_f64() * y.to_f64()).abs())
        .sum();
    let scale_b: f64 = v
        .iter()
        .zip(&jtw)
        .map(|(x, y)| (x.to_f64() * y.to_f64()).abs())
        .sum();
    let scale = scale_a.max(scale_b).max(f64::MIN_POSITIVE);
    num_traits::Float::abs(a - b) / scale
}

/// Tolerances for comparing an analytic gradient with a reference:
/// pass if `|a − n| ≤ abs_tol + rel_tol·max(|a|, |n|)` for every entry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GradCheck {
    /// Absolute tolerance.
    pub abs_tol: f64,
    /// Relative tolerance.
    pub rel_tol: f64,
}

/// One entry that failed a [`GradCheck`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GradFailure {
    /// Index into the compared slices.
    pub index: usize,
    /// Analytic value.
    pub analytic: f64,
    /// Reference (numeric) value.
    pub numeric: f64,
}

/// The outcome of a [`GradCheck`]: worst entries, errors and all failures.
#[derive(Clone, Debug, PartialEq)]
pub struct GradReport {
    /// Number of entries compared.
    pub len: usize,
    /// Index with the largest error relative to its allowance (`None` if empty).
    pub worst_index: Option<usize>,
    /// Largest absolute error `|a − n|` over all entries.
    pub max_abs_err: f64,
    /// Largest relative error `|a − n|/max(|a|, |n|)` over all entries (0 where both are 0).
    pub max_rel_err: f64,
    /// Largest ratio of error to allowance; the check passes iff it is ≤ 1.
    pub worst_ratio: f64,
    /// Every failing entry, in index order.
    pub failures: Vec<GradFailure>,
    /// The tolerances used.
    pub tolerance: GradCheck,
}

impl GradCheck {
    /// Tolerances `abs_tol` and `rel_tol`.
    #[must_use]
    pub const fn new(abs_tol: f64, rel_tol: f64) -> Self {
        Self { abs_tol, rel_tol }
    }

    /// Compares `analytic` with `numeric` entry by entry.
    ///
    /// A NaN on either side is a failure.
    ///
    /// # Panics
    /// If the slices differ in length.
    #[must_use]
    pub fn check<T: Real>(&self, analytic: &[T], numeric: &[T]) -> GradReport {
        assert_eq!(
            analytic.len(),
            numeric.len(),
            "compared slices differ in length"
        );
        let mut rep = GradReport {
            len: analytic.len(),
            worst_index: None,
            max_abs_err: 0.0,
            max_rel_err: 0.0,
            worst_ratio: 0.0,
            failures: Vec::new(),
            tolerance: *self,
        };
        for (i, (a, n)) in analytic.iter().zip(numeric).enumerate() {
            let (a, n) = (a.to_f64(), n.to_f64());
            let err = num_traits::Float::abs(a - n);
            let mag = num_traits::Float::abs(a).max(num_traits::Float::abs(n));
            let rel = if mag > 0.0 { err / mag } else { 0.0 };
            let allow = self.abs_tol + self.rel_tol * mag;
            let ratio = if err.is_nan() {
                f64::INFINITY
            } else if allow > 0.0 {
                err / allow
            } else if err > 0.0 {
                f64::INFINITY
            } else {
                0.0
            };
            if err.is_nan() || err > rep.max_abs_err {
                rep.max_abs_err = if err.is_nan() { f64::NAN } else { err };
            }
            if rel > rep.max_rel_err {
                rep.max_rel_err = rel;
            }
            if rep.worst_index.is_none() || ratio > rep.worst_ratio {
                rep.worst_ratio = ratio;
                rep.worst_index = Some(i);
            }
            if ratio > 1.0 {
                rep.failures.push(GradFailure {
                    index: i,
                    analytic: a,
                    numeric: n,
                });
            }
        }
        rep
    }
}

impl GradReport {
    /// `true` if every entry is within tolerance.
    #[must_use]
    pub fn passed(&self) -> bool {
        self.failures.is_empty()
    }

    /// Panics with the full report if the check failed.
    ///
    /// # Panics
    /// If any entry is out of tolerance.
    #[track_caller]
    pub fn assert_passed(&self, what: &str) {
        assert!(self.passed(), "gradient check failed for {what}: {self}");
    }
}

impl fmt::Display for GradReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} entries, max abs err {:.3e}, max rel err {:.3e}, worst index {:?} ({:.3} of allowance; abs_tol {:.1e}, rel_tol {:.1e})",
            self.len,
            self.max_abs_err,
            self.max_rel_err,
            self.worst_index,
            self.worst_ratio,
            self.tolerance.abs_tol,
            self.tolerance.rel_tol
        )?;
        if !self.failures.is_empty() {
            write!(f, "; {} failures:", self.failures.len())?;
            for fl in self.failures.iter().take(12) {
                write!(
                    f,
                    " [{}] analytic {:.6e} vs numeric {:.6e};",
                    fl.index, fl.analytic, fl.numeric
                )?;
            }
            if self.failures.len() > 12 {
                write!(f, " …")?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn central_jvp_steps_by_the_documented_h_and_divides_by_2h() {
        // The points it evaluates at are x ± h·v with h = ε^(1/3)·max(1, |x|∞)/|v|∞.
        let x = [50.0_f64, -1.25];
        let v = [300.0_f64, -500.0];
        let mut seen: Vec<Vec<f64>> = Vec::new();
        let mut out = [0.0; 2];
        central_jvp(
            |p: &[f64], o: &mut [f64]| {
                seen.push(p.to_vec());
                o[0] = 2.0 * p[0] - 3.0 * p[1];
                o[1] = 0.5 * p[1];
            },
            &x,
            &v,
            &mut out,
        );
        let h = f64::EPSILON.cbrt() * 50.0 / 500.0;
        assert_eq!(seen.len(), 2);
        for (k, sign) in [(0, 1.0), (1, -1.0)] {
            for i in 0..2 {
                let want = x[i] + sign * h * v[i];
                assert!(
                    (seen[k][i] - want).abs() <= 1e-12 * want.abs().max(1.0),
                    "{seen:?}"
                );
            }
        }
        // A linear map: J v exactly (up to rounding).
        let jv = [2.0 * v[0] - 3.0 * v[1], 0.5 * v[1]];
        for i in 0..2 {
            assert!(
                (out[i] - jv[i]).abs() <= 1e-6 * jv[i].abs(),
                "{out:?} {jv:?}"
            );
        }
    }

    #[test]
    fn the_dot_test_measures_the_relative_mismatch_in_random_directions() {
        // ⟨J v, w⟩ = 2vw against ⟨v, Jᵀ w⟩ = 3vw: mismatch |2 − 3|/3 = 1/3 exactly.
        let r = vjp_dot_test(
            |v: &[f64], o: &mut [f64]| o[0] = 2.0 * v[0],
            |w: &[f64], o: &mut [f64]| o[0] = 3.0 * w[0],
            1,
            1,
            5,
        );
        assert!((r - 1.0 / 3.0).abs() < 1e-12, "{r}");
        // The same the other way round: the scale is then the JVP side's.
        let r = vjp_dot_test(
            |v: &[f64], o: &mut [f64]| o[0] = 3.0 * v[0],
            |w: &[f64], o: &mut [f64]| o[0] = 2.0 * w[0],
            1,
            1,
            5,
        );
        assert!((r - 1.0 / 3.0).abs() < 1e-12, "{r}");
        // Wrong VJPs that agree with the JVP along v = (1, 1), or along w = (1, 1), for every
        // other vector: random directions in both see them.
        type Map = fn(&[f64], &mut [f64]);
        let jvp: Map = |v, o| {
            o[0] = v[0] + 2.0 * v[1];
            o[1] = 3.0 * v[0] + 4.0 * v[1];
        };
        let along_ones_in: Map = |w, o| {
            o[0] = 3.0 * w[0] + 7.0 * w[1];
            o[1] = 0.0;
        };
        let along_ones_out: Map = |w, o| {
            o[0] = 4.0 * w[0];
            o[1] = 6.0 * w[1];
        };
        for wrong in [along_ones_in, along_ones_out] {
            for seed in 0..4 {
                let r = vjp_dot_test(jvp, wrong, 2, 2, seed);
                assert!(r > 1e-6, "seed {seed}: a wrong VJP passed ({r})");
            }
        }
    }

    #[test]
    fn grad_check_reports_its_errors_and_ratios_exactly() {
        let c = GradCheck::new(0.0, 0.05);
        let r = c.check(&[1.0_f64, 2.0, 0.0, 4.0], &[1.1, 2.0, 0.0, 4.2]);
        let (e0, e3) = ((1.0_f64 - 1.1).abs(), (4.0_f64 - 4.2).abs());
        assert_eq!(r.max_abs_err.to_bits(), e3.to_bits(), "{r:?}");
        assert_eq!(r.max_rel_err.to_bits(), (e0 / 1.1).to_bits(), "{r:?}");
        assert_eq!(r.worst_index, Some(0), "{r:?}");
        assert_eq!(
            r.worst_ratio.to_bits(),
            (e0 / (0.05 * 1.1)).to_bits(),
            "{r:?}"
        );
        let failed: Vec<usize> = r.failures.iter().map(|f| f.index).collect();
        assert_eq!(failed, [0], "{r:?}: 4.2 against 4.0 is within 5 %");
        // Zero allowance: any error fails, no error passes.
        let strict = GradCheck::new(0.0, 0.0);
        let r = strict.check(&[1.0_f64], &[1.5]);
        assert!(r.worst_ratio.is_infinite() && !r.passed(), "{r:?}");
        let r = strict.check(&[0.0_f64, 3.0], &[0.0, 3.0]);
        assert_eq!(r.worst_ratio.to_bits(), 0.0_f64.to_bits(), "{r:?}");
        assert!(r.passed() && r.failures.is_empty(), "{r:?}");
        assert_eq!(r.worst_index, Some(0), "{r:?}: the first of equal ratios");
        // An entry within tolerance after a failing one keeps the worst; a worse one later
        // takes it; of equal ratios the first stays.
        let r = c.check(&[1.0_f64, 1.0], &[2.0, 1.01]);
        assert_eq!(r.worst_index, Some(0), "{r:?}");
        assert_eq!(r.max_rel_err.to_bits(), 0.5_f64.to_bits(), "{r:?}");
        let r = c.check(&[1.0_f64, 1.0], &[1.01, 2.0]);
        assert_eq!(r.worst_index, Some(1), "{r:?}");
        let r = c.check(&[1.0_f64, 1.0], &[1.1, 1.1]);
        assert_eq!(r.worst_index, Some(0), "{r:?}");
        // An error exactly at the allowance passes.
        let r = GradCheck::new(0.5, 0.0).check(&[1.0_f64], &[1.5]);
        assert_eq!(r.worst_ratio.to_bits(), 1.0_f64.to_bits(), "{r:?}");
        assert!(r.passed(), "{r:?}");
    }

    #[test]
    fn a_report_prints_its_figures_and_at_most_twelve_failures() {
        let c = GradCheck::new(0.0, 1e-3);
        let ok = c.check(&[1.0_f64, 2.0], &[1.0, 2.0]);
        ok.assert_passed("equal slices");
        let text = ok.to_string();
        assert!(text.starts_with("2 entries, max abs err 0.000e0"), "{text}");
        assert!(!text.contains("failures"), "{text}");
        let twelve = c.check(&[1.0_f64; 12], &[2.0; 12]);
        let text = twelve.to_string();
        assert!(
            text.contains("; 12 failures: [0] analytic 1.000000e0 vs numeric 2.000000e0;"),
            "{text}"
        );
        assert!(!text.ends_with(" …"), "{text}");
        let thirteen = c.check(&[1.0_f64; 13], &[2.0; 13]);
        let text = thirteen.to_string();
        assert!(
            text.contains("13 failures") && text.ends_with(" …"),
            "{text}"
        );
        assert!(!text.contains("[12]"), "{text}: the first twelve only");
    }

    #[test]
    #[should_panic(expected = "gradient check failed for the example: 1 entries")]
    fn a_failed_report_panics_when_asserted() {
        GradCheck::new(0.0, 1e-3)
            .check(&[1.0_f64], &[2.0])
            .assert_passed("the example");
    }

    #[test]
    fn the_default_step_is_the_cube_root_of_epsilon_times_the_magnitude() {
        let h = f64::EPSILON.cbrt();
        let bits = |x: f64| x.to_bits();
        assert_eq!(bits(default_step(0.0_f64)), bits(h));
        assert_eq!(
            bits(default_step(0.5_f64)),
            bits(h),
            "below one the step is absolute"
        );
        assert_eq!(bits(default_step(4.0_f64)), bits(4.0 * h));
        assert_eq!(bits(default_step(-8.0_f64)), bits(8.0 * h));
        assert_eq!(
            default_step(2.0_f32).to_bits(),
            (2.0 * f32::EPSILON.cbrt()).to_bits()
        );
    }

    #[test]
    fn check_reports_worst_and_failures() {
        let r = GradCheck::new(1e-6, 1e-3).check(&[1.0, 2.0, 3.0], &[1.0, 2.1, 3.0]);
        assert!(!r.passed(), "0.1 off must fail");
        assert_eq!(r.worst_index, Some(1), "worst index");
        assert_eq!(r.failures.len(), 1, "one failure");
        assert!((r.max_abs_err - 0.1).abs() < 1e-12, "abs err");
    }

    #[test]
    fn nan_fails() {
        let r = GradCheck::new(1.0, 1.0).check(&[f64::NAN], &[0.0]);
        assert!(!r.passed(), "NaN must never pass");
    }

    #[test]
    fn central_jacobian_of_linear_map_is_exact() {
        let j = central_jacobian_vec(
            |x: &[f64], y: &mut [f64]| {
                y[0] = 2.0 * x[0] - x[1];
                y[1] = 0.5 * x[1];
                y[2] = x[0] + x[1];
            },
            &[0.3, 0.7],
            3,
        );
        let want = [2.0, -1.0, 0.0, 0.5, 1.0, 1.0];
        assert!(
            GradCheck::new(1e-10, 0.0).check(&j, &want).passed(),
            "linear Jacobian"
        );
    }

    #[test]
    fn dot_test_detects_a_transposed_vjp() {
        let j = [[1.0, 2.0], [3.0, 4.0]];
        let r = vjp_dot_test(
            |v: &[f64], o: &mut [f64]| {
                for i in 0..2 {
                    o[i] = j[i][0] * v[0] + j[i][1] * v[1];
                }
            },
            // Wrong: J w instead of Jᵀ w.
            |w: &[f64], o: &mut [f64]| {
                for i in 0..2 {
                    o[i] = j[i][0] * w[0] + j[i][1] * w[1];
                }
            },
            2,
            2,
            3,
        );
        assert!(
            r > 1e-3,
            "a transposed VJP must fail the dot test (residual {r})"
        );
    }
}
