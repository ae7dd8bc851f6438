//! Adaptive integration ([`evogs_ode::adaptive`]): orders of both pairs (work–precision
//! slopes of the adaptive solves and fixed-step orders of the propagated and embedded
//! solutions), dense-output accuracy off the grid, rejections on a stiff-ish problem, the
//! statistics, the controller's law and its argument checks, SO(3) blocks and failures as
//! errors. The adjoint of a solve is `adaptive_adjoint.rs`.

use crate::common;

use common::{Counting, CoupledField, random_state};
use evogs_ode::adaptive::{
    AdaptiveError, AdaptiveOptions, AdaptiveSolution, AdaptiveSolver, Pair, StepControl,
    StepSequence,
};
use evogs_ode::fields::LinearField;
use evogs_ode::order::{convergence_study, estimate_order};
use evogs_ode::problems::{
    ConstantRate, CosGrowth, DissipativePair, ExactProblem, Logistic, Lorenz, ProblemK,
    SymmetricTop, VanDerPol, state_distance,
};
use evogs_ode::{Checkpointing, StateLayout, VectorField};

pub(crate) fn opts(tol: f64) -> AdaptiveOptions<f64> {
    AdaptiveOptions::with_tolerances(tol, tol)
}

fn solve<F: VectorField<f64> + ?Sized>(
    f: &mut F,
    pair: Pair,
    o: AdaptiveOptions<f64>,
    t0: f64,
    t1: f64,
    y0: &[f64],
    times: &[f64],
) -> AdaptiveSolution<f64> {
    AdaptiveSolver::new(pair, f.layout(), o)
        .solve(f, t0, t1, y0, times)
        .unwrap_or_else(|e| panic!("{pair}: {e}"))
}

/// Least-squares slope of `log y` against `log x`.
fn slope(x: &[f64], y: &[f64]) -> f64 {
    let lx: Vec<f64> = x.iter().map(|v| v.ln()).collect();
    let ly: Vec<f64> = y.iter().map(|v| v.ln()).collect();
    let (mx, my) = (
        lx.iter().sum::<f64>() / lx.len() as f64,
        ly.iter().sum::<f64>() / ly.len() as f64,
    );
    let sxy: f64 = lx.iter().zip(&ly).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = lx.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

/// Worst error of the outputs against the exact solution.
fn output_error<P: ExactProblem<f64>>(p: &P, sol: &AdaptiveSolution<f64>) -> f64 {
    let layout = p.layout();
    let mut exact = vec![0.0; layout.ambient_len()];
    (0..sol.times().len())
        .map(|j| {
            p.exact(sol.times()[j], &mut exact);
            state_distance(&layout, sol.output(j), &exact)
        })
        .fold(0.0, f64::max)
}

pub(crate) fn times_in(t0: f64, t1: f64, m: usize) -> Vec<f64> {
    // Irregular, off any step grid; t1 last.
    let mut v: Vec<f64> = (1..m)
        .map(|j| t0 + (t1 - t0) * ((j as f64 + 0.31) / m as f64).powf(1.1))
        .collect();
    v.push(t1);
    v
}

#[test]
fn work_precision_slopes_match_the_orders() {
    // Error ∝ tol (tolerance proportionality) and error ∝ nfev^(−p).
    let cases: [(&str, Maker); 3] = [
        (
            "logistic",
            Box::new(|| Box::new(Logistic::<f64>::default())),
        ),
        (
            "cos-growth",
            Box::new(|| Box::new(CosGrowth::<f64>::default())),
        ),
        (
            "symmetric top (SO(3))",
            Box::new(|| Box::new(SymmetricTop::<f64>::default())),
        ),
    ];
    for (name, make) in &cases {
        for pair in Pair::ALL {
            let tols: Vec<f64> = match pair {
                Pair::Dopri5 => (0..7).map(|k| 1e-5 * 10f64.powi(-k)).collect(),
                Pair::Bs32 => (0..6).map(|k| 1e-4 * 10f64.powi(-k)).collect(),
            };
            let (mut errs, mut nfev) = (Vec::new(), Vec::new());
            for &tol in &tols {
                let mut p = make();
                let (t0, t1) = (p.as_exact().t0(), p.as_exact().t_end());
                let mut y0 = vec![0.0; p.as_exact().layout().ambient_len()];
                p.as_exact().initial_state(&mut y0);
                let times = times_in(t0, t1, 12);
                let sol = solve(p.as_exact(), pair, opts(tol), t0, t1, &y0, &times);
                errs.push(output_error_dyn(p.as_exact(), &sol));
                nfev.push(sol.stats().field_evals as f64);
            }
            let s_tol = slope(&tols, &errs);
            let s_work = slope(&nfev, &errs);
            println!(
                "{name:<22} {pair}: error ∝ tol^{s_tol:.2}, error ∝ nfev^{s_work:.2} (order {})",
                pair.order()
            );
            assert!(
                (0.8..=1.2).contains(&s_tol),
                "{name} {pair}: tol slope {s_tol}"
            );
            let p = pair.order() as f64;
            assert!(
                (-s_work - p).abs() < 0.2 * p,
                "{name} {pair}: work slope {s_work}, order {p}"
            );
        }
    }
}

/// Builds a problem of the work–precision test.
type Maker = Box<dyn Fn() -> Box<dyn ExactHolder>>;

/// Object-safe access to an exact problem (the test builds them at run time).
trait ExactHolder {
    fn as_exact(&mut self) -> &mut dyn ExactProblem<f64, Record = ()>;
}
impl<P: ExactProblem<f64, Record = ()> + 'static> ExactHolder for P {
    fn as_exact(&mut self) -> &mut dyn ExactProblem<f64, Record = ()> {
        self
    }
}

