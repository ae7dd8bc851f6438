//! The work–precision study shared by `benches/adaptive.rs` and
//! `examples/work_precision.rs`: error at the end time against field evaluations, for the
//! adaptive pairs over a range of tolerances and for fixed-step methods over a range of
//! step counts, on Kepler (e = 0.6, one period: the exact end state is the start) and Van der
//! Pol (μ = 1 on [0, 10], reference by Dormand–Prince at rtol = atol = 1e-13).

#![allow(dead_code, reason = "the bench and the example use different parts")]

use evogs_ode::adaptive::{AdaptiveOptions, AdaptiveSolver, Pair};
use evogs_ode::problems::{Kepler, VanDerPol};
use evogs_ode::{Method, Stepper, Tableau, TimeGrid, VectorField, integrate};

/// A test problem of the study.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Problem {
    /// Kepler, e = 0.6, one period.
    Kepler,
    /// Van der Pol, μ = 1, t ∈ [0, 10].
    VanDerPol,
}

impl Problem {
    pub(crate) const ALL: [Self; 2] = [Self::Kepler, Self::VanDerPol];

    pub(crate) fn name(self) -> &'static str {
        match self {
            Self::Kepler => "Kepler e = 0.6 (one period)",
            Self::VanDerPol => "Van der Pol μ = 1, t ∈ [0, 10]",
        }
    }

    pub(crate) fn short(self) -> &'static str {
        match self {
            Self::Kepler => "kepler_e0.6",
            Self::VanDerPol => "van_der_pol_mu1",
        }
    }

    pub(crate) fn field(self) -> Box<dyn VectorField<f64, Record = ()>> {
        match self {
            Self::Kepler => Box::new(Kepler::<f64>::default()),
            Self::VanDerPol => Box::new(VanDerPol { mu: 1.0 }),
        }
    }

    pub(crate) fn span(self) -> (f64, f64) {
        match self {
            Self::Kepler => (0.0, 2.0 * core::f64::consts::PI),
            Self::VanDerPol => (0.0, 10.0),
        }
    }

    pub(crate) fn y0(self) -> Vec<f64> {
        match self {
            Self::Kepler => Kepler::initial_state(0.6).to_vec(),
            Self::VanDerPol => vec![2.0, 0.0],
        }
    }

    /// The state at the end time: exact for Kepler (periodic), a tight Dormand–Prince
    /// solve for Van der Pol.
    pub(crate) fn reference(self) -> Vec<f64> {
        match self {
            Self::Kepler => self.y0(),
            Self::VanDerPol => {
                let (t0, t1) = self.span();
                let mut f = self.field();
                let o = AdaptiveOptions::with_tolerances(1e-13, 1e-13).max_steps(1_000_000);
                let mut s = AdaptiveSolver::new(Pair::Dopri5, f.layout(), o);
                s.solve(&mut f, t0, t1, &self.y0(), &[])
                    .expect("reference solve")
                    .final_state()
                    .to_vec()
            }
        }
    }
}

/// One point of a work–precision diagram.
#[derive(Clone, Debug)]
pub(crate) struct Point {
    /// Method name (`dopri5`, `bs32`, `rk4 (fixed)`, …).
    pub(crate) method: String,
    /// The tolerance (adaptive) or the number of steps (fixed).
    pub(crate) setting: f64,
    /// Field evaluations.
    pub(crate) nfev: usize,
    /// Max-norm error at the end time.
    pub(crate) error: f64,
}

fn max_err(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// An adaptive solve at rtol = atol = `tol`.
pub(crate) fn adaptive(problem: Problem, pair: Pair, tol: f64, reference: &[f64]) -> Point {
    let (t0, t1) = problem.span();
    let mut f = problem.field();
    let o = AdaptiveOptions::with_tolerances(tol, tol).max_steps(1_000_000);
    let mut s = AdaptiveSolver::new(pair, f.layout(), o);
    let sol = s.solve(&mut f, t0, t1, &problem.y0(), &[]).expect("solve");
    Point {
        method: pair.name().to_string(),
        setting: tol,
        nfev: sol.stats().field_evals,
        error: max_err(sol.final_state(), reference),
    }
}

/// `n` uniform steps of a fixed tableau (evaluations: the stages the update uses).
pub(crate) fn fixed(
    problem: Problem,
    name: &str,
    tableau: Tableau,
    n: usize,
    reference: &[f64],
) -> Point {
    let (t0, t1) = problem.span();
    let mut f = problem.field();
    let mut st = Stepper::with_tableau(tableau, f.layout());
    let mut y = problem.y0();
    integrate(&mut f, &mut st, &TimeGrid::uniform(t0, t1, n), &mut y);
    let stages = (0..tableau.stages())
        .rev()
        .find(|&i| !tableau.b(i).is_zero())
        .map_or(1, |i| i + 1);
    Point {
        method: format!("{name} (fixed)"),
        setting: n as f64,
        nfev: n * stages,
        error: max_err(&y, reference),
    }
}

/// The fixed-step methods compared: RK4, Heun (order 2) and Dormand–Prince's 5th-order
/// tableau with fixed steps.
pub(crate) fn fixed_methods() -> Vec<(&'static str, Tableau)> {
    vec![
        ("rk4", Method::Rk4.tableau()),
        ("heun", Method::Heun.tableau()),
        ("dopri5", Pair::Dopri5.tableau()),
    ]
}

/// Every point of the study for one problem.
pub(crate) fn study(problem: Problem) -> Vec<Point> {
    let reference = problem.reference();
    let mut pts = Vec::new();
    for pair in Pair::ALL {
        for k in 2..=13 {
            pts.push(adaptive(problem, pair, 10f64.powi(-k), &reference));
        }
    }
    for (name, t) in fixed_methods() {
        let max_k = if name == "heun" { 20 } else { 15 };
        for k in 4..=max_k {
            pts.push(fixed(problem, name, t, 1 << k, &reference));
        }
    }
    pts
}

/// Field evaluations a method needs for an end error of `target`, interpolated in
/// log–log between its two points that bracket the target (the cheapest such pair); `None`
/// if no two consecutive points bracket it.
pub(crate) fn cost_at(points: &[&Point], target: f64) -> Option<f64> {
    let mut best: Option<f64> = None;
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (lo, hi) = if a.error >= b.error { (b, a) } else { (a, b) };
        if !(lo.error <= target && target <= hi.error) || lo.error <= 0.0 {
            continue;
        }
        let s = (target.ln() - hi.error.ln()) / (lo.error.ln() - hi.error.ln());
        let c = ((hi.nfev as f64).ln() + s * ((lo.nfev as f64).ln() - (hi.nfev as f64).ln())).exp();
        best = Some(best.map_or(c, |x: f64| x.min(c)));
    }
    best
}

/// The method names of a study, in order of first appearance.
pub(crate) fn methods(points: &[Point]) -> Vec<String> {
    let mut v: Vec<String> = Vec::new();
    for p in points {
        if !v.contains(&p.method) {
            v.push(p.method.clone());
        }
    }
    v
}
