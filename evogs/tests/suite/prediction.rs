//! Prediction after the training window, on a scene with known motion: the procedural
//! `translate` scene (a box sliding at constant velocity over a static floor, `evogs
//! scenes`), multi-view, trained on `t ≤ 0.75` with continuous waypoints and first-order
//! hops, must carry the box on past the window (it does: 0.49 of the travel left as error,
//! on 2 threads; holding the state leaves all of it). The trajectory error at `t = 1.3` (the
//! distance of the model's Gaussians on the box from where the true motion takes them,
//! relative to the distance the box travels after 0.75) is 1 for a model that holds the
//! state at the end of the window; the test fails if the model's error regresses past
//! [`MAX_RELATIVE_ERROR`].

use evogs::config::{Protocol, TrainConfig};
use evogs::data::{Dataset, LoadOptions};
use evogs::field::HexPlaneConfig;
use evogs::model::{HopLaw, Motion, Waypoints};
use evogs::scenes::{
    BuiltScene, GroundTruth, Layout, Spacing, Variant, model_trajectory_error, select, write_scene,
};
use evogs::train::trainer::Trainer;
use evogs::train::views::{supervised_indices, training_views};
use evogs_math::Par;

/// The largest accepted relative trajectory error at t = 1.3 (holding the state scores 1).
const MAX_RELATIVE_ERROR: f64 = 0.6;

fn layout() -> Layout {
    Layout {
        size: 48,
        train_times: 16,
        test_times: 4,
        val_times: 2,
        future_times: 3,
        ring: 4,
        ring_times: 16,
    }
}

fn config() -> TrainConfig {
    let mut cfg = TrainConfig::fast();
    cfg.data.protocol = Protocol::Future;
    cfg.data.split_time = 0.75;
    cfg.dynamics.motion = Motion::Velocity;
    cfg.dynamics.waypoints = Waypoints::Continuous;
    cfg.hop.law = HopLaw::FirstOrder;
    cfg.hop.length = 1.0 / 11.0;
    cfg.field.hexplane = HexPlaneConfig {
        channels: 8,
        resolution: [16, 16, 16, 8],
        multires: vec![1, 2],
    };
    cfg.field.width = 32;
    cfg.densify.max_gaussians = 4000;
    cfg.schedule.iterations = 900;
    cfg.schedule.warmup_iters = 100;
    cfg.schedule.curriculum_iters = 400;
    cfg.densify.from_iter = 150;
    cfg.densify.until_iter = 700;
    cfg.optim.lr_max_steps = 600;
    cfg.schedule.checkpoint_every = 0;
    cfg
}

#[test]
fn first_order_hops_carry_a_sliding_box_past_the_training_window() {
    let spec = &select(&["translate".to_string()]).expect("a known scene")[0];
    let scene = BuiltScene::new(spec, Spacing::default(), 0);
    let dir = std::env::temp_dir().join(format!("evogs-prediction-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    write_scene(
        &scene,
        Variant::Multiview,
        &layout(),
        &dir,
        Par::best(),
        |_, _| {},
    )
    .expect("scene written");
    let ds = Dataset::load(&dir, &LoadOptions::default()).expect("scene loads");
    let cfg = config();
    let idx = supervised_indices(&ds.train, &cfg.data);
    let views = training_views(&ds.train, &idx).expect("views");
    let points = ds
        .points
        .as_ref()
        .map(|p| (p.positions.as_slice(), p.colors.as_deref()));
    let mut trainer = Trainer::new(cfg, views, points).expect("trainer");
    while !trainer.finished() {
        trainer.step().expect("a finite step");
    }
    let truth = GroundTruth::read(&dir.join("motion.json")).expect("motion.json");
    let err = model_trajectory_error(trainer.model_mut(), &truth, 0.75, 1.3)
        .expect("Gaussians on the box");
    println!("trajectory error at t = 1.3: {err:?}");
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        err.relative < MAX_RELATIVE_ERROR,
        "relative trajectory error {:.3} (holding the state: 1)",
        err.relative
    );
}

/// The configurations that `docs/results.md` measures with (`docs/configs/*.toml`) still
/// read onto the `fast` preset and validate.
#[test]
fn the_documented_prediction_configurations_read_and_validate() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/configs");
    let mut read = 0;
    for entry in std::fs::read_dir(&dir).expect("docs/configs") {
        let path = entry.expect("an entry").path();
        if path.extension().is_some_and(|e| e == "toml") {
            let text = std::fs::read_to_string(&path).expect("readable");
            let cfg = TrainConfig::fast()
                .merge_toml(&text)
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            cfg.validate()
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            read += 1;
        }
    }
    assert!(read >= 5, "{read} configurations");
}