fn output_error_dyn(
    p: &mut dyn ExactProblem<f64, Record = ()>,
    sol: &AdaptiveSolution<f64>,
) -> f64 {
    let layout = p.layout();
    let mut exact = vec![0.0; layout.ambient_len()];
    (0..sol.times().len())
        .map(|j| {
            p.exact(sol.times()[j], &mut exact);
            p.error(sol.output(j), &exact)
        })
        .fold(0.0, f64::max)
}

#[test]
fn fixed_step_orders_of_the_propagated_and_embedded_solutions() {
    // Both solutions of both pairs on a non-autonomous scalar problem and on SO(3) (RKMK with
    // the pair's tableau): orders 5 and 4, 3 and 2.
    for pair in Pair::ALL {
        for (tableau, want) in [
            (pair.tableau(), pair.order()),
            (pair.embedded_tableau(), pair.embedded_order()),
        ] {
            let ns: Vec<usize> = (2..10).map(|k| 1 << k).collect();
            for (problem, study) in [
                (
                    "cos-growth",
                    convergence_study(&mut CosGrowth::default(), tableau, &ns),
                ),
                ("problem K", convergence_study(&mut ProblemK, tableau, &ns)),
            ] {
                let est = study
                    .estimate
                    .clone()
                    .unwrap_or_else(|| panic!("{}: no clean range: {:?}", tableau.name(), study));
                // The successive order of the finest pair of steps above the rounding floor
                // (the fitted slope also sees the slow pre-asymptotics of these problems).
                let k = (0..est.successive.len())
                    .rev()
                    .find(|&k| study.errors[k + 1] > 5e-14)
                    .expect("errors above the floor");
                let finest = est.successive[k];
                println!(
                    "{} on {problem}: fitted order {:.2}, finest successive order {finest:.2}",
                    tableau.name(),
                    est.order
                );
                assert!(
                    (finest - want as f64).abs() < 0.15 && (est.order - want as f64).abs() < 0.4,
                    "{} on {problem}: {:.3} / {finest:.3}, want {want}",
                    tableau.name(),
                    est.order
                );
            }
        }
    }
}

