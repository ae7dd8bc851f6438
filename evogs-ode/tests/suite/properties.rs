//! Property tests of the steppers and the adaptive solver on the public strategies
//! (`evogs_ode::strategies`, feature `proptest`): round trips within the method's order,
//! exactness on polynomial-in-t fields, tolerances met on random linear systems, dense
//! output, the step VJP's and the adaptive adjoint's exactness (dot-product test, replayed
//! central differences, checkpointing), statistics, and exact rational arithmetic.

use crate::common;

use common::{
    Counting, CoupledField, CoupledSe3Field, Loss, N_THETA_SE3, dual_tangent, random_state, retract,
};
use evogs_math::Dual;
use evogs_math::diff::{
    GradCheck, central_gradient, central_gradient_with_step, default_step, vjp_dot_test,
};
use evogs_ode::adaptive::{AdaptiveOptions, AdaptiveSolver, Pair, StepSequence};
use evogs_ode::fields::LinearField;
use evogs_ode::problems::{Lorenz, VanDerPol};
use evogs_ode::strategies::{
    euclidean_state, linear_system, log_uniform, method, output_times, pair, state, step_sequence,
};
use evogs_ode::{
    Checkpointing, Method, Rational, StateLayout, Stepper, Tableau, TimeGrid, VectorField,
    integrate,
};
use proptest::prelude::*;

/// `e^{tA}` (row-major n × n) by scaling and squaring of a degree-24 Taylor series.
fn expm(n: usize, a: &[f64], t: f64) -> Vec<f64> {
    let norm = a.iter().map(|v| (v * t).abs()).sum::<f64>();
    let mut s = 0;
    while norm / f64::from(1u32 << s) > 0.25 {
        s += 1;
    }
    let scale = t / f64::from(1u32 << s);
    let mul = |x: &[f64], y: &[f64]| -> Vec<f64> {
        let mut o = vec![0.0; n * n];
        for i in 0..n {
            for k in 0..n {
                for j in 0..n {
                    o[i * n + j] += x[i * n + k] * y[k * n + j];
                }
            }
        }
        o
    };
    let b: Vec<f64> = a.iter().map(|v| v * scale).collect();
    let mut e = vec![0.0; n * n];
    let mut term = vec![0.0; n * n];
    for i in 0..n {
        e[i * n + i] = 1.0;
        term[i * n + i] = 1.0;
    }
    for k in 1..=24 {
        term = mul(&term, &b);
        for v in &mut term {
            *v /= f64::from(k);
        }
        for (x, y) in e.iter_mut().zip(&term) {
            *x += y;
        }
    }
    for _ in 0..s {
        e = mul(&e, &e);
    }
    e
}

