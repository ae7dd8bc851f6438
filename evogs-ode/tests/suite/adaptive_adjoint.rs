//! The exact discrete adjoint of an adaptive solve ([`AdaptiveSolver::adjoint`]): against
//! central differences of the replayed solve (steps held fixed), a dual-number JVP (the
//! dot-product test), across checkpointing policies (bitwise), and its documented cost.

use crate::adaptive::{opts, times_in};
use crate::common;

use common::{Counting, CoupledField, Loss, N_THETA, dual_tangent, random_state, retract};
use evogs_math::Dual;
use evogs_math::diff::{GradCheck, central_gradient, vjp_dot_test};
use evogs_ode::adaptive::{AdaptiveOptions, AdaptiveSolution, AdaptiveSolver, Pair, StepSequence};
use evogs_ode::problems::{Lorenz, VanDerPol};
use evogs_ode::{Checkpointing, VectorField};

/// The adjoint's cost as documented: a reverse pass over the stages the update uses for a
/// step without outputs (6 of Dopri5's 7: its last, FSAL stage has weight 0), over all of
/// them for a step with outputs; the replay's forward pass likewise.
#[test]
fn the_adjoint_passes_over_the_stages_each_step_needs() {
    let mut f = Counting::new(VanDerPol { mu: 1.5 });
    let mut solver = AdaptiveSolver::new(Pair::Dopri5, f.layout(), opts(1e-6));
    let times = [0.7, 3.0];
    let sol = solver
        .solve(&mut f, 0.0, 3.0, &[2.0, 0.0], &times)
        .expect("solve");
    let n = sol.steps().len();
    let with_outputs = 1 + usize::from(sol.steps().locate(0.7) != Some(n - 1));
    assert!(n > 4 && with_outputs == 2, "{n} steps");
    let (mut d_y0, mut d_mu, mut d_t) = ([0.0; 2], [0.0], [0.0; 2]);
    f.vjps = 0;
    solver
        .adjoint(
            &mut f,
            &sol,
            &[1.0, 0.5, -0.3, 0.2],
            &mut d_y0,
            &mut d_mu,
            &mut d_t,
        )
        .expect("adjoint");
    let passes = 6 * (n - with_outputs) + 7 * with_outputs;
    assert_eq!(f.vjps, passes, "{n} steps");
    // The replay likewise evaluates the stages each step needs.
    let mut outputs = [0.0; 4];
    f.evals = 0;
    solver
        .replay(&mut f, sol.steps(), &[2.0, 0.0], &times, &mut outputs)
        .expect("replay");
    assert_eq!(f.evals, passes, "replay");
}

/// `[∂L/∂y0 (tangent), ∂L/∂θ, ∂L/∂τ]` by the adaptive adjoint, with `L = Σⱼ loss(y(τⱼ))`.
fn adaptive_gradient<F: VectorField<f64>>(
    solver: &mut AdaptiveSolver<f64>,
    f: &mut F,
    sol: &AdaptiveSolution<f64>,
    loss: &Loss,
) -> Vec<f64> {
    let m = sol.times().len();
    let n = f.dim();
    let mut d_out = Vec::with_capacity(m * n);
    for j in 0..m {
        d_out.extend(loss.gradient(sol.output(j)));
    }
    let mut d_y0 = vec![0.0; n];
    let mut d_th = vec![0.0; f.n_params()];
    let mut d_t = vec![0.0; m];
    solver
        .adjoint(f, sol, &d_out, &mut d_y0, &mut d_th, &mut d_t)
        .expect("adjoint");
    d_y0.extend(d_th);
    d_y0.extend(d_t);
    d_y0
}