#[test]
fn dense_output_has_the_extensions_order_off_the_grid() {
    // Fixed uniform steps, outputs at θ = 0.37 in every step: the error of the dense output
    // (the extension's local error O(h^{q+1}) plus the global error) converges at ≥ the
    // extension's order (4 for Dopri5, 3 for Bs32).
    let mut p = CosGrowth::<f64>::default();
    let (t0, t1) = (p.t0(), p.t_end());
    let mut y0 = [0.0];
    p.initial_state(&mut y0);
    for pair in Pair::ALL {
        let mut solver = AdaptiveSolver::new(pair, p.layout(), opts(1e-6));
        let (mut hs, mut errs) = (Vec::new(), Vec::new());
        for k in 2..10 {
            let n = 1usize << k;
            let h = (t1 - t0) / n as f64;
            let steps = StepSequence::from_sizes(t0, &vec![h; n]);
            let times: Vec<f64> = (0..n).map(|i| t0 + (i as f64 + 0.37) * h).collect();
            let mut out = vec![0.0; n];
            solver
                .replay(&mut p, &steps, &y0, &times, &mut out)
                .unwrap();
            let mut exact = [0.0];
            let e = times
                .iter()
                .zip(&out)
                .map(|(&t, &y)| {
                    p.exact(t, &mut exact);
                    (y - exact[0]).abs()
                })
                .fold(0.0, f64::max);
            hs.push(h);
            errs.push(e);
        }
        let est = estimate_order(&hs, &errs).expect("clean range");
        println!("{pair} dense output at θ = 0.37: order {:.2}", est.order);
        assert!(
            est.order > pair.dense_order() as f64 - 0.2,
            "{pair}: dense order {:.2}",
            est.order
        );
    }
    // Adaptive: outputs at 40 irregular times within a small multiple of the tolerance.
    for pair in Pair::ALL {
        for tol in [1e-5, 1e-8] {
            let times = times_in(t0, t1, 40);
            let sol = solve(&mut p, pair, opts(tol), t0, t1, &y0, &times);
            let e = output_error(&p, &sol);
            assert!(e < 30.0 * tol, "{pair} tol {tol:e}: dense error {e:e}");
        }
    }
}

#[test]
fn steps_do_not_depend_on_output_times_and_grid_outputs_are_the_states() {
    let mut f = Lorenz::<f64>::default();
    let y0 = [1.0, 1.0, 1.0];
    for pair in Pair::ALL {
        let bare = solve(&mut f, pair, opts(1e-7), 0.5, 2.0, &y0, &[]);
        let many = solve(
            &mut f,
            pair,
            opts(1e-7),
            0.5,
            2.0,
            &y0,
            &times_in(0.5, 2.0, 50),
        );
        assert_eq!(bare.steps(), many.steps(), "{pair}: same steps");
        assert_eq!(bare.final_state(), many.final_state(), "{pair}: same end");
        // Outputs requested at every step end are bitwise the step values.
        let steps = bare.steps();
        let ends: Vec<f64> = (0..steps.len())
            .map(|n| {
                let (t, h) = steps.step(n);
                if n + 1 == steps.len() { 2.0 } else { t + h }
            })
            .collect();
        let at_ends = solve(&mut f, pair, opts(1e-7), 0.5, 2.0, &y0, &ends);
        let mut solver = AdaptiveSolver::new(pair, f.layout(), opts(1e-7));
        let mut y = y0.to_vec();
        for n in 0..steps.len() {
            // The state after step n, by replaying n + 1 steps.
            let partial = StepSequence::from_sizes(0.5, &steps.sizes()[..=n]);
            let mut out = vec![0.0; 3];
            let end = if n + 1 == steps.len() { 2.0 } else { ends[n] };
            solver
                .replay(&mut f, &partial, &y0, &[end], &mut out)
                .unwrap();
            y.copy_from_slice(&out);
            assert_eq!(
                at_ends.output(n),
                &y[..],
                "{pair}: output at the end of step {n}"
            );
        }
        assert_eq!(
            at_ends.output(steps.len() - 1),
            bare.final_state(),
            "{pair}: at t1"
        );
    }
}

#[test]
fn replay_reproduces_the_solve_bitwise() {
    let proto = CoupledField::<f64>::random(3, 11);
    let layout = proto.layout();
    let y0 = random_state(&layout, 2);
    for pair in Pair::ALL {
        let mut f = proto.clone();
        let times = times_in(0.2, 1.9, 9);
        let sol = solve(&mut f, pair, opts(1e-6), 0.2, 1.9, &y0, &times);
        let mut out = vec![0.0; sol.outputs().len()];
        AdaptiveSolver::new(pair, layout, opts(1e-6))
            .replay(&mut f, sol.steps(), &y0, &times, &mut out)
            .unwrap();
        assert_eq!(out, sol.outputs(), "{pair}: replay == solve");
        // Unit quaternions stay unit.
        for j in 0..times.len() {
            let o = sol.output(j);
            for p in 0..3 {
                let q = &o[9 * p + 3..9 * p + 7];
                let nq: f64 = q.iter().map(|v| v * v).sum();
                assert!((nq - 1.0).abs() < 1e-14, "{pair}: |q|² = {nq}");
            }
        }
    }
}

