//! Empirical convergence orders: [`estimate_order`] and [`convergence_study`].
//!
//! For a method of order p the global error behaves like `C·hᵖ` once h is small enough,
//! until rounding takes over. The **successive observed orders**
//!
//! ```text
//! pₖ = log(eₖ/eₖ₊₁) / log(hₖ/hₖ₊₁)
//! ```
//!
//! are erratic in the pre-asymptotic regime (large h) and at the rounding floor (tiny
//! errors), and settle at p in between. [`estimate_order`] keeps the points whose errors
//! lie in a window (by default `1e3·ε` to `1e-2`), takes the reference order from the
//! finest successive orders there, extends the "clean range" toward coarser steps while
//! the successive orders stay within a tolerance of it, and least-squares fits the slope of
//! `log e` against `log h` over that range. Fitting one slope over everything is what
//! misreads slow pre-asymptotics (`docs/integrators.md` §8; Kutta3 on `y' = cos(t)y` fits 3.40 over
//! the whole range, while the successive orders settle at 3.00).

use crate::problems::ExactProblem;
use crate::{Stepper, Tableau, TimeGrid, integrate_steps};
use alloc::vec;
use alloc::vec::Vec;
use evogs_math::Real;

/// The window and tolerance of [`estimate_order_with`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrderWindow {
    /// Errors below this are at the rounding floor (default `1e3·ε ≈ 2.2e-13`: scale it by
    /// the solution's magnitude if that is far from 1).
    pub floor: f64,
    /// Errors above this are pre-asymptotic (default `1e-2`).
    pub ceiling: f64,
    /// How far successive orders may stray from the reference order inside the clean
    /// range (default 0.1).
    pub tolerance: f64,
}

impl Default for OrderWindow {
    fn default() -> Self {
        Self {
            floor: 1e3 * f64::EPSILON,
            ceiling: 1e-2,
            tolerance: 0.1,
        }
    }
}

/// An order estimate over a refinement sequence.
#[derive(Clone, Debug, PartialEq)]
pub struct OrderEstimate {
    /// The least-squares slope of `log e` against `log h` over `first..=last`.
    pub order: f64,
    /// First index of the clean range.
    pub first: usize,
    /// Last index of the clean range.
    pub last: usize,
    /// Successive observed orders `pₖ` between points k and k+1 (NaN where undefined).
    pub successive: Vec<f64>,
}

fn ln(x: f64) -> f64 {
    Real::ln(x)
}

/// Successive observed orders `log(eₖ/eₖ₊₁)/log(hₖ/hₖ₊₁)` (NaN where an error is not
/// positive and finite).
#[must_use]
pub fn successive_orders(hs: &[f64], errors: &[f64]) -> Vec<f64> {
    hs.windows(2)
        .zip(errors.windows(2))
        .map(|(h, e)| {
            let ok = e.iter().all(|&x| x > 0.0 && x.is_finite()) && (h[0] - h[1]).abs() > 0.0;
            if ok {
                ln(e[0] / e[1]) / ln(h[0] / h[1])
            } else {
                f64::NAN
            }
        })
        .collect()
}

/// [`estimate_order_with`] with the default [`OrderWindow`].
///
/// ```
/// use evogs_ode::order::estimate_order;
/// let hs: Vec<f64> = (0..8).map(|k| 0.5_f64.powi(k)).collect();
/// let errors: Vec<f64> = hs.iter().map(|h| 3e-3 * h.powi(2) * (1.0 + h)).collect();
/// let est = estimate_order(&hs, &errors).unwrap();
/// assert!((est.order - 2.0).abs() < 0.05);
/// ```
#[must_use]
pub fn estimate_order(hs: &[f64], errors: &[f64]) -> Option<OrderEstimate> {
    estimate_order_with(hs, errors, OrderWindow::default())
}

