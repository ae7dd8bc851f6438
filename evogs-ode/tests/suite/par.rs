//! `Par::Rayon` gives bitwise the same results as `Par::Seq`: the per-particle block
//! updates are split into fixed-size chunks with no reductions.
#![cfg(feature = "rayon")]

use crate::common;

use common::{CoupledField, CoupledSe3Field, Loss, random_state};
use evogs_math::{Par, Vec3};
use evogs_ode::algebra::{ParticleFrame, RigidRotation};
use evogs_ode::{
    Checkpointing, Method, StageTape, Stepper, TimeGrid, VectorField, discrete_adjoint,
    discrete_adjoint_recorded, integrate_recorded, integrate_trajectory,
};

/// How [`run_with`] integrates and goes back.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Route {
    /// `integrate_trajectory` with a checkpoint every second step, then `discrete_adjoint`.
    Checkpoints,
    /// `integrate_recorded` through a stage tape that keeps every step (the field values of
    /// the stages are copied into the tape in the stages' parallel passes), then
    /// `discrete_adjoint_recorded`.
    Tape,
}

/// Final state and gradients of one forward-and-adjoint run with the given parallelism.
fn run<F: VectorField<f64> + Clone>(proto: &F, m: Method, par: Par) -> [Vec<f64>; 3] {
    run_with(proto, m, par, Route::Checkpoints)
}

/// [`run`] through a stage tape that keeps every step.
fn run_recorded<F: VectorField<f64> + Clone>(proto: &F, m: Method, par: Par) -> [Vec<f64>; 3] {
    run_with(proto, m, par, Route::Tape)
}

/// Final state and gradients of one forward-and-adjoint run along `route`.
fn run_with<F: VectorField<f64> + Clone>(
    proto: &F,
    m: Method,
    par: Par,
    route: Route,
) -> [Vec<f64>; 3] {
    let layout = proto.layout();
    let y0 = random_state(&layout, 62);
    let loss = Loss::new(layout, 63);
    let grid = TimeGrid::uniform(0.0, 0.8, 6);
    let mut field = proto.clone();
    let mut st = Stepper::new(m, layout).with_par(par);
    assert_eq!(st.par(), par, "with_par");
    st.set_par(Par::Seq);
    assert_eq!(st.par(), Par::Seq, "set_par");
    st.set_par(par);
    let mut d_y0 = vec![0.0; layout.tangent_len()];
    let mut d_th = vec![0.0; field.n_params()];
    let traj = match route {
        Route::Checkpoints => {
            let traj =
                integrate_trajectory(&mut field, &mut st, &grid, &y0, Checkpointing::Every(2));
            let d_final = loss.gradient(traj.final_state());
            discrete_adjoint(&mut field, &mut st, &traj, &d_final, &mut d_y0, &mut d_th);
            traj
        }
        Route::Tape => {
            let mut tape = StageTape::new(6 * m.stages());
            let traj = integrate_recorded(&mut field, &mut st, &grid, &y0, &mut tape);
            assert_eq!(tape.kept_stages(), 6 * m.stages(), "{m}: every step kept");
            let d_final = loss.gradient(traj.final_state());
            discrete_adjoint_recorded(
                &mut field, &mut st, &traj, &mut tape, &d_final, &mut d_y0, &mut d_th,
            );
            traj
        }
    };
    [traj.final_state().to_vec(), d_y0, d_th]
}

#[test]
fn rayon_and_sequential_steppers_agree_bitwise() {
    // More particles than one chunk, so the parallel path really splits the work.
    let proto = CoupledField::<f64>::random(1500, 61);
    for m in [Method::Euler, Method::Rk4, Method::Rk38] {
        let [y_seq, dy_seq, dth_seq] = run(&proto, m, Par::Seq);
        let [y_par, dy_par, dth_par] = run(&proto, m, Par::Rayon);
        assert!(y_seq == y_par, "{m}: final states differ");
        assert!(dy_seq == dy_par, "{m}: state gradients differ");
        assert!(dth_seq == dth_par, "{m}: parameter gradients differ");
        let recorded = run_recorded(&proto, m, Par::Rayon);
        assert!(recorded == [y_seq, dy_seq, dth_seq], "{m}: recorded run");
    }
}

#[test]
fn rayon_and_sequential_steppers_agree_bitwise_with_se3_blocks() {
    let proto = CoupledSe3Field::<f64>::random(1500, 71);
    assert_seq_and_rayon_agree(&proto, "SE(3) results");
}

#[test]
fn rayon_and_sequential_steppers_agree_bitwise_on_points() {
    // A Euclidean layout takes the steppers' flat per-chunk loops.
    let frame = ParticleFrame::points(1500);
    assert!(frame.layout().is_euclidean(), "points are Euclidean");
    let proto = RigidRotation::new(frame, Vec3::new(0.3, -0.2, 0.5), Vec3::new(0.1, 0.0, -0.1));
    assert_seq_and_rayon_agree(&proto, "results on points");
}

/// [`run`] and [`run_recorded`] give bitwise the same results with `Par::Seq` and
/// `Par::Rayon` for each method.
fn assert_seq_and_rayon_agree<F: VectorField<f64> + Clone>(proto: &F, what: &str) {
    for m in [Method::Euler, Method::Rk4, Method::Rk38] {
        let seq = run(proto, m, Par::Seq);
        let par = run(proto, m, Par::Rayon);
        assert!(seq == par, "{m}: {what} differ between Seq and Rayon");
        let recorded = run_recorded(proto, m, Par::Rayon);
        assert!(recorded == seq, "{m}: recorded {what} differ");
        assert!(
            run_recorded(proto, m, Par::Seq) == seq,
            "{m}: recorded {what}, Seq"
        );
    }
}