#[test]
fn a_stiff_problem_makes_the_controller_reject_steps() {
    // Van der Pol with μ = 30 and the −50 decay of DissipativePair: an explicit pair runs at
    // its stability limit, and the controller keeps probing it (rejections).
    for pair in Pair::ALL {
        let mut vdp = VanDerPol { mu: 30.0 };
        let sol = solve(&mut vdp, pair, opts(1e-6), 0.0, 30.0, &[2.0, 0.0], &[30.0]);
        let st = sol.stats();
        println!("{pair} van der Pol μ = 30: {st:?}");
        assert!(st.rejected >= 10, "{pair}: only {} rejections", st.rejected);
        let mut dp = DissipativePair::default();
        let y0 = DissipativePair::initial_state();
        let sol = solve(&mut dp, pair, opts(1e-6), 0.0, 3.0, &y0, &[3.0]);
        assert!(sol.stats().rejected > 0, "{pair}: dissipative pair");
        // Step sizes stay near the stability boundary |hλ| ≲ 3.3 of the pairs.
        let hmax = sol
            .steps()
            .sizes()
            .iter()
            .skip(5)
            .fold(0.0f64, |a, h| a.max(h.abs()));
        assert!(hmax * 50.0 < 4.0, "{pair}: h = {hmax} beyond stability");
    }
}

/// Each condition of the argument checks refuses on its own, and the edges it allows pass.
#[test]
fn each_invalid_argument_is_refused_alone() {
    let mut f = Logistic::<f64>::default();
    let mut s = AdaptiveSolver::new(Pair::Bs32, f.layout(), opts(1e-6));
    let base = opts(1e-6);
    let with = |f: fn(&mut AdaptiveOptions<f64>)| {
        let mut o = base;
        f(&mut o);
        o
    };
    let refused: [(&str, AdaptiveOptions<f64>); 10] = [
        ("rtol < 0 alone", with(|o| o.rtol = -1e-6)),
        ("atol NaN alone", with(|o| o.atol = f64::NAN)),
        ("h_min < 0", with(|o| o.h_min = -1.0)),
        ("h_min ∞", with(|o| o.h_min = f64::INFINITY)),
        ("h_max = 0", with(|o| o.h_max = Some(0.0))),
        ("h_max NaN", with(|o| o.h_max = Some(f64::NAN))),
        ("h_init = 0", with(|o| o.h_init = Some(0.0))),
        ("h_init ∞", with(|o| o.h_init = Some(f64::INFINITY))),
        // Bs32's error is O(h³): β < 1/(0.75·3) ≈ 0.444 (0.5 would pass for k = 1 or 2).
        ("β ≥ 1/k", with(|o| o.control.beta = 0.5)),
        ("both tolerances 0", with(|o| (o.rtol, o.atol) = (0.0, 0.0))),
    ];
    for (what, o) in refused {
        s.set_options(o);
        let e = s.solve(&mut f, 0.0, 1.0, &[0.5], &[]).err();
        assert!(
            matches!(
                e,
                Some(AdaptiveError::InvalidTolerance | AdaptiveError::InvalidOption(_))
            ),
            "{what}: {e:?}"
        );
    }
    let allowed: [(&str, AdaptiveOptions<f64>); 4] = [
        ("rtol = 0", with(|o| o.rtol = 0.0)),
        ("atol = 0", with(|o| o.atol = 0.0)),
        ("h_max = 1", with(|o| o.h_max = Some(1.0))),
        ("h_init = −0.1", with(|o| o.h_init = Some(-0.1))),
    ];
    for (what, o) in allowed {
        s.set_options(o);
        assert!(s.solve(&mut f, 0.0, 1.0, &[0.5], &[]).is_ok(), "{what}");
    }
    s.set_options(base);
    for (t0, t1) in [(f64::NAN, 1.0), (0.0, f64::INFINITY)] {
        let e = s.solve(&mut f, t0, t1, &[0.5], &[]).err();
        assert!(
            matches!(e, Some(AdaptiveError::NonFinite(_))),
            "{t0} → {t1}: {e:?}"
        );
    }
    // A field of the right dimension on another layout (Euclidean 6 against [SO(3), ℝ³]).
    let top = SymmetricTop::<f64>::default();
    let mut s = AdaptiveSolver::new(Pair::Bs32, top.layout(), base);
    let mut flat = LinearField::new(6, vec![0.0; 36]);
    let e = s.solve(
        &mut flat,
        0.0,
        1.0,
        &[1.0, 0.0, 0.0, 0.0, 0.1, 0.2, 0.3],
        &[],
    );
    assert!(
        matches!(e.err(), Some(AdaptiveError::LayoutMismatch)),
        "layout alone"
    );
}

