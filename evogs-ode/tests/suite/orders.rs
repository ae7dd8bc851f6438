//! Measured convergence orders on problems with exact solutions (`docs/integrators.md` §7).

//!
//! Each method must show its nominal order within 0.15 on nonlinear, non-autonomous and
//! rotational problems (a linear problem alone cannot tell a fake RK4 from a real one).

use evogs_math::So3;
use evogs_ode::fields::LinearField;
use evogs_ode::order::{ConvergenceStudy, convergence_study, estimate_order};
use evogs_ode::problems::{
    AsymmetricTop, ConstantRate, ConstantTwist, CosGrowth, ExactProblem, HarmonicOscillator,
    Logistic, ProblemK, PropelledTop, RotatingDecay, ScrewPair, SymmetricTop, state_distance,
};
use evogs_ode::{Method, Rational as R, Stepper, Tableau, TimeGrid, VectorField, integrate};

fn pow2(lo: u32, hi: u32) -> Vec<usize> {
    (lo..=hi).map(|k| 1usize << k).collect()
}

/// Step counts per method: low orders need many more steps to reach small errors.
fn ns_for(order: usize) -> Vec<usize> {
    match order {
        1 => pow2(4, 17),
        2 => pow2(3, 14),
        _ => pow2(2, 11),
    }
}

fn report(s: &ConvergenceStudy) -> f64 {
    let est = s
        .estimate
        .as_ref()
        .unwrap_or_else(|| panic!("{} on {}: no clean range", s.method, s.problem));
    println!(
        "{:>20} {:>9}: order {:.3} over N = {}..{}; successive {:?}",
        s.problem,
        s.method,
        est.order,
        s.ns[est.first],
        s.ns[est.last],
        est.successive
            .iter()
            .map(|p| (p * 100.0).round() / 100.0)
            .collect::<Vec<_>>()
    );
    est.order
}

fn check_orders(problem: &mut dyn ExactProblem<f64, Record = ()>, methods: &[Method]) {
    for &m in methods {
        let s = convergence_study(problem, m, &ns_for(m.order()));
        let p = report(&s);
        let nominal = m.order() as f64;
        assert!(
            (p - nominal).abs() <= 0.15,
            "{} on {}: order {p:.3}, expected {nominal}",
            m,
            s.problem
        );
    }
}

#[test]
fn orders_on_the_logistic_equation() {
    check_orders(&mut Logistic::default(), &Method::ALL);
}

#[test]
fn orders_on_the_non_autonomous_problem() {
    check_orders(&mut CosGrowth::default(), &Method::ALL);
}

#[test]
fn orders_on_the_harmonic_oscillator() {
    check_orders(&mut HarmonicOscillator::default(), &Method::ALL);
}

#[test]
fn orders_on_the_linear_rotating_decay() {
    check_orders(&mut RotatingDecay::default(), &Method::ALL);
}

#[test]
fn lie_orders_on_problem_k() {
    check_orders(&mut ProblemK, &Method::ALL);
}

#[test]
fn rkmk_orders_on_the_symmetric_top() {
    check_orders(&mut SymmetricTop::default(), &Method::ALL);
}

#[test]
fn lie_orders_on_the_se3_screw_pair() {
    check_orders(&mut ScrewPair::default(), &Method::ALL);
}

#[test]
fn rkmk_orders_on_the_propelled_top_on_se3_times_r3() {
    check_orders(&mut PropelledTop::default(), &Method::ALL);
}

/// The fake tableau of `docs/integrators.md` §2: RK4's stability polynomial, but order 2.
fn fake_rk4() -> Tableau {
    let (z, one) = (R::ZERO, R::ONE);
    Tableau::new(
        "fake-rk4",
        &[z, one, z, one],
        &[
            &[],
            &[one],
            &[R::new(-1, 4), R::new(1, 4)],
            &[R::new(-1, 2), R::new(1, 2), one],
        ],
        &[R::new(1, 6), R::new(1, 3), R::new(1, 3), R::new(1, 6)],
    )
    .expect("explicit tableau")
}

#[test]
fn the_fake_rk4_is_order_4_on_a_linear_problem_but_order_2_on_the_logistic_one() {
    let lin = convergence_study(&mut RotatingDecay::default(), fake_rk4(), &ns_for(4));
    let p_lin = report(&lin);
    assert!(
        (p_lin - 4.0).abs() <= 0.15,
        "linear problems only see R(z): {p_lin:.3}"
    );
    let log = convergence_study(&mut Logistic::default(), fake_rk4(), &ns_for(2));
    let p_log = report(&log);
    assert!(
        (p_log - 2.0).abs() <= 0.15,
        "the logistic equation exposes it: {p_log:.3}"
    );
}