/// Central differences of the replayed solve in `[δy0, θ, τ]`.
fn replay_gradient<F: VectorField<f64>>(
    pair: Pair,
    make: impl Fn(&[f64]) -> F,
    theta: &[f64],
    sol: &AdaptiveSolution<f64>,
    y0: &[f64],
    loss: &Loss,
) -> Vec<f64> {
    let f0 = make(theta);
    let layout = f0.layout();
    let (n, np, m) = (layout.tangent_len(), theta.len(), sol.times().len());
    let mut x = vec![0.0; n];
    x.extend_from_slice(theta);
    x.extend_from_slice(sol.times());
    let mut num = vec![0.0; x.len()];
    let mut solver = AdaptiveSolver::new(pair, layout, opts(1e-6));
    let len = layout.ambient_len();
    central_gradient(
        |v: &[f64]| {
            let mut f = make(&v[n..n + np]);
            let mut out = vec![0.0; m * len];
            solver
                .replay(
                    &mut f,
                    sol.steps(),
                    &retract(&layout, y0, &v[..n]),
                    &v[n + np..],
                    &mut out,
                )
                .expect("replay");
            out.chunks_exact(len).map(|o| loss.value(o)).sum()
        },
        &mut x,
        &mut num,
    );
    num
}

#[test]
fn adjoint_matches_central_differences_of_the_replayed_solve() {
    // Euclidean (Lorenz, θ = (σ, ρ, β), from t0 = 0.3) and SO(3) blocks (the coupled particle
    // field, backward in time too); output times inside steps and at t1.
    for pair in Pair::ALL {
        let th = [10.0, 28.0, 8.0 / 3.0];
        let make = |t: &[f64]| Lorenz {
            sigma: t[0],
            rho: t[1],
            beta: t[2],
        };
        let mut f = make(&th);
        let y0 = [1.0, 1.2, 0.9];
        let loss = Loss::new(f.layout(), 9);
        let times = times_in(0.3, 1.1, 6);
        let mut solver = AdaptiveSolver::new(pair, f.layout(), opts(1e-6));
        let sol = solver.solve(&mut f, 0.3, 1.1, &y0, &times).unwrap();
        let a = adaptive_gradient(&mut solver, &mut f, &sol, &loss);
        let num = replay_gradient(pair, make, &th, &sol, &y0, &loss);
        GradCheck::new(1e-7, 1e-6)
            .check(&a, &num)
            .assert_passed(&format!("{pair} Lorenz"));

        let proto = CoupledField::<f64>::random(2, 4);
        let layout = proto.layout();
        let y0 = random_state(&layout, 8);
        let loss = Loss::new(layout, 6);
        for (t0, t1) in [(0.1, 1.6), (1.2, -0.4)] {
            let mut f = proto.clone();
            let times = times_in(t0, t1, 5);
            let mut solver = AdaptiveSolver::new(pair, layout, opts(1e-5));
            let sol = solver.solve(&mut f, t0, t1, &y0, &times).unwrap();
            assert!(sol.steps().len() >= 4, "{pair}: several steps");
            let a = adaptive_gradient(&mut solver, &mut f, &sol, &loss);
            let make = |t: &[f64]| CoupledField {
                theta: t.to_vec(),
                count: 2,
            };
            let num = replay_gradient(pair, make, &proto.theta, &sol, &y0, &loss);
            GradCheck::new(1e-8, 1e-6)
                .check(&a, &num)
                .assert_passed(&format!("{pair} SO(3) particles [{t0}, {t1}]"));
        }
    }
}