/// `y' = g(t)`: a scalar field of time alone, without parameters.
struct OfTime(fn(f64) -> f64);

impl VectorField<f64> for OfTime {
    type Record = ();
    fn dim(&self) -> usize {
        1
    }
    fn n_params(&self) -> usize {
        0
    }
    fn eval(&mut self, t: f64, _y: &[f64], dydt: &mut [f64]) {
        dydt[0] = (self.0)(t);
    }
    fn vjp(&mut self, _t: f64, _y: &[f64], _w: &[f64], _d_y: &mut [f64], _d_p: &mut [f64]) {}
}

/// The I controller's law, step by step, where every error it saw is known: on `y' = t²`
/// Bs32's two solutions differ by exactly `h³E` (`E = Σ(bᵢ − b̂ᵢ)cᵢ²`; both are exact for
/// `y' = t`), so with `rtol = 0` the error of a step of size h is `|E|h³/atol`, and the next
/// step must be `h·clamp(0.9·err^(−1/k), 0.2, 10)` with k = 3, the embedded order plus one.
#[test]
fn the_controller_follows_its_law_where_the_error_is_known() {
    let pair = Pair::Bs32;
    let (tab, b_hat) = (pair.tableau(), pair.embedded_weights());
    // eᵢ = bᵢ − b̂ᵢ, exact and rounded once (as the solver holds them), and cᵢ.
    let (w, c): (Vec<f64>, Vec<f64>) = (0..pair.stages())
        .map(|i| ((tab.b(i) - b_hat[i]).to_f64(), tab.c(i).to_f64()))
        .unzip();
    let e: f64 = w.iter().zip(&c).map(|(w, c)| w * c * c).sum();
    assert!((e + 1.0 / 24.0).abs() < 1e-16, "E = {e}");
    let atol = 1e-6;
    let o = AdaptiveOptions {
        rtol: 0.0,
        atol,
        h_init: Some(1e-3),
        control: StepControl::integral(),
        ..opts(1e-6)
    };
    let mut f = OfTime(|t| t * t);
    let mut s = AdaptiveSolver::new(pair, f.layout(), o);
    let sol = s.solve(&mut f, 0.0, 2.0, &[0.0], &[]).expect("solve");
    assert_eq!(sol.stats().rejected, 0, "no rejection");
    let h = sol.steps().sizes();
    assert!(h.len() > 20, "{} steps", h.len());
    // The last step is cut (or stretched) onto t1: compare every step before it.
    for n in 0..h.len() - 2 {
        let err = (e * h[n].powi(3)).abs() / atol;
        let want = h[n] * (0.9 * err.powf(-1.0 / 3.0)).clamp(0.2, 10.0);
        assert!(
            (h[n + 1] - want).abs() <= 1e-8 * want,
            "step {}: {} vs {want}",
            n + 1,
            h[n + 1]
        );
    }
    // An error of exactly 1 is accepted. With h = 1/8 from t = 0 every stage value
    // (cᵢh)² is exact, so the estimate `h·Σ eᵢKᵢ` (eᵢ = bᵢ − b̂ᵢ rounded, summed in stage
    // order as the solver does) is known to the bit; with it as atol and rtol = 0 the
    // error norm is exactly 1.
    let h0 = 0.125;
    let mut acc = 0.0;
    for (w, c) in w.iter().zip(&c) {
        if *w != 0.0 {
            acc += w * (c * h0).powi(2);
        }
    }
    let o = AdaptiveOptions {
        atol: (h0 * acc).abs(),
        h_init: Some(h0),
        ..o
    };
    let mut s = AdaptiveSolver::new(pair, f.layout(), o);
    let sol = s.solve(&mut f, 0.0, 1.0, &[0.0], &[]).expect("solve");
    assert!(
        sol.steps().step(0) == (0.0, h0),
        "err = 1 accepted: {:?}",
        sol.steps().step(0)
    );
    // Backward through zero: the span is |t1 − t0|.
    let mut f = Logistic::<f64>::default();
    let mut s = AdaptiveSolver::new(pair, f.layout(), opts(1e-6));
    assert!(s.solve(&mut f, 1.0, -1.0, &[0.5], &[]).is_ok(), "1 → −1");
}

