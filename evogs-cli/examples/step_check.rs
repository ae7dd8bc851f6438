//! Is the trained ODE solved accurately at the run's step size?
//!
//! Loads a run's checkpoint and, for each anchor segment and a few times inside it, integrates
//! every Gaussian from its anchor with the run's stepper at its maximum step `h` and at `h/16`,
//! then prints percentiles of the position difference between the two solutions (an estimate
//! of the global integration error at step `h`: RK4's error falls 16⁴-fold at `h/16`), of the
//! displacement from the anchor, and of the largest `|p|`. A difference comparable with the
//! displacement means the stepper is outside its stability or accuracy region for the learnt
//! field, and the exact discrete adjoint then differentiates a numerical artefact.
//!
//! ```text
//! cargo run --release -p evogs-cli --example step_check -- RUN [REFINE]
//! ```

use evogs::run::checkpoint;
use evogs_cli::app::paths::RunFolder;
use evogs_math::Par;
use evogs_splat::Splats;
use stats::pct;
use std::path::PathBuf;

#[path = "common/stats.rs"]
mod stats;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let run = RunFolder::new(&PathBuf::from(
        args.get(1).expect("usage: step_check RUN [REFINE]"),
    ));
    let refine: f64 = args
        .get(2)
        .map_or(16.0, |s| s.parse().expect("REFINE: a number"));
    let l = checkpoint::load_model(&run.checkpoint()).expect("checkpoint");
    let mut model = l.model;
    model.set_par(Par::best());
    let h = model.max_step;
    let times = model.anchor_times.clone();
    println!(
        "{} Gaussians, anchors at {times:?}, step h = {h}, reference step h/{refine}",
        model.len()
    );
    println!("     t | |p(h) − p(h/r)| p50 p99 max | displacement p50 p99 max | max |p|");
    let (mut stepper, mut coarse, mut fine) = (None, Splats::default(), Splats::default());
    for (k, w) in times.windows(2).enumerate() {
        let start = model.anchor_state(k).0.to_vec();
        for f in [0.25, 0.5, 0.75, 0.999] {
            let t = w[0] + f * (w[1] - w[0]);
            model.max_step = h;
            model.splats_at(t, &mut stepper, &mut coarse);
            model.max_step = h / refine;
            model.splats_at(t, &mut stepper, &mut fine);
            let mut err: Vec<f64> = (0..model.len())
                .map(|i| f64::from((coarse.means[i] - fine.means[i]).norm()))
                .collect();
            let mut disp: Vec<f64> = (0..model.len())
                .map(|i| f64::from((fine.means[i] - start[i]).norm()))
                .collect();
            let far = fine
                .means
                .iter()
                .map(|p| f64::from(p.norm()))
                .fold(0.0, f64::max);
            err.sort_by(f64::total_cmp);
            disp.sort_by(f64::total_cmp);
            println!(
                "{t:6.3} | {:.2e} {:.2e} {:.2e} | {:.3} {:.3} {:.3} | {far:.2}",
                pct(&err, 0.5),
                pct(&err, 0.99),
                pct(&err, 1.0),
                pct(&disp, 0.5),
                pct(&disp, 0.99),
                pct(&disp, 1.0),
            );
        }
    }
}