/// Estimates the convergence order from step sizes `hs` and errors `errors` (same
/// length, any monotone order of h).
///
/// Returns `None` if fewer than two consecutive points lie inside the window, or if no
/// successive order there is within the tolerance of the reference (a step size repeated,
/// or a tolerance that admits nothing).
///
/// # Panics
/// If the slices differ in length.
#[must_use]
pub fn estimate_order_with(
    hs: &[f64],
    errors: &[f64],
    window: OrderWindow,
) -> Option<OrderEstimate> {
    assert_eq!(hs.len(), errors.len(), "one error per step size");
    let successive = successive_orders(hs, errors);
    let inside = |i: usize| {
        let e = errors[i];
        e.is_finite() && e >= window.floor && e <= window.ceiling && hs[i] > 0.0
    };
    // The longest run of consecutive points inside the window (the finer one on ties).
    let (mut best, mut run_start) = (None::<(usize, usize)>, None::<usize>);
    for i in 0..=hs.len() {
        if i < hs.len() && inside(i) {
            run_start.get_or_insert(i);
        } else if let Some(s) = run_start.take() {
            let e = i - 1;
            if best.is_none_or(|(bs, be)| e - s >= be - bs) {
                best = Some((s, e));
            }
        }
    }
    let (a, b) = best?;
    if b == a {
        return None;
    }
    // Reference order: the median of the (up to) three finest successive orders.
    let mut tail: Vec<f64> = successive[a.max(b.saturating_sub(3))..b].to_vec();
    tail.sort_by(f64::total_cmp);
    let p_ref = tail[tail.len() / 2];
    let near = |k: usize| (successive[k] - p_ref).abs() <= window.tolerance;
    // Trim deviating pairs at the fine end, then extend toward coarse steps.
    let mut last = b;
    while last > a && !near(last - 1) {
        last -= 1;
    }
    if last == a {
        // No pair is near the reference: it is NaN (steps that repeat) or the tolerance
        // admits nothing (negative or NaN).
        return None;
    }
    // `near(last − 1)` holds, so the range holds at least that pair.
    let mut first = last;
    while first > a && near(first - 1) {
        first -= 1;
    }
    // Least-squares slope of log e against log h.
    let m = f64::from(u32::try_from(last - first + 1).unwrap_or(u32::MAX));
    let (mut sx, mut sy) = (0.0, 0.0);
    for i in first..=last {
        sx += ln(hs[i]);
        sy += ln(errors[i]);
    }
    let (mx, my) = (sx / m, sy / m);
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for i in first..=last {
        let dx = ln(hs[i]) - mx;
        sxy += dx * (ln(errors[i]) - my);
        sxx += dx * dx;
    }
    Some(OrderEstimate {
        order: sxy / sxx,
        first,
        last,
        successive,
    })
}

/// Sample times per interval in [`convergence_study`].
pub const SAMPLES: usize = 8;

/// A convergence study of one method on one problem: per-N step sizes and errors, and the
/// fitted order.
#[derive(Clone, Debug, PartialEq)]
pub struct ConvergenceStudy {
    /// The method's name.
    pub method: &'static str,
    /// The problem's name.
    pub problem: &'static str,
    /// Step counts.
    pub ns: Vec<usize>,
    /// Step sizes `|t_end − t0|/N`.
    pub hs: Vec<f64>,
    /// Global errors: the maximum of [`ExactProblem::error`] over the sample times
    /// `t0 + (j/8)(t_end − t0)`, `j = 1..=8`, that are grid points (all of them when 8
    /// divides N; `t_end` always). These are what the order is fitted to.
    pub errors: Vec<f64>,
    /// Errors at `t_end` alone (for reports).
    pub end_errors: Vec<f64>,
    /// The order estimate from `errors` (`None` if no clean range was found).
    pub estimate: Option<OrderEstimate>,
}