/// HNW's initial step on `y' = 1 + t + t²`, `y₀ = 1`, where every norm is known: the scale
/// is `sc = atol + rtol·|y₀|`, `d0 = d1 = 1/sc`, so the probe is `h₀ = 0.01`, and
/// `d2 = |f(h₀) − f(0)|/(h₀·sc) = 1.01/sc`; the first step is `(0.01/max(d1, d2))^(1/3)`
/// (Bs32: k = 3), well below `100h₀` and the span, and accepted.
#[test]
fn the_initial_step_is_the_heuristics_where_the_norms_are_known() {
    let (rtol, atol) = (1e-3, 1e-6);
    let o = AdaptiveOptions {
        rtol,
        atol,
        ..opts(1e-6)
    };
    let mut f = OfTime(|t| 1.0 + t + t * t);
    let mut s = AdaptiveSolver::new(Pair::Bs32, f.layout(), o);
    let sol = s.solve(&mut f, 0.0, 1.0, &[1.0], &[]).expect("solve");
    let sc = atol + rtol;
    let (d1, d2) = (1.0 / sc, 1.01 / sc);
    let want = (0.01 / d1.max(d2)).cbrt();
    let (t, h) = sol.steps().step(0);
    assert!(
        t == 0.0 && (h - want).abs() < 1e-12 * want,
        "first step {h}, want {want}"
    );
}

/// A step is too small below `h_min` (a step of exactly `h_min` is taken) and where a tenth
/// of it vanishes against t (`0.1|h| ≤ |t|·ε`).
#[test]
fn steps_too_small_are_refused_at_their_edges() {
    let mut f = Logistic::<f64>::default();
    let mut s = AdaptiveSolver::new(Pair::Bs32, f.layout(), opts(1e-6));
    let with = |h_min: f64, h_init: f64| AdaptiveOptions {
        h_min,
        h_init: Some(h_init),
        ..opts(1e-6)
    };
    s.set_options(with(1e-3, 1e-3));
    assert!(s.solve(&mut f, 0.0, 1.0, &[0.5], &[]).is_ok(), "h = h_min");
    s.set_options(with(1e-3, 0.999e-3));
    let e = s.solve(&mut f, 0.0, 1.0, &[0.5], &[]).err();
    assert!(
        matches!(e, Some(AdaptiveError::StepSizeTooSmall { .. })),
        "{e:?}"
    );
    // At t = 10⁶, |t|·ε ≈ 2.2e-10: a step of 1e-9 is lost in t, one of 1e-8 is not.
    s.set_options(with(0.0, 1e-9));
    let e = s.solve(&mut f, 1e6, 1e6 + 1.0, &[0.5], &[]).err();
    assert!(
        matches!(e, Some(AdaptiveError::StepSizeTooSmall { .. })),
        "{e:?}"
    );
    s.set_options(with(0.0, 1e-8));
    assert!(
        s.solve(&mut f, 1e6, 1e6 + 1.0, &[0.5], &[]).is_ok(),
        "h = 1e-8 at 10⁶"
    );
}

/// `is_empty`, and the direction of a span of zero: forward, so a later time belongs to
/// the last step.
#[test]
fn a_sequence_of_zero_span_runs_forward() {
    assert!(StepSequence::from_sizes(1.0, &[]).is_empty(), "no steps");
    assert!(
        !StepSequence::from_sizes(1.0, &[0.5]).is_empty(),
        "one step"
    );
    let zero = StepSequence::from_sizes(1.0, &[0.0, 0.0]);
    assert_eq!(zero.locate(2.0), Some(1), "a later time");
    assert_eq!(zero.locate(0.0), Some(0), "an earlier time");
}

