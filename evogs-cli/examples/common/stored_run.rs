//! A stored run read back for the examples that work on one: its configuration as written
//! in `RUN/config.toml` and its trainer resumed from the checkpoint, with every training view
//! of its dataset.

use evogs_cli::app::load::load_dataset;
use evogs_cli::app::paths::RunFolder;
use evogs_cli::config::TrainConfig;
use evogs_cli::run::checkpoint;
use evogs_cli::train::trainer::Trainer;
use evogs_cli::train::views::training_views;

/// The run's `config.toml` and its trainer at the stored checkpoint. Panics with the failing
/// piece named.
pub(crate) fn load(run: &RunFolder) -> (TrainConfig, Trainer) {
    let text = std::fs::read_to_string(run.config()).expect("the run's config.toml");
    let cfg = TrainConfig::from_run_toml(&text).expect("the run's config.toml");
    let ds = load_dataset(&run.data_dir().expect("data folder"), &cfg, true).expect("dataset");
    let views = training_views(&ds.train, &(0..ds.train.len()).collect::<Vec<_>>()).expect("views");
    let tr = checkpoint::resume(&run.checkpoint(), views).expect("checkpoint");
    (cfg, tr)
}
