//! `Par::Rayon` gives bitwise the same results as `Par::Seq`: the per-particle block
//! updates are split into fixed-size chunks with no reductions.
#![cfg(feature = "rayon")]

mod common;

use common::{CoupledField, Loss, random_state};
use evogs_math::Par;
use evogs_ode::{
    Checkpointing, Method, Stepper, TimeGrid, VectorField, discrete_adjoint, integrate_trajectory,
};

#[test]
fn rayon_and_sequential_steppers_agree_bitwise() {
    // More particles than one chunk, so the parallel path really splits the work.
    let count = 1500;
    let proto = CoupledField::<f64>::random(count, 61);
    let layout = proto.layout();
    let y0 = random_state(&layout, 62);
    let loss = Loss::new(layout, 63);
    let grid = TimeGrid::uniform(0.0, 0.8, 6);
    for m in [Method::Euler, Method::Rk4, Method::Rk38] {
        let mut results = Vec::new();
        for par in [Par::Seq, Par::Rayon] {
            let mut field = proto.clone();
            let mut st = Stepper::new(m, layout).with_par(par);
            let traj =
                integrate_trajectory(&mut field, &mut st, &grid, &y0, Checkpointing::Every(2));
            let mut d_y0 = vec![0.0; layout.tangent_len()];
            let mut d_th = vec![0.0; field.n_params()];
            discrete_adjoint(
                &mut field,
                &mut st,
                &traj,
                &loss.gradient(traj.final_state()),
                &mut d_y0,
                &mut d_th,
            );
            results.push((traj.final_state().to_vec(), d_y0, d_th));
        }
        assert!(results[0].0 == results[1].0, "{m}: final states differ");
        assert!(results[0].1 == results[1].1, "{m}: state gradients differ");
        assert!(
            results[0].2 == results[1].2,
            "{m}: parameter gradients differ"
        );
    }
}