#[test]
fn one_step_on_dahlquist_equals_the_stability_polynomial() {
    for m in Method::ALL {
        let t = m.tableau();
        for (lambda, h) in [(-1.7_f64, 0.3_f64), (0.9, 0.25), (-30.0, 0.01), (2.0, -0.4)] {
            let mut f = LinearField::new(1, vec![lambda]);
            let mut st = Stepper::new(m, f.layout());
            let mut y = [1.0];
            st.step(&mut f, 0.3, h, &mut y);
            let want = t.stability_function(h * lambda);
            assert!(
                (y[0] - want).abs() <= 4.0 * f64::EPSILON * want.abs(),
                "{m}: y1 = {} vs R(hλ) = {want}",
                y[0]
            );
        }
        // Imaginary λ (and complex, α ≠ 0): the rotating system's step matrix.
        for alpha in [0.0_f64, -0.3] {
            let mut f = RotatingDecay {
                alpha,
                beta: 2.5,
                ..RotatingDecay::default()
            };
            let h = 0.2_f64;
            let mut st = Stepper::new(m, f.layout());
            let mut y = [0.6, -0.8];
            st.step(&mut f, 0.0, h, &mut y);
            let mm = f.step_matrix(&t, h);
            let want = [
                mm[0][0] * 0.6 - mm[0][1] * 0.8,
                mm[1][0] * 0.6 - mm[1][1] * 0.8,
            ];
            let err = (y[0] - want[0]).abs().max((y[1] - want[1]).abs());
            assert!(err < 4e-16, "{m}: complex R(hλ) off by {err:e}");
        }
    }
}

#[test]
fn lie_methods_are_exact_for_a_constant_world_twist() {
    let mut p = ConstantTwist::<f64>::default();
    let t_end = p.t_end;
    let mut exact = [0.0; 7];
    p.exact(t_end, &mut exact);
    for m in Method::ALL {
        for n in [1, 3, 10, 100] {
            let mut st = Stepper::new(m, p.layout());
            let mut y = [0.0; 7];
            p.initial_state(&mut y);
            integrate(&mut p, &mut st, &TimeGrid::uniform(0.0, t_end, n), &mut y);
            let e = p.error(&y, &exact);
            assert!(e < 1e-13, "{m} N={n}: error {e:e} for a constant twist");
        }
    }
}

#[test]
fn lie_methods_are_exact_for_a_constant_world_rate() {
    let mut p = ConstantRate::<f64>::default();
    let t_end = p.t_end;
    let mut exact = [0.0; 4];
    p.exact(t_end, &mut exact);
    for m in Method::ALL {
        for n in [1, 3, 10, 100] {
            let mut st = Stepper::new(m, p.layout());
            let mut y = [0.0; 4];
            p.initial_state(&mut y);
            integrate(&mut p, &mut st, &TimeGrid::uniform(0.0, t_end, n), &mut y);
            let e = p.error(&y, &exact);
            assert!(
                e < 1e-14,
                "{m} N={n}: rotation error {e:e} for a constant rate"
            );
        }
    }
}

