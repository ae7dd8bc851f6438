//! The discrete adjoint is the exact gradient of the discrete map: checked against central
//! differences of the discrete solve (f64, relative 1e-7) for every method including the
//! Lie ones (SO(3) and SE(3) initial states perturbed as Exp(δ)·R and Exp(δ)·T), against a
//! dual-number JVP by the dot-product test, against the exact discrete gradient of a linear
//! problem, and checkpointing policies against each other (bitwise).

use crate::common;

use common::{CoupledField, CoupledSe3Field, Loss, N_THETA, random_state, retract};
use evogs_math::diff::{GradCheck, central_gradient, vjp_dot_test};
use evogs_math::{Dual, Quat, Vec3};
use evogs_ode::problems::{PropelledTop, RotatingDecay, SymmetricTop};
use evogs_ode::{
    Block, Checkpointing, Method, StateLayout, Stepper, TimeGrid, Trajectory, VectorField,
    discrete_adjoint, discrete_adjoint_observed, integrate, integrate_steps, integrate_trajectory,
};

/// Final state of the discrete solve.
fn solve<F: VectorField<f64>>(
    field: &mut F,
    m: Method,
    grid: &TimeGrid<f64>,
    y0: &[f64],
) -> Vec<f64> {
    let mut st = Stepper::new(m, field.layout());
    let mut y = y0.to_vec();
    integrate(field, &mut st, grid, &mut y);
    y
}

/// Analytic `[∂L/∂y0 (tangent), ∂L/∂θ]` by the discrete adjoint.
fn adjoint_gradient<F: VectorField<f64>>(
    field: &mut F,
    m: Method,
    grid: &TimeGrid<f64>,
    y0: &[f64],
    loss: &Loss,
    policy: Checkpointing,
) -> Vec<f64> {
    let mut st = Stepper::new(m, field.layout());
    let traj = integrate_trajectory(field, &mut st, grid, y0, policy);
    let d_final = loss.gradient(traj.final_state());
    let mut d_y0 = vec![0.0; field.dim()];
    let mut d_th = vec![0.0; field.n_params()];
    discrete_adjoint(field, &mut st, &traj, &d_final, &mut d_y0, &mut d_th);
    d_y0.extend(d_th);
    d_y0
}

/// Central differences of `L(solve(θ, y0 ⊕ δ))` in `[δ, θ]` at `δ = 0`.
fn numeric_gradient<F: VectorField<f64>>(
    make: impl Fn(&[f64]) -> F,
    theta: &[f64],
    layout: &StateLayout,
    m: Method,
    grid: &TimeGrid<f64>,
    y0: &[f64],
    loss: &Loss,
) -> Vec<f64> {
    let n = layout.tangent_len();
    let mut x = vec![0.0; n];
    x.extend_from_slice(theta);
    let mut num = vec![0.0; x.len()];
    central_gradient(
        |v: &[f64]| {
            let mut f = make(&v[n..]);
            loss.value(&solve(&mut f, m, grid, &retract(layout, y0, &v[..n])))
        },
        &mut x,
        &mut num,
    );
    num
}

