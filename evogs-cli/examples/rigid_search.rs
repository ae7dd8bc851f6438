//! Runs the spin search ([`evogs_cli::motion`]) on a stored run and writes the checkpoint
//! back, so that `evogs train --out RUN --resume` continues from the chosen spins. (The same
//! as `[spin_search] at_iter` during training, for a run that was trained without it.)
//!
//! ```text
//! cargo run --release -p evogs-cli --example rigid_search -- RUN
//! ```
//! The search's settings are the `[spin_search]` table of `RUN/config.toml` (defaults if it
//! has none).

#[path = "common/stored_run.rs"]
mod stored_run;
use evogs_cli::app::paths::RunFolder;
use evogs_cli::run::checkpoint;
use std::path::PathBuf;

fn main() {
    let run = RunFolder::new(&PathBuf::from(
        std::env::args().nth(1).expect("usage: rigid_search RUN"),
    ));
    let (cfg, mut tr) = stored_run::load(&run);
    assert!(tr.model.dynamics_active, "the run's dynamics must be on");
    tr.cfg.spin_search = cfg.spin_search;
    println!("iteration {}, {} Gaussians", tr.iteration, tr.model.len());
    let chosen = tr.spin_search(&mut |m| println!("{m}"));
    println!("chosen multipliers: {chosen:?}");
    checkpoint::save(&tr, &run.checkpoint()).expect("write the checkpoint");
    println!("wrote {}", run.checkpoint().display());
}
