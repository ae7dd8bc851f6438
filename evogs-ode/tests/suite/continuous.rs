//! The continuous adjoint: its failure mode on dissipative dynamics (backsolve), its typed
//! errors, and its O(hᵖ) distance to the exact discrete gradient.

use evogs_math::diff::{GradCheck, central_gradient};
use evogs_ode::fields::Mlp;
use evogs_ode::order::estimate_order;
use evogs_ode::problems::{DissipativePair, ProblemK};
use evogs_ode::{
    AdjointError, Checkpointing, ContinuousVariant, Method, Stepper, TimeGrid, VectorField,
    continuous_adjoint, discrete_adjoint, integrate, integrate_trajectory,
};

fn discrete<F: VectorField<f64>>(
    f: &mut F,
    m: Method,
    grid: &TimeGrid<f64>,
    y0: &[f64],
    c: &[f64],
) -> Vec<f64> {
    let mut st = Stepper::new(m, f.layout());
    let traj = integrate_trajectory(f, &mut st, grid, y0, Checkpointing::StoreAll);
    let mut g = vec![0.0; f.dim()];
    let mut gp = vec![0.0; f.n_params()];
    discrete_adjoint(f, &mut st, &traj, c, &mut g, &mut gp);
    g.extend(gp);
    g
}

fn continuous<F: VectorField<f64>>(
    f: &mut F,
    m: Method,
    grid: &TimeGrid<f64>,
    y0: &[f64],
    c: &[f64],
    v: ContinuousVariant,
) -> (Vec<f64>, Option<f64>) {
    let r = continuous_adjoint(f, m, grid, y0, c, v).expect("Euclidean field");
    let mut g = r.d_y0;
    g.extend(r.d_params);
    (g, r.reconstruction_error)
}

fn max_rel(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() / y.abs().max(1.0))
        .fold(0.0, f64::max)
}

/// docs/integrators.md §7.9: with a −50 decay mode, re-integrating x backward amplifies every
/// error like e^{50}: the backsolve reconstruction of x(0) and its gradients are garbage,
/// the checkpoint variant is O(h⁴)-close to the discrete gradient, and the discrete
/// adjoint matches central differences.
#[test]
fn backsolve_fails_on_dissipative_dynamics_and_the_discrete_adjoint_does_not() {
    let x0 = DissipativePair::<f64>::initial_state();
    let c = DissipativePair::<f64>::loss_weights();
    let theta = DissipativePair::<f64>::default().theta;
    let mut ckpt_errors = Vec::new();
    println!(
        "   N | backsolve |x̃(0) − x0| | backsolve grad err | checkpoint grad err | discrete vs FD"
    );
    for n in [20, 40, 80, 160] {
        let grid = TimeGrid::uniform(0.0, 1.0, n);
        let mut f = DissipativePair::default();
        let exact = discrete(&mut f, Method::Rk4, &grid, &x0, &c);
        // Central differences of the discrete solve.
        let mut x: Vec<f64> = x0.iter().chain(&theta).copied().collect();
        let mut num = vec![0.0; 6];
        central_gradient(
            |v: &[f64]| {
                let mut g = DissipativePair {
                    theta: [v[2], v[3], v[4], v[5]],
                };
                let mut st = Stepper::new(Method::Rk4, g.layout());
                let mut y = [v[0], v[1]];
                integrate(&mut g, &mut st, &grid, &mut y);
                c[0] * y[0] + c[1] * y[1]
            },
            &mut x,
            &mut num,
        );
        let fd = GradCheck::new(1e-9, 1e-7).check(&exact, &num);
        fd.assert_passed("discrete adjoint of the dissipative pair");
        let (back, rec) = continuous(
            &mut f,
            Method::Rk4,
            &grid,
            &x0,
            &c,
            ContinuousVariant::Reintegrate,
        );
        let (ckpt, none) = continuous(
            &mut f,
            Method::Rk4,
            &grid,
            &x0,
            &c,
            ContinuousVariant::Checkpoint,
        );
        let rec = rec.expect("backsolve reports its reconstruction error");
        assert!(
            none.is_none(),
            "checkpoint variant has nothing to reconstruct"
        );
        let (e_back, e_ckpt) = (max_rel(&back, &exact), max_rel(&ckpt, &exact));
        println!(
            "{n:4} | {rec:24.2e} | {e_back:18.2e} | {e_ckpt:19.2e} | {:.1e}",
            fd.max_abs_err
        );
        assert!(
            rec > 1e3,
            "N={n}: backward reconstruction must blow up (got {rec:e})"
        );
        assert!(
            e_back > 1e2,
            "N={n}: backsolve gradient must be garbage (got {e_back:e})"
        );
        ckpt_errors.push(e_ckpt);
    }
    // The checkpoint variant converges to the discrete gradient (at least 8× per halving
    // of h: order ≥ 3; h·50 = 2.5 at N = 20 is at the edge of RK4's stability region).
    for w in ckpt_errors.windows(2) {
        assert!(
            w[1] < w[0] / 8.0,
            "checkpoint variant must converge: {ckpt_errors:?}"
        );
    }
    assert!(
        ckpt_errors[3] < 1e-6,
        "checkpoint variant at N = 160: {:e}",
        ckpt_errors[3]
    );
}