/// Integrating forward then backward with the same N returns to the start with an error
/// that scales like h^p.
#[test]
fn forward_then_backward_returns_within_h_to_the_p() {
    fn round_trip(p: &mut dyn ExactProblem<f64, Record = ()>, m: Method, n: usize) -> f64 {
        let layout = p.layout();
        let mut st = Stepper::new(m, layout);
        let mut y0 = vec![0.0; layout.ambient_len()];
        p.initial_state(&mut y0);
        let mut y = y0.clone();
        let t1 = p.t_end();
        integrate(p, &mut st, &TimeGrid::uniform(0.0, t1, n), &mut y);
        integrate(p, &mut st, &TimeGrid::uniform(t1, 0.0, n), &mut y);
        state_distance(&layout, &y, &y0)
    }
    type Problem = Box<dyn ExactProblem<f64, Record = ()>>;
    let problems: [(&str, Problem); 4] = [
        ("logistic", Box::new(Logistic::default())),
        ("problem K", Box::new(ProblemK)),
        ("symmetric top", Box::new(SymmetricTop::default())),
        ("screw pair", Box::new(ScrewPair::default())),
    ];
    for (name, mut p) in problems {
        for m in Method::ALL {
            let ns = ns_for(m.order());
            let hs: Vec<f64> = ns.iter().map(|&n| 1.0 / n as f64).collect();
            let errs: Vec<f64> = ns.iter().map(|&n| round_trip(p.as_mut(), m, n)).collect();
            let est = estimate_order(&hs, &errs).expect("clean range");
            println!("round trip {name:>13} {m:>9}: order {:.3}", est.order);
            // Locally Φ₋ₕ∘Φₕ(y) − y = C hᵖ⁺¹ + C(−h)ᵖ⁺¹ + O(hᵖ⁺²): the leading terms cancel
            // when p + 1 is odd, so the round trip is order p + 1 for even p, p for odd p.
            let p_m = m.order();
            let want = if p_m % 2 == 0 { p_m + 1 } else { p_m } as f64;
            assert!(
                (est.order - want).abs() <= 0.15,
                "{name} {m}: round-trip error order {:.3}, expected {want}",
                est.order
            );
        }
    }
}

/// The asymmetric top has no elementary closed form: check its invariants. The spatial
/// angular momentum R·I·ω sees attitude errors that energy and |L|² cannot.
#[test]
fn asymmetric_top_invariants_converge_at_the_method_order() {
    let mut top = AsymmetricTop::<f64>::default();
    let t_end = top.t_end;
    let mut y0 = [0.0; 7];
    top.initial_state(&mut y0);
    let (e0, m0, l0) = (
        top.body.energy(&y0),
        top.body.momentum_squared(&y0),
        top.body.spatial_momentum(&y0),
    );
    for m in [Method::Euler, Method::Midpoint, Method::Rk4, Method::Rk38] {
        let ns: Vec<usize> = match m.order() {
            1 => pow2(10, 17),
            2 => pow2(8, 15),
            _ => pow2(7, 12),
        };
        let mut drift_l = Vec::new();
        let mut drift_e = Vec::new();
        for &n in &ns {
            let mut st = Stepper::new(m, top.layout());
            let mut y = y0;
            integrate(&mut top, &mut st, &TimeGrid::uniform(0.0, t_end, n), &mut y);
            drift_l.push((top.body.spatial_momentum(&y) - l0).norm());
            drift_e.push(
                (top.body.energy(&y) - e0)
                    .abs()
                    .max((top.body.momentum_squared(&y) - m0).abs()),
            );
            let q = So3::from_quat(evogs_math::Quat::from_slice(&y));
            assert!(
                (q.quat().norm() - 1.0).abs() < 1e-14,
                "unit quaternion kept"
            );
        }
        let hs: Vec<f64> = ns.iter().map(|&n| 1.0 / n as f64).collect();
        let pl = estimate_order(&hs, &drift_l).expect("clean range").order;
        let pe = estimate_order(&hs, &drift_e).expect("clean range").order;
        println!(
            "asymmetric top {m:>9}: spatial-momentum drift order {pl:.3}, energy/|L|² {pe:.3}"
        );
        assert!(
            (pl - m.order() as f64).abs() <= 0.15,
            "{m}: spatial momentum drift order {pl:.3}"
        );
        assert!(
            pe >= m.order() as f64 - 0.15,
            "{m}: energy drift order {pe:.3}"
        );
    }
}

/// Training runs in f32: the same generic stepper, RKMK4 on Problem K, reaches f32 accuracy.
#[test]
fn the_stepper_runs_in_f32() {
    let mut p = ProblemK;
    let mut st = Stepper::<f32>::new(Method::Rk4, VectorField::<f32>::layout(&p));
    let mut y = [1.0_f32, 0.0, 0.0, 0.0];
    integrate(&mut p, &mut st, &TimeGrid::uniform(0.0, 4.0, 64), &mut y);
    let mut exact = [0.0_f64; 4];
    ExactProblem::<f64>::exact(&p, 4.0, &mut exact);
    let y64 = y.map(f64::from);
    let err = state_distance(&VectorField::<f64>::layout(&p), &y64, &exact);
    assert!(err < 2e-5, "f32 RKMK4 error {err:e}");
    assert!(
        (y64.iter().map(|v| v * v).sum::<f64>() - 1.0).abs() < 1e-6,
        "unit quaternion"
    );
}