/// Integrates `problem` from `t0` to `t_end` with `N` uniform steps for each `N` in `ns`,
/// measures the global error against the exact solution, then [`estimate_order`].
///
/// The error is the maximum over [`SAMPLES`] fixed times of the interval rather than the
/// error at `t_end` alone: the end-time error constant of a method can happen to be small
/// for a given problem and end time, which leaves the next order's term dominant until the
/// rounding floor (e.g. the 3/8 rule on `y' = cos(t)y` at `T = 4`: successive end-time
/// orders 4.69, 4.51, 4.34, 4.21, 4.12, 4.01, then rounding).
///
/// ```
/// use evogs_ode::{Method, order::convergence_study, problems::Logistic};
/// let ns: Vec<usize> = (3..10).map(|k| 1 << k).collect();
/// let study = convergence_study(&mut Logistic::default(), Method::Rk4, &ns);
/// assert!((study.estimate.unwrap().order - 4.0).abs() < 0.15);
/// ```
pub fn convergence_study<P: ExactProblem<f64> + ?Sized>(
    problem: &mut P,
    tableau: impl Into<Tableau>,
    ns: &[usize],
) -> ConvergenceStudy {
    let tableau = tableau.into();
    let layout = problem.layout();
    let mut stepper = Stepper::with_tableau(tableau, layout);
    let (t0, t1) = (problem.t0(), problem.t_end());
    let mut y = vec![0.0; layout.ambient_len()];
    let mut exact = vec![0.0; layout.ambient_len()];
    let mut hs = Vec::with_capacity(ns.len());
    let mut errors = Vec::with_capacity(ns.len());
    let mut end_errors = Vec::with_capacity(ns.len());
    for &n in ns {
        let grid = TimeGrid::uniform(t0, t1, n);
        problem.initial_state(&mut y);
        let mut worst: f64 = 0.0;
        let mut done = 0;
        for j in 1..=SAMPLES {
            if (j * n) % SAMPLES != 0 {
                continue;
            }
            let k = j * n / SAMPLES;
            integrate_steps(problem, &mut stepper, &grid, done, k, &mut y);
            done = k;
            problem.exact(grid.time(k), &mut exact);
            let e = problem.error(&y, &exact);
            worst = worst.max(e);
            if j == SAMPLES {
                end_errors.push(e);
            }
        }
        hs.push(grid.h().abs());
        errors.push(worst);
    }
    let estimate = estimate_order(&hs, &errors);
    ConvergenceStudy {
        method: tableau.name(),
        problem: problem.name(),
        ns: ns.to_vec(),
        hs,
        errors,
        end_errors,
        estimate,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hs(n: usize) -> Vec<f64> {
        (0..n)
            .map(|k| Real::powi(0.5, i32::try_from(k).expect("small")))
            .collect()
    }

    #[test]
    fn clean_range_excludes_pre_asymptotics_and_the_rounding_floor() {
        let h = hs(16);
        // 4th order with a large 5th-order term, plus a rounding floor of 1e-14 with noise.
        let errors: Vec<f64> = h
            .iter()
            .enumerate()
            .map(|(k, &h)| {
                let noise = if k % 2 == 0 { 1.0 } else { 0.3 };
                0.5 * h.powi(4) * (1.0 + 8.0 * h) + 1e-14 * noise
            })
            .collect();
        let est = estimate_order(&h, &errors).expect("clean range");
        assert!((est.order - 4.0).abs() < 0.06, "fitted {}", est.order);
        assert!(
            errors[est.last] >= OrderWindow::default().floor,
            "floor excluded"
        );
        assert!(
            est.successive[est.first] < 4.2,
            "pre-asymptotic pairs excluded: {:?}",
            est.successive
        );
        // A naive fit over everything is far off.
        let all = estimate_order_with(
            &h,
            &errors,
            OrderWindow {
                floor: 0.0,
                ceiling: f64::INFINITY,
                tolerance: f64::INFINITY,
            },
        )
        .expect("fit");
        assert!((all.order - 4.0).abs() > 0.3, "naive fit {}", all.order);
    }

    #[test]
    fn no_clean_range_gives_none() {
        let h = hs(5);
        assert!(
            estimate_order(&h, &[1.0, 0.5, 0.3, 0.2, 0.1]).is_none(),
            "all too large"
        );
        assert!(
            estimate_order(&h, &[1e-16; 5]).is_none(),
            "all at the floor"
        );
    }

    #[test]
    fn successive_orders_are_exact_for_power_laws() {
        let h = hs(6);
        let e: Vec<f64> = h.iter().map(|h| 3.0 * h * h * h).collect();
        for p in successive_orders(&h, &e) {
            assert!((p - 3.0).abs() < 1e-12, "successive order {p}");
        }
    }

    #[test]
    fn successive_orders_are_nan_where_undefined() {
        let inf = f64::INFINITY;
        // (h₀, h₁, e₀, e₁): an error that is not positive and finite, or two equal steps.
        for (h0, h1, e0, e1) in [
            (1.0, 0.5, 0.0, 1e-3),
            (1.0, 0.5, 1e-3, 0.0),
            (1.0, 0.5, inf, 1e-3),
            (1.0, 0.5, 1e-3, inf),
            (1.0, 0.5, -1e-3, 1e-3),
            (1.0, 0.5, f64::NAN, 1e-3),
            (0.5, 0.5, 2e-3, 1e-3),
            (-0.5, -0.5, 2e-3, 1e-3),
        ] {
            let p = successive_orders(&[h0, h1], &[e0, e1]);
            assert!(p.len() == 1 && p[0].is_nan(), "{h0} {h1} {e0} {e1}: {p:?}");
        }
        // Defined: the order of the pair, whichever way h runs.
        assert_eq!(successive_orders(&[1.0, 0.5], &[4e-3, 1e-3]), [2.0]);
        assert_eq!(successive_orders(&[0.5, 1.0], &[1e-3, 4e-3]), [2.0]);
    }

    /// Errors `1e-3·hᵖ` at `h = 2⁻ᵏ`, `k = 0..orders.len()`, with `p` per point; `None` puts
    /// the point above the window (1.0).
    fn errors_of(orders: &[Option<i32>]) -> (Vec<f64>, Vec<f64>) {
        let h = hs(orders.len());
        let e = h
            .iter()
            .zip(orders)
            .map(|(h, p)| p.map_or(1.0, |p| 1e-3 * h.powi(p)))
            .collect();
        (h, e)
    }

    #[test]
    fn the_longest_run_inside_the_window_is_fitted_the_finer_on_ties() {
        let (o, x) = (None, Some(2));
        // (orders, the run fitted)
        for (orders, run) in [
            (vec![o, x, x, x, x, o, x, x], (1, 4)),
            (vec![o, x, x, o, x, x, x, x], (4, 7)),
            (vec![o, x, x, x, o, x, x, x], (5, 7)),
            (vec![x, x, x, o, x, x, x, o], (4, 6)),
            (vec![o, o, o, o, o, x, x, o], (5, 6)),
        ] {
            let (h, e) = errors_of(&orders);
            let est = estimate_order(&h, &e).expect("a run");
            assert_eq!((est.first, est.last), run, "{orders:?}");
            assert!((est.order - 2.0).abs() < 1e-12, "{orders:?}: {}", est.order);
        }
    }

    #[test]
    fn a_step_of_zero_is_outside_the_window() {
        let (mut h, mut e) = errors_of(&[Some(2); 6]);
        h.push(0.0);
        e.push(1e-5);
        let est = estimate_order(&h, &e).expect("a run");
        assert_eq!((est.first, est.last), (0, 5));
        // The successive order of a pair with h = 0 is 0 (or NaN), so only the window keeps
        // it out of a method that does not converge (order 0).
        let e = vec![1e-3; 7];
        let est = estimate_order(&h, &e).expect("a run");
        assert_eq!((est.first, est.last, est.order), (0, 5, 0.0));
    }

    #[test]
    fn deviating_pairs_at_the_fine_end_are_trimmed() {
        // Order 2 throughout, then one pair of order 4 at the fine end: the reference is
        // the median of the three finest successive orders (2, 2, 4), the last pair goes.
        let mut orders = vec![Some(2); 6];
        orders.push(Some(4));
        let (h, mut e) = errors_of(&orders);
        e[6] = e[5] / 16.0;
        let est = estimate_order(&h, &e).expect("a run");
        assert_eq!((est.first, est.last), (0, 5));
        assert!((est.order - 2.0).abs() < 1e-12, "{}", est.order);
        // Of two successive orders the reference is the larger: a run of three points with
        // orders 2 then 4 keeps the order-4 pair alone.
        let h = hs(5);
        let e = [1.0, 1e-3, 2.5e-4, 2.5e-4 / 16.0, 1.0];
        let est = estimate_order(&h, &e).expect("a run");
        assert_eq!((est.first, est.last), (2, 3), "{:?}", est.successive);
        assert!((est.order - 4.0).abs() < 1e-12, "{}", est.order);
    }

    #[test]
    fn no_pair_near_the_reference_gives_none() {
        let (h, e) = errors_of(&[None, Some(2), Some(2), Some(2), None]);
        for tolerance in [f64::NAN, -1.0] {
            let window = OrderWindow {
                tolerance,
                ..OrderWindow::default()
            };
            assert_eq!(estimate_order_with(&h, &e, window), None, "{tolerance}");
        }
        // A step repeated throughout: every successive order is NaN.
        assert_eq!(estimate_order(&[0.5; 4], &[1e-3; 4]), None);
        // A run of exactly two points: the one pair's order.
        let (h, e) = errors_of(&[None, Some(3), Some(3), None]);
        let est = estimate_order(&h, &e).expect("a pair");
        assert_eq!((est.first, est.last), (1, 2));
        assert!((est.order - 3.0).abs() < 1e-12, "{}", est.order);
    }

    #[test]
    fn a_study_samples_the_eighths_that_are_grid_points() {
        use crate::Method;
        use crate::VectorField;
        use crate::problems::{ExactProblem, Logistic};
        let mut problem = Logistic::default();
        // (N, the grid indices of the eighths of the interval that are grid points)
        let cases: [(usize, &[usize]); 3] = [
            (12, &[3, 6, 9, 12]),
            (5, &[5]),
            (16, &[2, 4, 6, 8, 10, 12, 14, 16]),
        ];
        let ns: Vec<usize> = cases.iter().map(|c| c.0).collect();
        let study = convergence_study(&mut problem, Method::Rk4, &ns);
        let layout = problem.layout();
        let mut stepper = Stepper::new(Method::Rk4, layout);
        for (i, (n, ks)) in cases.into_iter().enumerate() {
            let grid = TimeGrid::uniform(problem.t0(), problem.t_end(), n);
            let mut errors = Vec::new();
            for &k in ks {
                let mut y = vec![0.0; layout.ambient_len()];
                let mut exact = y.clone();
                problem.initial_state(&mut y);
                integrate_steps(&mut problem, &mut stepper, &grid, 0, k, &mut y);
                problem.exact(grid.time(k), &mut exact);
                errors.push(problem.error(&y, &exact));
            }
            let worst = errors.iter().copied().fold(0.0, f64::max);
            let bits = |v: f64| v.to_bits();
            assert_eq!(bits(study.hs[i]), bits(grid.h().abs()));
            assert_eq!(bits(study.errors[i]), bits(worst), "N = {n}");
            assert_eq!(
                bits(study.end_errors[i]),
                bits(errors[errors.len() - 1]),
                "N = {n}"
            );
        }
        assert_eq!(study.end_errors.len(), 3);
        assert_eq!(study.ns, ns);
    }
}