fn grids() -> [(&'static str, TimeGrid<f64>); 3] {
    [
        ("forward", TimeGrid::uniform(0.0, 1.3, 7)),
        ("backward", TimeGrid::uniform(1.3, 0.0, 7)),
        (
            "shortened last step",
            TimeGrid::with_max_step(0.2, 1.5, 0.3),
        ),
    ]
}

/// The discrete adjoint of `make(theta)` from `y0` against central differences, for every
/// method on every grid; returns the worst absolute error.
fn check_against_central_differences<F: VectorField<f64>>(
    what: &str,
    theta: &[f64],
    make: impl Fn(&[f64]) -> F,
    y0: &[f64],
    loss_seed: u64,
    policy: Checkpointing,
) -> f64 {
    let layout = make(theta).layout();
    let loss = Loss::new(layout, loss_seed);
    let mut worst: f64 = 0.0;
    for m in Method::ALL {
        for (grid_name, grid) in grids() {
            let mut field = make(theta);
            let analytic = adjoint_gradient(&mut field, m, &grid, y0, &loss, policy);
            let numeric = numeric_gradient(&make, theta, &layout, m, &grid, y0, &loss);
            let rep = GradCheck::new(1e-9, 1e-7).check(&analytic, &numeric);
            rep.assert_passed(&format!("{what}, {m}, {grid_name}"));
            worst = worst.max(rep.max_abs_err);
        }
    }
    worst
}

#[test]
fn discrete_adjoint_matches_central_differences_with_so3_blocks() {
    let proto = CoupledField::<f64>::random(2, 7);
    let make = |th: &[f64]| CoupledField {
        theta: th.to_vec(),
        count: 2,
    };
    let y0 = random_state(&proto.layout(), 3);
    let worst = check_against_central_differences(
        "coupled SO(3) field",
        &proto.theta,
        make,
        &y0,
        5,
        Checkpointing::StoreAll,
    );
    println!("coupled SO(3) field: worst |analytic − central difference| = {worst:.2e}");
}

#[test]
fn discrete_adjoint_matches_central_differences_with_se3_blocks() {
    let proto = CoupledSe3Field::<f64>::random(2, 17);
    let make = |th: &[f64]| CoupledSe3Field {
        theta: th.to_vec(),
        count: 2,
    };
    let y0 = random_state(&proto.layout(), 13);
    let worst = check_against_central_differences(
        "coupled SE(3) field",
        &proto.theta,
        make,
        &y0,
        15,
        Checkpointing::StoreAll,
    );
    println!("coupled SE(3) field: worst |analytic − central difference| = {worst:.2e}");
}

#[test]
fn discrete_adjoint_matches_central_differences_on_the_propelled_top() {
    let top = PropelledTop::<f64>::default();
    let mut y0 = [0.0; 10];
    evogs_ode::problems::ExactProblem::initial_state(&top, &mut y0);
    let make = |th: &[f64]| {
        let mut t = top;
        t.top.body.inertia = Vec3::from_slice(th);
        t.speed = th[3];
        t
    };
    // An asymmetric body.
    let theta = [1.0, 1.7, 2.4, 0.6];
    check_against_central_differences(
        "propelled top",
        &theta,
        make,
        &y0,
        12,
        Checkpointing::sqrt(7),
    );
}

#[test]
fn discrete_adjoint_matches_central_differences_on_the_rigid_body() {
    let top = SymmetricTop::<f64>::default();
    let mut y0 = [0.0; 7];
    evogs_ode::problems::ExactProblem::initial_state(&top, &mut y0);
    let make = |th: &[f64]| {
        let mut t = top;
        t.body.inertia = Vec3::from_slice(th);
        t
    };
    // An asymmetric body.
    let theta = [1.0, 1.7, 2.4];
    check_against_central_differences("rigid body", &theta, make, &y0, 11, Checkpointing::sqrt(7));
}

#[test]
fn checkpointing_policies_give_bitwise_identical_gradients() {
    let proto = CoupledField::<f64>::random(3, 21);
    let layout = proto.layout();
    let y0 = random_state(&layout, 8);
    let loss = Loss::new(layout, 9);
    let grid = TimeGrid::with_max_step(0.0, 2.0, 0.15); // 14 steps, the last shortened
    assert_eq!(grid.n_steps(), 14, "grid");
    for m in [Method::Euler, Method::Rk4, Method::Rk38] {
        let mut field = proto.clone();
        let reference = adjoint_gradient(&mut field, m, &grid, &y0, &loss, Checkpointing::StoreAll);
        for k in [1, 2, 3, 5, 7, 13, 14, 40] {
            let g = adjoint_gradient(&mut field, m, &grid, &y0, &loss, Checkpointing::Every(k));
            assert!(g == reference, "{m}: Every({k}) differs from StoreAll");
        }
        let g = adjoint_gradient(&mut field, m, &grid, &y0, &loss, Checkpointing::sqrt(14));
        assert!(
            g == reference,
            "{m}: √N checkpointing differs from StoreAll"
        );
    }
    // Memory: √N checkpoints instead of N + 1 states.
    let mut field = proto;
    let mut st = Stepper::new(Method::Rk4, layout);
    let all = integrate_trajectory(&mut field, &mut st, &grid, &y0, Checkpointing::StoreAll);
    let few = integrate_trajectory(&mut field, &mut st, &grid, &y0, Checkpointing::sqrt(14));
    assert_eq!(all.stored_states(), 15, "store-all keeps N + 1 states");
    assert_eq!(
        few.stored_states(),
        5,
        "every 4th: 0, 4, 8, 12 and the final state"
    );
    assert!(
        all.final_state() == few.final_state(),
        "same forward solution"
    );
    assert!(
        few.state(3).is_none() && few.state(8).is_some(),
        "stored indices"
    );
}

/// Forward-mode derivative of the whole discrete map, in tangent coordinates, from the same
/// generic stepper run on dual numbers: `v = [δ (tangent), θ̇]`, the field built by `make`
/// from dual parameters.
fn dual_jvp_of_solve<F: VectorField<Dual<f64>>>(
    m: Method,
    grid: &TimeGrid<f64>,
    layout: StateLayout,
    theta: &[f64],
    make: impl Fn(Vec<Dual<f64>>) -> F,
    y0: &[f64],
    v: &[f64],
    out: &mut [f64],
) {
    let n = layout.tangent_len();
    let theta: Vec<Dual<f64>> = theta
        .iter()
        .zip(&v[n..])
        .map(|(&a, &b)| Dual::new(a, b))
        .collect();
    let mut field = make(theta);
    let y0d: Vec<Dual<f64>> = y0.iter().map(|&a| Dual::constant(a)).collect();
    let vd: Vec<Dual<f64>> = v[..n].iter().map(|&b| Dual::new(0.0, b)).collect();
    let mut y = retract(&layout, &y0d, &vd);
    let gd = TimeGrid::uniform(
        Dual::constant(grid.t0()),
        Dual::constant(grid.t1()),
        grid.n_steps(),
    );
    let mut st = Stepper::new(m, layout);
    integrate(&mut field, &mut st, &gd, &mut y);
    // Dual parts → tangent: Euclidean as is; SO(3): dq = ½(0, ε)⊗q ⇒ ε = 2 vec(dq ⊗ q*);
    // SE(3): the same ε_φ, and dt = ε_ρ + ε_φ × t ⇒ ε_ρ = dt − ε_φ × t.
    let (pa, pt) = (layout.particle_ambient_len(), layout.particle_tangent_len());
    let re = |a: &[Dual<f64>]| -> Vec<f64> { a.iter().map(|d| d.re).collect() };
    let eps = |a: &[Dual<f64>]| -> Vec<f64> { a.iter().map(|d| d.eps).collect() };
    for p in 0..layout.count() {
        for sp in layout.spans() {
            let (o, ot) = (p * pa + sp.ambient, p * pt + sp.tangent);
            match sp.block {
                Block::Euclidean(k) => {
                    for e in 0..k {
                        out[ot + e] = y[o + e].eps;
                    }
                }
                Block::So3 | Block::Se3 => {
                    let q = Quat::from_slice(&re(&y[o..o + 4]));
                    let dq = Quat::from_slice(&eps(&y[o..o + 4]));
                    let e_phi = dq.mul_quat(q.conj()).vec() * 2.0;
                    if sp.block == Block::So3 {
                        e_phi.write_to(&mut out[ot..]);
                    } else {
                        let t = Vec3::from_slice(&re(&y[o + 4..o + 7]));
                        let dt = Vec3::from_slice(&eps(&y[o + 4..o + 7]));
                        (dt - e_phi.cross(t)).write_to(&mut out[ot..]);
                        e_phi.write_to(&mut out[ot + 3..]);
                    }
                }
            }
        }
    }
}

/// The dot-product test of the discrete adjoint against [`dual_jvp_of_solve`] for every
/// method, forward and backward in time.
fn check_dot_products<F, FD>(
    what: &str,
    layout: StateLayout,
    theta: &[f64],
    make: impl Fn(&[f64]) -> F,
    make_dual: impl Fn(Vec<Dual<f64>>) -> FD,
    y0: &[f64],
) where
    F: VectorField<f64>,
    FD: VectorField<Dual<f64>>,
{
    let n = layout.tangent_len();
    for m in Method::ALL {
        for (dir, grid) in [
            ("forward", TimeGrid::uniform(0.0, 0.9, 5)),
            ("backward", TimeGrid::uniform(0.9, -0.3, 4)),
        ] {
            let r = vjp_dot_test(
                |v: &[f64], out: &mut [f64]| {
                    dual_jvp_of_solve(m, &grid, layout, theta, &make_dual, y0, v, out);
                },
                |w: &[f64], out: &mut [f64]| {
                    let mut field = make(theta);
                    let mut st = Stepper::new(m, layout);
                    let traj = integrate_trajectory(
                        &mut field,
                        &mut st,
                        &grid,
                        y0,
                        Checkpointing::StoreAll,
                    );
                    let (d_y0, d_th) = out.split_at_mut(n);
                    discrete_adjoint(&mut field, &mut st, &traj, w, d_y0, d_th);
                },
                n + theta.len(),
                n,
                17,
            );
            println!("{what}, {m} {dir}: dot-product residual {r:.1e}");
            assert!(r < 1e-13, "{what}, {m} {dir}: dot-product residual {r:e}");
        }
    }
}

#[test]
fn discrete_adjoint_passes_the_dot_product_test_against_dual_numbers() {
    let proto = CoupledField::<f64>::random(2, 31);
    let count = proto.count;
    check_dot_products(
        "coupled SO(3) field",
        proto.layout(),
        &proto.theta,
        |th| CoupledField {
            theta: th.to_vec(),
            count,
        },
        |theta| CoupledField { theta, count },
        &random_state(&proto.layout(), 32),
    );
}

#[test]
fn discrete_adjoint_passes_the_dot_product_test_with_se3_blocks() {
    let proto = CoupledSe3Field::<f64>::random(2, 41);
    let count = proto.count;
    check_dot_products(
        "coupled SE(3) field",
        proto.layout(),
        &proto.theta,
        |th| CoupledSe3Field {
            theta: th.to_vec(),
            count,
        },
        |theta| CoupledSe3Field { theta, count },
        &random_state(&proto.layout(), 42),
    );
}

#[test]
fn discrete_adjoint_equals_the_exact_discrete_gradient_of_a_linear_map() {
    let mut p = RotatingDecay::<f64>::default();
    let c = [0.7, -1.3];
    for m in Method::ALL {
        for (t0, t1, n) in [
            (0.0, 10.0, 1),
            (0.0, 10.0, 37),
            (10.0, 0.0, 200),
            (0.0, 3.0, 1000),
        ] {
            let grid = TimeGrid::uniform(t0, t1, n);
            let mut st = Stepper::new(m, p.layout());
            let traj =
                integrate_trajectory(&mut p, &mut st, &grid, &[1.0, 0.0], Checkpointing::sqrt(n));
            let (mut d_y0, mut d_th) = ([0.0; 2], [0.0; 2]);
            discrete_adjoint(&mut p, &mut st, &traj, &c, &mut d_y0, &mut d_th);
            let want = p.discrete_gradient(&m.tableau(), grid.h(), n, c);
            let scale = want[0].abs().max(want[1].abs());
            let err = (d_y0[0] - want[0]).abs().max((d_y0[1] - want[1]).abs()) / scale;
            assert!(err < 1e-12, "{m} N={n} ({t0}→{t1}): relative error {err:e}");
        }
    }
}

#[test]
fn intermediate_observations_enter_the_reverse_sweep() {
    // L = L_N(y_N) + L_k(y_k) with k = 3 of 8 steps.
    let proto = CoupledField::<f64>::random(1, 41);
    let layout = proto.layout();
    let y0 = random_state(&layout, 42);
    let (loss_n, loss_k) = (Loss::new(layout, 43), Loss::new(layout, 44));
    let grid = TimeGrid::uniform(0.0, 1.0, 8);
    let k_obs = 3;
    let total = |theta: &[f64], y0: &[f64]| {
        let mut f = CoupledField {
            theta: theta.to_vec(),
            count: 1,
        };
        let mut st = Stepper::new(Method::Rk4, layout);
        let mut y = y0.to_vec();
        integrate_steps(&mut f, &mut st, &grid, 0, k_obs, &mut y);
        let lk = loss_k.value(&y);
        integrate_steps(&mut f, &mut st, &grid, k_obs, 8, &mut y);
        lk + loss_n.value(&y)
    };
    let mut field = proto.clone();
    let mut st = Stepper::new(Method::Rk4, layout);
    let traj: Trajectory<f64> =
        integrate_trajectory(&mut field, &mut st, &grid, &y0, Checkpointing::Every(3));
    let yk = traj.state(k_obs).expect("stored").to_vec();
    let (mut d_y0, mut d_th) = (vec![0.0; layout.tangent_len()], vec![0.0; N_THETA]);
    discrete_adjoint_observed(
        &mut field,
        &mut st,
        &traj,
        &loss_n.gradient(traj.final_state()),
        &mut d_y0,
        &mut d_th,
        |k, lambda| {
            if k == k_obs {
                for (l, g) in lambda.iter_mut().zip(loss_k.gradient(&yk)) {
                    *l += g;
                }
            }
        },
    );
    let n = layout.tangent_len();
    let mut x = vec![0.0; n];
    x.extend_from_slice(&proto.theta);
    let mut num = vec![0.0; x.len()];
    central_gradient(
        |v: &[f64]| total(&v[n..], &retract(&layout, &y0, &v[..n])),
        &mut x,
        &mut num,
    );
    d_y0.extend(d_th);
    GradCheck::new(1e-9, 1e-7)
        .check(&d_y0, &num)
        .assert_passed("observation at step 3");
}

#[test]
fn restart_from_a_checkpoint_reproduces_the_trajectory() {
    let mut field = CoupledField::<f64>::random(2, 51);
    let layout = field.layout();
    let y0 = random_state(&layout, 52);
    let grid = TimeGrid::uniform(0.0, 2.0, 16);
    let mut st = Stepper::new(Method::Rk4, layout);
    let traj = integrate_trajectory(&mut field, &mut st, &grid, &y0, Checkpointing::Every(4));
    for k in [0, 4, 8, 12] {
        let mut y = traj.state(k).expect("checkpoint").to_vec();
        integrate_steps(&mut field, &mut st, &grid, k, 16, &mut y);
        assert!(
            y == traj.final_state(),
            "restart at step {k} is bitwise the same"
        );
        // A waypoint-style restart: a new grid from (t_k, y_k).
        let mut y = traj.state(k).expect("checkpoint").to_vec();
        integrate(
            &mut field,
            &mut st,
            &TimeGrid::uniform(grid.time(k), 2.0, 16 - k),
            &mut y,
        );
        let d = evogs_ode::problems::state_distance(&layout, &y, traj.final_state());
        assert!(d < 1e-14, "new grid from t_{k}: {d:e}");
    }
}