#[test]
fn statistics_count_every_evaluation() {
    for pair in Pair::ALL {
        for (h_init, start) in [(None, 2), (Some(0.01), 1)] {
            let mut f = Counting::new(VanDerPol { mu: 3.0 });
            let o = AdaptiveOptions {
                h_init,
                ..opts(1e-6)
            };
            let sol = solve(
                &mut f,
                pair,
                o,
                0.0,
                6.0,
                &[2.0, 0.0],
                &times_in(0.0, 6.0, 7),
            );
            let st = sol.stats();
            assert_eq!(st.field_evals, f.evals, "{pair}: counted evaluations");
            assert_eq!(
                st.field_evals,
                start + (pair.stages() - 1) * (st.accepted + st.rejected),
                "{pair}: FSAL accounting"
            );
            assert_eq!(st.accepted, sol.steps().len(), "{pair}: accepted = steps");
            assert!(st.rejected > 0, "{pair}: some rejections at μ = 3");
            let span: f64 = sol.steps().sizes().iter().sum();
            assert!((span - 6.0).abs() < 1e-12, "{pair}: steps cover the span");
        }
    }
}

#[test]
fn rotations_follow_exact_solutions() {
    // The symmetric top (SO(3) × ℝ³, closed form): within a small multiple of tol.
    let top = SymmetricTop::<f64>::default();
    let layout = top.layout();
    let mut y0 = vec![0.0; layout.ambient_len()];
    top.initial_state(&mut y0);
    for pair in Pair::ALL {
        for tol in [1e-5, 1e-8, 1e-10] {
            let mut f = top;
            let times = times_in(0.0, top.t_end(), 25);
            let sol = solve(&mut f, pair, opts(tol), 0.0, top.t_end(), &y0, &times);
            let e = output_error(&top, &sol);
            println!(
                "{pair} symmetric top tol {tol:e}: error {e:.2e}, {:?}",
                sol.stats()
            );
            assert!(e < 50.0 * tol, "{pair} tol {tol:e}: {e:e}");
        }
        // A constant rate is integrated exactly by RKMK: the error estimate vanishes and
        // one step does (after the initial-step probe).
        let mut cr = ConstantRate::<f64>::default();
        let mut q0 = [0.0; 4];
        cr.initial_state(&mut q0);
        let times = times_in(0.0, 3.0, 6);
        let sol = solve(&mut cr, pair, opts(1e-10), 0.0, 3.0, &q0, &times);
        assert!(output_error(&cr, &sol) < 1e-14, "{pair}: constant rate");
        // Steps grow by the largest factor from the probe's first step on.
        assert!(
            sol.steps().len() <= 6,
            "{pair}: {} steps",
            sol.steps().len()
        );
    }
}

#[test]
fn backward_in_time_from_a_nonzero_start() {
    let mut p = CosGrowth::<f64>::default();
    let (ta, tb) = (3.7, 0.4);
    let mut ya = [0.0];
    p.exact(ta, &mut ya);
    let times = times_in(ta, tb, 10);
    for pair in Pair::ALL {
        let sol = solve(&mut p, pair, opts(1e-9), ta, tb, &ya, &times);
        assert!(
            sol.steps().sizes().iter().all(|&h| h < 0.0),
            "{pair}: negative steps"
        );
        let e = output_error(&p, &sol);
        assert!(e < 1e-7, "{pair}: backward error {e:e}");
    }
}