fn mat_vec(n: usize, m: &[f64], v: &[f64]) -> Vec<f64> {
    (0..n)
        .map(|i| (0..n).map(|j| m[i * n + j] * v[j]).sum())
        .collect()
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// `y' = Σₖ cₖ tᵏ` (one component per row of coefficients): independent of y.
#[derive(Clone, Debug)]
struct Polynomial {
    coeffs: Vec<Vec<f64>>,
}

impl VectorField<f64> for Polynomial {
    type Record = ();
    fn dim(&self) -> usize {
        self.coeffs.len()
    }
    fn n_params(&self) -> usize {
        0
    }
    fn eval(&mut self, t: f64, _y: &[f64], d: &mut [f64]) {
        for (di, c) in d.iter_mut().zip(&self.coeffs) {
            *di = c.iter().rev().fold(0.0, |acc, &ck| acc * t + ck);
        }
    }
    fn vjp(&mut self, _: f64, _: &[f64], _: &[f64], _: &mut [f64], _: &mut [f64]) {}
}

impl Polynomial {
    /// `∫_{t0}^{t1}` of each component.
    fn integral(&self, t0: f64, t1: f64) -> Vec<f64> {
        self.coeffs
            .iter()
            .map(|c| {
                c.iter()
                    .enumerate()
                    .map(|(k, &ck)| {
                        let p = i32::try_from(k + 1).expect("small degree");
                        ck * (t1.powi(p) - t0.powi(p)) / f64::from(p)
                    })
                    .sum()
            })
            .collect()
    }
}

/// Every fixed-step tableau: the built-in methods and both solutions of both pairs.
fn tableaux() -> Vec<(Tableau, usize)> {
    let mut v: Vec<(Tableau, usize)> = Method::ALL
        .iter()
        .map(|m| (m.tableau(), m.order()))
        .collect();
    for p in Pair::ALL {
        v.push((p.tableau(), p.order()));
        v.push((p.embedded_tableau(), p.embedded_order()));
    }
    v
}

fn tableau() -> impl Strategy<Value = (Tableau, usize)> {
    proptest::sample::select(tableaux())
}

fn opts(tol: f64) -> AdaptiveOptions<f64> {
    AdaptiveOptions::with_tolerances(tol, tol)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// N steps forward then N back return within `2·T·L·(hL)^p·e^{2LT}·|y0|` (L = ‖A‖∞).
    #[test]
    fn forward_then_backward_returns_within_the_order(
        (tab, p) in tableau(),
        a in linear_system(3, 1.0),
        y0 in euclidean_state(3, 1.0),
        t_span in 0.2..1.5f64,
        k in 5u32..8,
    ) {
        let n_steps = 1usize << k;
        let mut f = LinearField::new(3, a.clone());
        let mut st = Stepper::with_tableau(tab, f.layout());
        let mut y = y0.clone();
        integrate(&mut f, &mut st, &TimeGrid::uniform(0.3, 0.3 + t_span, n_steps), &mut y);
        integrate(&mut f, &mut st, &TimeGrid::uniform(0.3 + t_span, 0.3, n_steps), &mut y);
        let l = (0..3).map(|i| (0..3).map(|j| a[i * 3 + j].abs()).sum::<f64>()).fold(0.0, f64::max);
        let h = t_span / n_steps as f64;
        let pi = i32::try_from(p).expect("small order");
        let bound = 2.0 * t_span * l * (h * l).powi(pi) * (2.0 * l * t_span).exp() * norm(&y0) + 1e-13;
        let err = norm(&y.iter().zip(&y0).map(|(a, b)| a - b).collect::<Vec<_>>());
        prop_assert!(err <= bound, "{}: round trip {err:e} > {bound:e}", tab.name());
    }

    /// Every method of order ≥ 2 integrates `y' = a + b t` exactly (to rounding).
    #[test]
    fn linear_in_t_fields_are_integrated_exactly(
        (tab, p) in tableau(),
        c in proptest::collection::vec(proptest::collection::vec(-2.0..2.0f64, 2), 2),
        y0 in euclidean_state(2, 1.0),
        t0 in -1.0..1.0f64,
        span in -2.0..2.0f64,
        n in 1usize..12,
    ) {
        prop_assume!(p >= 2 && span.abs() > 1e-3);
        let mut f = Polynomial { coeffs: c };
        let mut st = Stepper::with_tableau(tab, f.layout());
        let mut y = y0.clone();
        integrate(&mut f, &mut st, &TimeGrid::uniform(t0, t0 + span, n), &mut y);
        let want: Vec<f64> = f.integral(t0, t0 + span).iter().zip(&y0).map(|(a, b)| a + b).collect();
        for (a, b) in y.iter().zip(&want) {
            prop_assert!((a - b).abs() < 1e-13 * (1.0 + b.abs()) * n as f64, "{}: {a} vs {b}", tab.name());
        }
    }

    /// A method of order p is exact for polynomial-in-t fields of degree p − 1 (RK4 for
    /// cubics, Dormand–Prince for quartics, Bogacki–Shampine for quadratics).
    #[test]
    fn order_p_methods_integrate_degree_p_minus_1_polynomials_exactly(
        (tab, p) in tableau(),
        c in proptest::collection::vec(-1.0..1.0f64, 5),
        t0 in -1.0..1.0f64,
        span in 0.1..1.5f64,
        n in 1usize..8,
    ) {
        let mut f = Polynomial { coeffs: vec![c[..p].to_vec()] };
        let mut st = Stepper::with_tableau(tab, f.layout());
        let mut y = [0.5];
        integrate(&mut f, &mut st, &TimeGrid::uniform(t0, t0 + span, n), &mut y);
        let want = 0.5 + f.integral(t0, t0 + span)[0];
        prop_assert!((y[0] - want).abs() < 1e-13, "{} (order {p}): {} vs {want}", tab.name(), y[0]);
    }

    /// Adaptive solves of random linear systems meet the tolerance: every output within
    /// 200·tol·max(1, |y|) of `e^{tA} y0`.
    #[test]
    fn adaptive_solutions_meet_the_tolerance_on_linear_systems(
        pr in pair(),
        a in linear_system(3, 1.0),
        y0 in euclidean_state(3, 2.0),
        tol in log_uniform(-10.0, -4.0),
        times in output_times(0.0, 1.7, 6),
    ) {
        let mut f = LinearField::new(3, a.clone());
        let mut s = AdaptiveSolver::new(pr, f.layout(), opts(tol));
        let sol = s.solve(&mut f, 0.0, 1.7, &y0, &times).expect("solve");
        for (j, &t) in times.iter().enumerate() {
            let exact = mat_vec(3, &expm(3, &a, t), &y0);
            let err = norm(&sol.output(j).iter().zip(&exact).map(|(x, y)| x - y).collect::<Vec<_>>());
            prop_assert!(err <= 200.0 * tol * norm(&exact).max(1.0), "{pr} tol {tol:e} t {t}: {err:e}");
        }
    }

    /// Solving forward then backward adaptively returns within a multiple of the tolerance.
    #[test]
    fn adaptive_forward_then_backward_returns(
        pr in pair(),
        a in linear_system(2, 1.0),
        y0 in euclidean_state(2, 1.0),
        tol in log_uniform(-10.0, -5.0),
    ) {
        let mut f = LinearField::new(2, a);
        let mut s = AdaptiveSolver::new(pr, f.layout(), opts(tol));
        let there = s.solve(&mut f, 0.0, 1.0, &y0, &[]).expect("forward");
        let back = s.solve(&mut f, 1.0, 0.0, there.final_state(), &[]).expect("backward");
        let err = norm(&back.final_state().iter().zip(&y0).map(|(x, y)| x - y).collect::<Vec<_>>());
        let scale = norm(there.final_state()).max(norm(&y0)).max(1.0);
        prop_assert!(err <= 400.0 * tol * scale, "{pr} tol {tol:e}: {err:e}");
    }

    /// Outputs requested exactly at step ends equal the step values.
    #[test]
    fn dense_output_at_step_ends_equals_the_step_values(
        pr in pair(),
        steps in step_sequence(0.2, 6, 0.005, 0.04, false),
        y0 in euclidean_state(3, 1.0),
    ) {
        let mut f = Lorenz::<f64>::default();
        let mut s = AdaptiveSolver::new(pr, f.layout(), opts(1e-6));
        let ends: Vec<f64> = (0..steps.len()).map(|n| { let (t, h) = steps.step(n); t + h }).collect();
        let mut dense = vec![0.0; 3 * ends.len()];
        s.replay(&mut f, &steps, &y0, &ends, &mut dense).expect("replay");
        for n in 0..steps.len() {
            let partial = StepSequence::from_sizes(0.2, &steps.sizes()[..=n]);
            // The state after n + 1 steps: the end of a replay of the first n + 1 steps.
            let mut y = vec![0.0; 3];
            s.replay(&mut f, &partial, &y0, &[ends[n]], &mut y).expect("replay");
            prop_assert_eq!(&dense[3 * n..3 * n + 3], &y[..], "{} step {}", pr, n);
        }
    }

    /// Dense output at θ = 0 is the step's start state.
    #[test]
    fn dense_output_at_a_steps_start_is_its_state(
        pr in pair(),
        steps in step_sequence(-0.5, 4, 0.005, 0.03, true),
        y0 in euclidean_state(3, 1.0),
    ) {
        let mut f = Lorenz::<f64>::default();
        let mut s = AdaptiveSolver::new(pr, f.layout(), opts(1e-6));
        let mut out = vec![0.0; 3];
        s.replay(&mut f, &steps, &y0, &[-0.5], &mut out).expect("replay");
        prop_assert_eq!(&out[..], &y0[..]);
    }

    /// The VJP of one step of any tableau, SO(3) blocks included, against a dual-number JVP.
    #[test]
    fn step_vjp_passes_the_dot_product_test(
        (tab, _p) in tableau(),
        seed in 0u64..1000,
        t in -1.0..1.0f64,
        h in -0.4..0.4f64,
    ) {
        let proto = CoupledField::<f64>::random(2, seed);
        let layout = proto.layout();
        let y0 = random_state(&layout, seed + 1);
        let n = layout.tangent_len();
        let np = proto.theta.len();
        let r = vjp_dot_test(
            |v: &[f64], out: &mut [f64]| {
                let theta = proto.theta.iter().zip(&v[n..]).map(|(&a, &b)| Dual::new(a, b)).collect();
                let mut fd = CoupledField { theta, count: 2 };
                let y0d: Vec<Dual<f64>> = y0.iter().map(|&a| Dual::constant(a)).collect();
                let vd: Vec<Dual<f64>> = v[..n].iter().map(|&b| Dual::new(0.0, b)).collect();
                let mut y = retract(&layout, &y0d, &vd);
                Stepper::with_tableau(tab, layout).step(&mut fd, Dual::constant(t), Dual::constant(h), &mut y);
                dual_tangent(&layout, &y, out);
            },
            |w: &[f64], out: &mut [f64]| {
                let mut f = proto.clone();
                let (l, d_th) = out.split_at_mut(n);
                l.copy_from_slice(w);
                Stepper::with_tableau(tab, layout).step_vjp(&mut f, t, h, &y0, l, d_th);
            },
            n + np,
            n,
            seed,
        );
        prop_assert!(r < 1e-13, "{}: residual {r:e}", tab.name());
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// The adaptive adjoint (y0, θ, output times) against central differences of the
    /// replayed solve, on the Lorenz system with random parameters.
    #[test]
    fn adjoint_matches_replayed_central_differences(
        pr in pair(),
        sigma in 5.0..12.0f64,
        rho in 10.0..30.0f64,
        beta in 1.0..3.0f64,
        y0 in euclidean_state(3, 2.0),
        tol in log_uniform(-8.0, -4.0),
        times in output_times(0.1, 0.9, 4),
        seed in 0u64..100,
    ) {
        let th = [sigma, rho, beta];
        let make = |t: &[f64]| Lorenz { sigma: t[0], rho: t[1], beta: t[2] };
        let mut f = make(&th);
        let loss = Loss::new(f.layout(), seed);
        let mut s = AdaptiveSolver::new(pr, f.layout(), opts(tol));
        let sol = s.solve(&mut f, 0.1, 0.9, &y0, &times).expect("solve");
        let mut d_out = Vec::new();
        for j in 0..times.len() {
            d_out.extend(loss.gradient(sol.output(j)));
        }
        let (mut d_y0, mut d_th, mut d_t) = (vec![0.0; 3], vec![0.0; 3], vec![0.0; times.len()]);
        s.adjoint(&mut f, &sol, &d_out, &mut d_y0, &mut d_th, &mut d_t).expect("adjoint");
        let mut analytic = d_y0;
        analytic.extend(d_th);
        analytic.extend(d_t);
        let mut x = y0.clone();
        x.extend(th);
        x.extend(&times);
        // The replayed solve over 0.8 time units of a chaotic system bends enough that the
        // O(h²) error of one central difference can reach 2e-6 relative (seen at σ = 11,
        // ρ = 24): Richardson's combination of the steps h and h/2 cancels that term.
        let mut replayed = |v: &[f64]| -> f64 {
            let mut g = make(&v[3..6]);
            let mut out = vec![0.0; 3 * times.len()];
            s.replay(&mut g, sol.steps(), &v[..3], &v[6..], &mut out).expect("replay");
            out.chunks_exact(3).map(|o| loss.value(o)).sum()
        };
        let (mut num, mut half) = (vec![0.0; x.len()], vec![0.0; x.len()]);
        central_gradient(&mut replayed, &mut x, &mut num);
        central_gradient_with_step(&mut replayed, &mut x, |xi| default_step(xi) / 2.0, &mut half);
        for (n, h) in num.iter_mut().zip(&half) {
            *n = (4.0 * h - *n) / 3.0;
        }
        let rep = GradCheck::new(1e-6, 1e-6).check(&analytic, &num);
        prop_assert!(rep.passed(), "{pr} tol {tol:e}: {rep:?}");
    }

    /// On SE(3) × ℝ⁵ (a coupled field with an SE(3) block per particle): the adaptive
    /// adjoint with respect to the initial state (left-perturbation tangents) and θ against
    /// central differences of the replayed solve.
    #[test]
    fn se3_adjoint_matches_replayed_central_differences(
        pr in pair(),
        tol in log_uniform(-8.0, -5.0),
        seed in 0u64..1000,
    ) {
        let proto = CoupledSe3Field::<f64>::random(2, seed);
        let layout = proto.layout();
        let y0 = random_state(&layout, seed + 5);
        let loss = Loss::new(layout, seed + 6);
        let times = [0.3, 0.8];
        let mut f = proto.clone();
        let mut s = AdaptiveSolver::new(pr, layout, opts(tol));
        let sol = s.solve(&mut f, 0.0, 0.8, &y0, &times).expect("solve");
        let mut d_out = Vec::new();
        for j in 0..times.len() {
            d_out.extend(loss.gradient(sol.output(j)));
        }
        let n = layout.tangent_len();
        let (mut d_y0, mut d_th, mut d_t) = (vec![0.0; n], vec![0.0; N_THETA_SE3], vec![0.0; 2]);
        s.adjoint(&mut f, &sol, &d_out, &mut d_y0, &mut d_th, &mut d_t).expect("adjoint");
        let mut analytic = d_y0;
        analytic.extend(d_th);
        let mut x = vec![0.0; n];
        x.extend(&proto.theta);
        let mut num = vec![0.0; x.len()];
        let len = layout.ambient_len();
        central_gradient(
            |v: &[f64]| {
                let mut g = CoupledSe3Field { theta: v[n..].to_vec(), count: 2 };
                let y = retract(&layout, &y0, &v[..n]);
                let mut out = vec![0.0; 2 * len];
                s.replay(&mut g, sol.steps(), &y, &times, &mut out).expect("replay");
                out.chunks_exact(len).map(|o| loss.value(o)).sum()
            },
            &mut x,
            &mut num,
        );
        let rep = GradCheck::new(1e-6, 1e-6).check(&analytic, &num);
        prop_assert!(rep.passed(), "{pr} tol {tol:e}: {rep:?}");
    }

    /// Store-all and every-k checkpointing give bitwise identical gradients (SO(3) blocks).
    #[test]
    fn checkpointing_is_bitwise_identical(
        pr in pair(),
        k in 1usize..9,
        seed in 0u64..1000,
        tol in log_uniform(-8.0, -5.0),
    ) {
        let proto = CoupledField::<f64>::random(2, seed);
        let layout = proto.layout();
        let y0 = random_state(&layout, seed ^ 7);
        let loss = Loss::new(layout, seed ^ 9);
        let times = [0.4, 1.1, 1.5];
        let grad = |policy| {
            let mut f = proto.clone();
            let mut s = AdaptiveSolver::new(pr, layout, opts(tol).checkpointing(policy));
            let sol = s.solve(&mut f, 0.0, 1.5, &y0, &times).expect("solve");
            let mut d_out = Vec::new();
            for j in 0..times.len() {
                d_out.extend(loss.gradient(sol.output(j)));
            }
            let (mut a, mut b, mut c) = (vec![0.0; layout.tangent_len()], vec![0.0; f.n_params()], vec![0.0; 3]);
            s.adjoint(&mut f, &sol, &d_out, &mut a, &mut b, &mut c).expect("adjoint");
            (a, b, c)
        };
        prop_assert!(grad(Checkpointing::StoreAll) == grad(Checkpointing::Every(k)), "{pr} every {k}");
    }

    /// The replay of a solve's steps reproduces its outputs bitwise, and rotations stay unit
    /// quaternions.
    #[test]
    fn replay_reproduces_the_solve_and_rotations_stay_unit(
        pr in pair(),
        seed in 0u64..1000,
        tol in log_uniform(-9.0, -4.0),
        times in output_times(1.0, -0.5, 5),
    ) {
        let proto = CoupledField::<f64>::random(2, seed);
        let layout = proto.layout();
        let y0 = random_state(&layout, seed + 3);
        let mut f = proto.clone();
        let mut s = AdaptiveSolver::new(pr, layout, opts(tol));
        let sol = s.solve(&mut f, 1.0, -0.5, &y0, &times).expect("solve");
        let mut out = vec![0.0; sol.outputs().len()];
        s.replay(&mut f, sol.steps(), &y0, &times, &mut out).expect("replay");
        prop_assert!(out == sol.outputs(), "{pr}: replay differs");
        for j in 0..times.len() {
            for p in 0..2 {
                let q = &sol.output(j)[9 * p + 3..9 * p + 7];
                prop_assert!((q.iter().map(|v| v * v).sum::<f64>() - 1.0).abs() < 1e-14);
            }
        }
    }

    /// The steps do not depend on the output times.
    #[test]
    fn steps_do_not_depend_on_output_times(
        pr in pair(),
        mu in 0.3..4.0f64,
        y0 in euclidean_state(2, 2.0),
        tol in log_uniform(-9.0, -4.0),
        times in output_times(0.0, 5.0, 7),
    ) {
        let mut f = VanDerPol { mu };
        let mut s = AdaptiveSolver::new(pr, f.layout(), opts(tol));
        let a = s.solve(&mut f, 0.0, 5.0, &y0, &[]).expect("solve");
        let b = s.solve(&mut f, 0.0, 5.0, &y0, &times).expect("solve");
        prop_assert_eq!(a.steps(), b.steps());
        prop_assert_eq!(a.stats(), b.stats());
    }

    /// Field evaluations: counted = reported = start + (s − 1)·(accepted + rejected); the
    /// steps cover the span.
    #[test]
    fn statistics_are_consistent(
        pr in pair(),
        mu in 0.3..8.0f64,
        y0 in euclidean_state(2, 2.0),
        tol in log_uniform(-9.0, -3.0),
        t1 in 0.1..6.0f64,
    ) {
        // (Backward in time, Van der Pol's limit cycle repels: solutions blow up.)
        let mut f = Counting::new(VanDerPol { mu });
        let mut s = AdaptiveSolver::new(pr, f.layout(), opts(tol));
        let sol = s.solve(&mut f, 0.0, t1, &y0, &[t1]).expect("solve");
        let st = sol.stats();
        prop_assert_eq!(st.field_evals, f.evals);
        prop_assert_eq!(st.field_evals, 2 + (pr.stages() - 1) * (st.accepted + st.rejected));
        prop_assert_eq!(st.accepted, sol.steps().len());
        let span: f64 = sol.steps().sizes().iter().sum();
        prop_assert!((span - t1).abs() < 1e-12 * t1.abs().max(1.0));
        prop_assert_eq!(sol.output(0), sol.final_state());
    }

    /// Rational arithmetic is exact: field axioms hold with equality.
    #[test]
    fn rational_arithmetic_is_exact(
        a in (-1000i64..1000, 1i64..1000),
        b in (-1000i64..1000, 1i64..1000),
        c in (-1000i64..1000, 1i64..1000),
    ) {
        let (a, b, c) = (Rational::new(a.0, a.1), Rational::new(b.0, b.1), Rational::new(c.0, c.1));
        prop_assert_eq!(a + b, b + a);
        prop_assert_eq!((a + b) + c, a + (b + c));
        prop_assert_eq!(a * (b + c), a * b + a * c);
        prop_assert_eq!((a - b) + b, a);
        prop_assert!(((a * b).to_f64() - a.to_f64() * b.to_f64()).abs() <= 1e-12 * (1.0 + (a.to_f64() * b.to_f64()).abs()));
    }

    /// Any state of a random particle layout integrates with the pairs on the same core:
    /// adaptive SO(3) × ℝ³ × … solves end on unit quaternions and the replay agrees.
    #[test]
    fn random_layout_states_are_handled(
        pr in pair(),
        y0 in state(CoupledField::<f64>::layout_for(3), 1.5),
        tol in log_uniform(-8.0, -4.0),
    ) {
        let mut f = CoupledField::<f64>::random(3, 5);
        let layout: StateLayout = f.layout();
        let mut s = AdaptiveSolver::new(pr, layout, opts(tol));
        let sol = s.solve(&mut f, 0.0, 1.0, &y0, &[0.5, 1.0]).expect("solve");
        for p in 0..3 {
            let q = &sol.final_state()[9 * p + 3..9 * p + 7];
            prop_assert!((q.iter().map(|v| v * v).sum::<f64>() - 1.0).abs() < 1e-14);
        }
        prop_assert_eq!(sol.output(1), sol.final_state());
    }
}

#[test]
fn the_strategies_cover_every_method() {
    // `method()` is part of the public strategies; make sure it yields built-in methods.
    use proptest::strategy::ValueTree;
    use proptest::test_runner::TestRunner;
    let mut runner = TestRunner::deterministic();
    for _ in 0..20 {
        let m = method().new_tree(&mut runner).expect("tree").current();
        assert!(Method::ALL.contains(&m), "{m}");
    }
}
