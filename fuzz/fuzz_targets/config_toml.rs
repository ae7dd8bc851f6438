//! `TrainConfig::fast().merge_toml(text)` then `validate()` on arbitrary text.
//!
//! Properties: never panics (TOML parsing, the merge, deserialisation, validation); a
//! configuration that validates survives `to_toml` and a fresh merge unchanged, so a run's
//! stored `config.toml` resumes with exactly the settings it was trained with.
#![no_main]

use evogs::config::TrainConfig;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(cfg) = TrainConfig::fast().merge_toml(text) else {
        return;
    };
    if cfg.validate().is_err() {
        return;
    }
    let back = TrainConfig::fast()
        .merge_toml(&cfg.to_toml())
        .expect("a valid configuration's TOML reads back");
    assert_eq!(back, cfg, "to_toml round trip");
    back.validate().expect("still valid");
});
