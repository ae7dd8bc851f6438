//! `evogs check-order`: the measured convergence order of every stepper on every public test
//! problem of `evogs_ode::problems` (`docs/integrators.md` §7), with the error table over the step
//! sequence, the successive orders and the fitted order over its clean range
//! ([`evogs_ode::order::estimate_order`]).
//!
//! Errors are the largest state distance to the exact solution at eight sample times
//! ([`convergence_study`]). The asymmetric top has no closed form: its error is the drift of
//! the spatial angular momentum `R·I·ω` (a conserved quantity that sees attitude errors),
//! which converges at the method's order. A constant world rate (SO(3)) or twist (SE(3)) is
//! integrated exactly by every exp-based (RKMK) method, so its errors sit at rounding and
//! have no clean range: the verdict there is "exact" (every error below the accumulated
//! rounding bound [`exact_tol`]`(N) = 4·N·ε`).
//!
//! On SE(3) ([`ScrewPair`]: a state-dependent, time-varying world twist; [`PropelledTop`]:
//! SE(3) × ℝ³) the expected orders are the tableau's: Lie–Euler 1, RKMK midpoint and Heun 2,
//! RKMK4 and the 3/8 rule 4.
//!
//! Verdicts: `|fitted − nominal| ≤ ORDER_TOL` ([`ORDER_TOL`] = 0.15). In the printed
//! tables `order` is the successive order `ln(e_{k−1}/e_k)/ln(h_{k−1}/h_k)` and `*` marks
//! the clean range the fit uses.

use core::fmt;
use evogs_ode::order::{ConvergenceStudy, convergence_study, estimate_order, successive_orders};
use evogs_ode::problems::{
    AsymmetricTop, ConstantRate, ConstantTwist, CosGrowth, ExactProblem, HarmonicOscillator,
    Logistic, ProblemK, PropelledTop, RotatingDecay, ScrewPair, SymmetricTop,
};
use evogs_ode::{Method, Stepper, TimeGrid, VectorField, integrate};

/// Largest allowed distance of the fitted order from the nominal one.
pub const ORDER_TOL: f64 = 0.15;
/// Rounding allowed per step (in units of ε) for a problem a method integrates exactly:
/// the error after N steps must stay below `EXACT_ULPS_PER_STEP·N·ε` (each step rounds an
/// exponential and a quaternion product; the worst case accumulates linearly).
pub const EXACT_ULPS_PER_STEP: f64 = 4.0;

/// The rounding bound for `n` steps (see [`EXACT_ULPS_PER_STEP`]).
#[must_use]
pub fn exact_tol(n: usize) -> f64 {
    let n = n as f64;
    EXACT_ULPS_PER_STEP * n * f64::EPSILON
}

/// The problems, by name (as `--problem` takes them).
pub const PROBLEMS: [&str; 11] = [
    "logistic",
    "cos-growth",
    "harmonic-oscillator",
    "rotating-decay",
    "so3-constant-rate",
    "problem-k",
    "symmetric-top",
    "asymmetric-top",
    "se3-constant-twist",
    "se3-screw-pair",
    "se3-propelled-top",
];

/// The problems that every exp-based method integrates exactly (verdict "exact").
const EXACT: [&str; 2] = ["so3-constant-rate", "se3-constant-twist"];

/// What a study should show.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Expect {
    /// The method's nominal order.
    Order(usize),
    /// Exact to rounding.
    Exact,
}

/// One stepper on one problem.
#[derive(Clone, Debug)]
pub struct OrderResult {
    /// The measured errors and the fit.
    pub study: ConvergenceStudy,
    /// What it should show.
    pub expect: Expect,
    /// Whether it does.
    pub passed: bool,
}

/// `--problem` named no known problem.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown problem `{0}` (known: {problems})", problems = PROBLEMS.join(", "))]
pub struct UnknownProblem(pub String);

fn pow2(lo: u32, hi: u32) -> Vec<usize> {
    (lo..=hi).map(|k| 1_usize << k).collect()
}

/// Step counts for a method of `order`: low orders need many more steps to reach the range
/// where the error is asymptotic but above rounding.
#[must_use]
pub fn steps_for(order: usize) -> Vec<usize> {
    match order {
        1 => pow2(4, 17),
        2 => pow2(3, 14),
        _ => pow2(2, 11),
    }
}