/// Both continuous variants approach the exact discrete gradient at the method's order.
#[test]
fn continuous_adjoints_converge_to_the_discrete_gradient_at_the_method_order() {
    let theta: Vec<f64> = (0..Mlp::<f64>::param_count(3, 8))
        .map(|i| 0.4 * ((i as f64) * 1.37).sin())
        .collect();
    let x0 = [0.3, -0.5, 0.8];
    let c = [1.0, -0.5, 0.25];
    for m in [Method::Midpoint, Method::Rk4] {
        for v in [
            ContinuousVariant::Reintegrate,
            ContinuousVariant::Checkpoint,
        ] {
            let ns: Vec<usize> = (2..9).map(|k| 1 << k).collect();
            let mut hs = Vec::new();
            let mut diffs = Vec::new();
            for &n in &ns {
                let grid = TimeGrid::uniform(0.0, 1.5, n);
                let mut f = Mlp::new(3, 8, theta.clone());
                let exact = discrete(&mut f, m, &grid, &x0, &c);
                let (g, _) = continuous(&mut f, m, &grid, &x0, &c, v);
                hs.push(grid.h());
                diffs.push(max_rel(&g, &exact));
            }
            let est = estimate_order(&hs, &diffs).expect("clean range");
            println!(
                "{m} {v:?}: |continuous − discrete| order {:.3}, at N=256 {:.1e}",
                est.order, diffs[6]
            );
            assert!(
                (est.order - m.order() as f64).abs() < 0.3,
                "{m} {v:?}: difference order {:.3}",
                est.order
            );
        }
    }
}

#[test]
fn continuous_adjoint_reports_typed_errors() {
    let grid = TimeGrid::uniform(0.0, 1.0, 4);
    let e = continuous_adjoint(
        &mut ProblemK,
        Method::Rk4,
        &grid,
        &[1.0, 0.0, 0.0, 0.0],
        &[0.0; 3],
        ContinuousVariant::Checkpoint,
    );
    assert_eq!(
        e.unwrap_err(),
        AdjointError::NotEuclidean,
        "SO(3) layouts are rejected"
    );
    let mut f = DissipativePair::<f64>::default();
    let e = continuous_adjoint(
        &mut f,
        Method::Rk4,
        &grid,
        &[1.0],
        &[1.0, 2.0],
        ContinuousVariant::Reintegrate,
    );
    assert_eq!(
        e.unwrap_err(),
        AdjointError::LengthMismatch {
            what: "y0",
            expected: 2,
            got: 1
        },
        "short y0"
    );
    assert!(
        AdjointError::NotEuclidean.to_string().contains("Euclidean"),
        "Display"
    );
}
