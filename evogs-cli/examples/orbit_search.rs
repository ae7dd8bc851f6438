//! Runs the orbit search ([`evogs_cli::motion::orbit`]) on a stored run and writes the
//! checkpoint back, so that `evogs train --out RUN --resume` continues from the orbits found.
//! (The same as `[orbit_search] at_iter` during training.) A run stopped at the end of its
//! static warm-up is first taken one step into the dynamics.
//!
//! ```text
//! cargo run --release -p evogs-cli --example orbit_search -- RUN [--dry-run]
//! ```
//! The search's settings are the `[orbit_search]` table of `RUN/config.toml` (defaults if it
//! has none). `--dry-run` prints the search and leaves the checkpoint as it is.

#[path = "common/stored_run.rs"]
mod stored_run;
use evogs_cli::app::paths::RunFolder;
use evogs_cli::run::checkpoint;
use std::path::PathBuf;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let run = RunFolder::new(&PathBuf::from(
        args.first().expect("usage: orbit_search RUN [--dry-run]"),
    ));
    let dry = args.iter().any(|a| a == "--dry-run");
    let (cfg, mut tr) = stored_run::load(&run);
    if !tr.model.dynamics_active {
        tr.step().expect("one step into the dynamics");
    }
    assert!(tr.model.dynamics_active, "the run's dynamics must be on");
    tr.cfg.orbit_search = cfg.orbit_search;
    println!("iteration {}, {} Gaussians", tr.iteration, tr.model.len());
    let start = Instant::now();
    let found = tr.orbit_search(&mut |m| println!("{m}"));
    println!(
        "{} orbits found in {:.1} s",
        found.len(),
        start.elapsed().as_secs_f64()
    );
    if !dry {
        checkpoint::save(&tr, &run.checkpoint()).expect("write the checkpoint");
        println!("wrote {}", run.checkpoint().display());
    }
}