/// Spatial-momentum drift of the asymmetric top, as a study.
fn asymmetric_top(method: Method) -> ConvergenceStudy {
    let mut top = AsymmetricTop::<f64>::default();
    let mut y0 = [0.0; 7];
    top.initial_state(&mut y0);
    let l0 = top.body.spatial_momentum(&y0);
    let ns = match method.order() {
        1 => pow2(10, 17),
        2 => pow2(8, 15),
        _ => pow2(7, 12),
    };
    let mut hs = Vec::new();
    let mut errors = Vec::new();
    for &n in &ns {
        let grid = TimeGrid::uniform(0.0, top.t_end, n);
        let mut st = Stepper::new(method, top.layout());
        let mut y = y0;
        integrate(&mut top, &mut st, &grid, &mut y);
        hs.push(grid.h().abs());
        errors.push((top.body.spatial_momentum(&y) - l0).norm());
    }
    ConvergenceStudy {
        method: method.name(),
        problem: "asymmetric-top",
        estimate: estimate_order(&hs, &errors),
        ns,
        hs,
        end_errors: errors.clone(),
        errors,
    }
}

fn study(problem: &str, method: Method) -> Option<ConvergenceStudy> {
    let ns = steps_for(method.order());
    let mut p: Box<dyn ExactProblem<f64, Record = ()>> = match problem {
        "logistic" => Box::new(Logistic::default()),
        "cos-growth" => Box::new(CosGrowth::default()),
        "harmonic-oscillator" => Box::new(HarmonicOscillator::default()),
        "rotating-decay" => Box::new(RotatingDecay::default()),
        "so3-constant-rate" => Box::new(ConstantRate::default()),
        "problem-k" => Box::new(ProblemK),
        "symmetric-top" => Box::new(SymmetricTop::default()),
        "asymmetric-top" => return Some(asymmetric_top(method)),
        "se3-constant-twist" => Box::new(ConstantTwist::default()),
        "se3-screw-pair" => Box::new(ScrewPair::default()),
        "se3-propelled-top" => Box::new(PropelledTop::default()),
        _ => return None,
    };
    Some(convergence_study(p.as_mut(), method, &ns))
}

/// Runs the studies for the selected steppers and problems (all if `None`).
///
/// # Errors
/// [`UnknownProblem`] if `problem` is not one of [`PROBLEMS`].
pub fn check_order(
    stepper: Option<Method>,
    problem: Option<&str>,
) -> Result<Vec<OrderResult>, UnknownProblem> {
    if let Some(p) = problem
        && !PROBLEMS.contains(&p)
    {
        return Err(UnknownProblem(p.to_string()));
    }
    let mut out = Vec::new();
    for name in PROBLEMS.iter().filter(|n| problem.is_none_or(|p| p == **n)) {
        for m in Method::ALL
            .iter()
            .filter(|m| stepper.is_none_or(|s| s == **m))
        {
            let Some(study) = study(name, *m) else {
                continue;
            };
            let expect = if EXACT.contains(name) {
                Expect::Exact
            } else {
                Expect::Order(m.order())
            };
            let passed = match expect {
                Expect::Exact => study
                    .ns
                    .iter()
                    .zip(&study.errors)
                    .all(|(&n, &e)| e <= exact_tol(n)),
                Expect::Order(p) => study
                    .estimate
                    .as_ref()
                    .is_some_and(|e| (e.order - p as f64).abs() <= ORDER_TOL),
            };
            out.push(OrderResult {
                study,
                expect,
                passed,
            });
        }
    }
    Ok(out)
}

impl fmt::Display for OrderResult {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.study;
        let verdict = if self.passed { "pass" } else { "FAIL" };
        let fit = match (&s.estimate, self.expect) {
            (_, Expect::Exact) => format!(
                "exact to rounding (max error/(N·ε) = {:.2}, bound {EXACT_ULPS_PER_STEP})",
                s.ns.iter()
                    .zip(&s.errors)
                    .map(|(&n, &e)| e / exact_tol(n) * EXACT_ULPS_PER_STEP)
                    .fold(0.0_f64, f64::max)
            ),
            (Some(e), Expect::Order(p)) => format!(
                "fitted order {:.3} over N = {}..{} (nominal {p}, tolerance {ORDER_TOL})",
                e.order, s.ns[e.first], s.ns[e.last]
            ),
            (None, Expect::Order(p)) => format!("no clean range (nominal {p})"),
        };
        writeln!(f, "{} / {}: {fit}  {verdict}", s.problem, s.method)?;
        writeln!(
            f,
            "  {:>7}  {:>10}  {:>10}  {:>8}",
            "N", "h", "error", "order"
        )?;
        let successive = successive_orders(&s.hs, &s.errors);
        for (k, (&n, (&h, &e))) in s.ns.iter().zip(s.hs.iter().zip(&s.errors)).enumerate() {
            let p = match k.checked_sub(1).and_then(|j| successive.get(j)) {
                Some(p) if p.is_finite() => format!("{p:.3}"),
                _ => "-".to_string(),
            };
            let mark = match &s.estimate {
                Some(est) if (est.first..=est.last).contains(&k) => " *",
                _ => "",
            };
            writeln!(f, "  {n:>7}  {h:>10.3e}  {e:>10.3e}  {p:>8}{mark}")?;
        }
        Ok(())
    }
}