#[test]
fn adjoint_passes_the_dot_product_test_against_dual_numbers() {
    // JVP: the replay in dual numbers (exact); VJP: the adjoint. Inputs [δy0, θ, τ], outputs
    // every output state (tangent).
    let proto = CoupledField::<f64>::random(2, 21);
    let layout = proto.layout();
    let y0 = random_state(&layout, 13);
    let n = layout.tangent_len();
    for pair in Pair::ALL {
        let mut f = proto.clone();
        let times = times_in(0.0, 1.4, 4);
        let m = times.len();
        let mut solver = AdaptiveSolver::new(pair, layout, opts(1e-6));
        let sol = solver.solve(&mut f, 0.0, 1.4, &y0, &times).unwrap();
        let r = vjp_dot_test(
            |v: &[f64], out: &mut [f64]| {
                let theta = proto
                    .theta
                    .iter()
                    .zip(&v[n..n + N_THETA])
                    .map(|(&a, &b)| Dual::new(a, b))
                    .collect();
                let mut fd = CoupledField { theta, count: 2 };
                let y0d: Vec<Dual<f64>> = y0.iter().map(|&a| Dual::constant(a)).collect();
                let vd: Vec<Dual<f64>> = v[..n].iter().map(|&b| Dual::new(0.0, b)).collect();
                let y0d = retract(&layout, &y0d, &vd);
                let td: Vec<Dual<f64>> = times
                    .iter()
                    .zip(&v[n + N_THETA..])
                    .map(|(&a, &b)| Dual::new(a, b))
                    .collect();
                let sizes: Vec<Dual<f64>> = sol
                    .steps()
                    .sizes()
                    .iter()
                    .map(|&h| Dual::constant(h))
                    .collect();
                let steps = StepSequence::from_sizes(Dual::constant(0.0), &sizes);
                let len = layout.ambient_len();
                let mut outd = vec![Dual::constant(0.0); m * len];
                AdaptiveSolver::new(pair, layout, AdaptiveOptions::default())
                    .replay(&mut fd, &steps, &y0d, &td, &mut outd)
                    .expect("dual replay");
                for j in 0..m {
                    dual_tangent(
                        &layout,
                        &outd[j * len..(j + 1) * len],
                        &mut out[j * n..(j + 1) * n],
                    );
                }
            },
            |w: &[f64], out: &mut [f64]| {
                let mut f = proto.clone();
                let (d_y0, rest) = out.split_at_mut(n);
                let (d_th, d_t) = rest.split_at_mut(N_THETA);
                solver
                    .adjoint(&mut f, &sol, w, d_y0, d_th, d_t)
                    .expect("adjoint");
            },
            n + N_THETA + m,
            m * n,
            5,
        );
        println!("{pair}: dot-product residual {r:.1e}");
        assert!(r < 1e-13, "{pair}: dot-product residual {r:e}");
    }
}

#[test]
fn checkpointing_policies_give_bitwise_identical_gradients() {
    let proto = CoupledField::<f64>::random(2, 17);
    let layout = proto.layout();
    let y0 = random_state(&layout, 19);
    let loss = Loss::new(layout, 23);
    for pair in Pair::ALL {
        let times = times_in(0.0, 2.5, 7);
        let mut reference: Option<Vec<f64>> = None;
        for policy in [
            Checkpointing::StoreAll,
            Checkpointing::Every(1),
            Checkpointing::Every(3),
            Checkpointing::Every(7),
            Checkpointing::Every(1000),
        ] {
            let mut f = proto.clone();
            let mut solver = AdaptiveSolver::new(pair, layout, opts(1e-7).checkpointing(policy));
            let sol = solver.solve(&mut f, 0.0, 2.5, &y0, &times).unwrap();
            let g = adaptive_gradient(&mut solver, &mut f, &sol, &loss);
            match &reference {
                None => reference = Some(g),
                Some(r) => assert!(r == &g, "{pair} {policy:?}: not bitwise identical"),
            }
            let stored = sol.stored_states();
            let n = sol.steps().len();
            assert_eq!(
                stored,
                n.div_ceil(policy.interval()) + 1,
                "{pair} {policy:?}: stored states"
            );
            // `state(k)` holds every k-th start, the final state at n, nothing else.
            let k = policy.interval();
            for i in 0..n + 2 * k + 2 {
                let held = i == n || (i < n && i % k == 0);
                assert_eq!(
                    sol.state(i).is_some(),
                    held,
                    "{pair} {policy:?}: state({i})"
                );
            }
        }
    }
}