#[test]
fn failures_are_errors_not_panics() {
    /// y' = y²: blows up at t = 1 from y(0) = 1.
    #[derive(Clone, Copy, Debug)]
    struct BlowUp;
    impl VectorField<f64> for BlowUp {
        type Record = ();
        fn dim(&self) -> usize {
            1
        }
        fn n_params(&self) -> usize {
            0
        }
        fn eval(&mut self, _t: f64, y: &[f64], d: &mut [f64]) {
            d[0] = y[0] * y[0];
        }
        fn vjp(&mut self, _t: f64, y: &[f64], w: &[f64], d_y: &mut [f64], _: &mut [f64]) {
            d_y[0] += 2.0 * y[0] * w[0];
        }
    }
    let l = StateLayout::euclidean(1);
    let mut s = AdaptiveSolver::new(Pair::Dopri5, l, opts(1e-8));
    let e = s.solve(&mut BlowUp, 0.0, 2.0, &[1.0], &[]).unwrap_err();
    assert!(
        matches!(e, AdaptiveError::StepSizeTooSmall { t, .. } | AdaptiveError::TooManySteps { t, .. } if (t - 1.0).abs() < 1e-3),
        "{e}"
    );
    s.set_options(opts(1e-8).max_steps(5));
    let e = s.solve(&mut BlowUp, 0.0, 0.9, &[1.0], &[]).unwrap_err();
    assert!(
        matches!(e, AdaptiveError::TooManySteps { max_steps: 5, .. }),
        "{e}"
    );
    s.set_options(AdaptiveOptions {
        h_min: 1e-2,
        ..opts(1e-12)
    });
    let e = s.solve(&mut BlowUp, 0.0, 0.99, &[1.0], &[]).unwrap_err();
    assert!(matches!(e, AdaptiveError::StepSizeTooSmall { .. }), "{e}");
    let mut f = Logistic::<f64>::default();
    let mut s = AdaptiveSolver::new(Pair::Bs32, l, opts(1e-6));
    /// Options, y0, output times and the expected error.
    type Case<'a> = (
        AdaptiveOptions<f64>,
        &'a [f64],
        &'a [f64],
        fn(&AdaptiveError) -> bool,
    );
    let cases: [Case<'_>; 7] = [
        (opts(-1.0), &[0.5], &[], |e| {
            matches!(e, AdaptiveError::InvalidTolerance)
        }),
        (opts(0.0), &[0.5], &[], |e| {
            matches!(e, AdaptiveError::InvalidTolerance)
        }),
        (opts(f64::NAN), &[0.5], &[], |e| {
            matches!(e, AdaptiveError::InvalidTolerance)
        }),
        (opts(1e-6), &[0.5, 1.0], &[], |e| {
            matches!(e, AdaptiveError::LengthMismatch { .. })
        }),
        (opts(1e-6), &[f64::NAN], &[], |e| {
            matches!(e, AdaptiveError::NonFinite(_))
        }),
        (opts(1e-6), &[0.5], &[0.5, 0.2], |e| {
            matches!(e, AdaptiveError::OutputTime { index: 1 })
        }),
        (opts(1e-6), &[0.5], &[3.0], |e| {
            matches!(e, AdaptiveError::OutputTime { index: 0 })
        }),
    ];
    for (o, y0, times, ok) in cases {
        s.set_options(o);
        let e = s.solve(&mut f, 0.0, 2.0, y0, times).unwrap_err();
        assert!(ok(&e), "unexpected {e:?}");
        assert!(!e.to_string().is_empty(), "message");
    }
    s.set_options(AdaptiveOptions {
        checkpointing: Checkpointing::Every(0),
        ..opts(1e-6)
    });
    assert!(matches!(
        s.solve(&mut f, 0.0, 2.0, &[0.5], &[]),
        Err(AdaptiveError::InvalidOption(_))
    ));
    // A field of another layout; an adjoint with wrong lengths or a foreign solution.
    let mut top = SymmetricTop::<f64>::default();
    assert!(matches!(
        s.solve(&mut top, 0.0, 1.0, &[0.5], &[]),
        Err(AdaptiveError::LayoutMismatch)
    ));
    s.set_options(opts(1e-6));
    let sol = s.solve(&mut f, 0.0, 2.0, &[0.5], &[1.0, 2.0]).unwrap();
    let (mut dy, mut dp, mut dt) = ([0.0], vec![0.0; f.n_params()], [0.0; 2]);
    let e = s
        .adjoint(&mut f, &sol, &[1.0], &mut dy, &mut dp, &mut dt)
        .unwrap_err();
    assert!(
        matches!(
            e,
            AdaptiveError::LengthMismatch {
                what: "d_outputs",
                ..
            }
        ),
        "{e}"
    );
    let mut other = AdaptiveSolver::new(Pair::Dopri5, l, opts(1e-6));
    let e = other
        .adjoint(&mut f, &sol, &[1.0, 1.0], &mut dy, &mut dp, &mut dt)
        .unwrap_err();
    assert_eq!(e, AdaptiveError::ForeignSolution, "other pair");
    // t1 = t0: no step, every output is y0, and the adjoint sums the cotangents.
    let sol = s.solve(&mut f, 1.0, 1.0, &[0.5], &[1.0, 1.0]).unwrap();
    assert_eq!(sol.outputs(), &[0.5, 0.5], "no step");
    s.adjoint(&mut f, &sol, &[1.0, 2.0], &mut dy, &mut dp, &mut dt)
        .unwrap();
    assert!((dy[0] - 3.0).abs() < 1e-300, "identity map: {dy:?}");
}
