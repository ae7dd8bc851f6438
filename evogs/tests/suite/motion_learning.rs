//! A regression test of motion learning on a small dynamic scene that the test makes itself:
//! a checkered patch of Gaussians slides across a static backdrop, filmed by a ring of six
//! cameras at nine times. Velocity motion, trained briefly, must carry the patch along (its
//! Gaussians move at least half the true distance, in the true direction: 72 % of it with
//! the default trainable waypoints, 99 % without waypoints) and must render held-out times
//! (between the training times) clearly better than the static model (by 4 dB; it does by
//! 6.0 dB, and by 11.1 dB without waypoints).
//!
//! `cargo test --release -p evogs --test suite motion_learning:: -- --ignored --nocapture` runs
//! the ablation table of `docs/results.md` on the same scene (each technique's switch, velocity
//! and deformation at equal settings).

use evogs::config::TrainConfig;
use evogs::eval::render_frame;
use evogs::field::HexPlaneConfig;
use evogs::model::{Motion, Waypoints};
use evogs::train::step::ViewData;
use evogs::train::trainer::Trainer;
use evogs_math::{Par, Quat, Vec3};
use evogs_ode::Method;
use evogs_splat::metrics::mse;
use evogs_splat::{Image, PinholeCamera, RenderOptions, Splats, render};
use std::sync::Arc;

const SIZE: usize = 40;
const CAMERAS: usize = 6;
const TIMES: usize = 9;
/// The patch's centre slides from START to START + TRAVEL over t in [0, 1].
const START: [f32; 3] = [-0.35, 0.0, 0.1];
const TRAVEL: f32 = 0.7;

/// One ground-truth Gaussian: position at t = 0, colour, whether it moves.
type Blob = ([f32; 3], [f32; 3], bool);

fn ground_truth() -> Vec<Blob> {
    let mut blobs = Vec::new();
    // The moving patch: 4 × 4 Gaussians, red and yellow checkers.
    for i in 0..4 {
        for j in 0..4 {
            let (x, y) = (
                START[0] + 0.06 * (i as f32 - 1.5),
                START[1] + 0.06 * (j as f32 - 1.5),
            );
            let c = if (i + j) % 2 == 0 {
                [0.9, 0.1, 0.1]
            } else {
                [0.95, 0.85, 0.1]
            };
            blobs.push(([x, y, START[2]], c, true));
        }
    }
    // The static backdrop: a 6 × 6 grid of blue and grey Gaussians below the patch.
    for i in 0..6 {
        for j in 0..6 {
            let (x, y) = (-0.6 + 0.24 * i as f32, -0.6 + 0.24 * j as f32);
            let c = if (i + j) % 2 == 0 {
                [0.15, 0.3, 0.8]
            } else {
                [0.5, 0.5, 0.5]
            };
            blobs.push(([x, y, -0.15], c, false));
        }
    }
    blobs
}

/// The scene at time `t` as Gaussians (SH degree 0).
fn scene_at(blobs: &[Blob], t: f32) -> Splats<f32> {
    let mut s = Splats::new(0);
    for &(p, c, moving) in blobs {
        let x = if moving { p[0] + TRAVEL * t } else { p[0] };
        let scale = if moving { 0.035_f32 } else { 0.13 };
        #[allow(clippy::cast_possible_truncation, reason = "a constant in f32")]
        let c0 = evogs_math::sh::SH_C0 as f32;
        let dc = c.map(|v| (v - 0.5) / c0);
        s.push(
            Vec3::new(x, p[1], p[2]),
            Vec3::new(scale.ln(), scale.ln(), (0.3 * scale).ln()),
            Quat::identity(),
            3.0,
            &[dc],
        );
    }
    s
}

fn camera(k: usize, shift: f64) -> PinholeCamera<f32> {
    let az = (k as f64 + shift) * std::f64::consts::TAU / CAMERAS as f64;
    let el = 0.8_f64;
    let eye = Vec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin()) * 2.2;
    PinholeCamera::look_at(eye, Vec3::zero(), Vec3::new(0.0, 0.0, 1.0), 0.9, SIZE, SIZE)
        .expect("camera")
}

fn view(blobs: &[Blob], cam: PinholeCamera<f32>, t: f64) -> ViewData<f32> {
    let opts = RenderOptions {
        sh_degree: 0,
        background: [1.0; 3],
        par: Par::Seq,
        ..RenderOptions::default()
    };
    #[allow(clippy::cast_possible_truncation, reason = "times in [0, 1]")]
    let image: Image<f32> = render(&scene_at(blobs, t as f32), &cam, &opts).raster.rgb;
    ViewData {
        camera: cam,
        time: t,
        image: Arc::new(image),
    }
}

fn config(motion: Motion) -> TrainConfig {
    let mut c = TrainConfig::fast();
    c.dynamics.motion = motion;
    c.field.hexplane = HexPlaneConfig {
        channels: 8,
        resolution: [12, 12, 12, 9],
        multires: vec![1, 2],
    };
    c.field.width = 32;
    c.init.sh_degree = 0;
    c.schedule.warmup_iters = 60;
    c.schedule.iterations = 700;
    c.schedule.curriculum_iters = 300;
    c.schedule.log_every = 100;
    c.densify.from_iter = 100;
    c.densify.until_iter = 400;
    c.densify.interval = 100;
    c.densify.max_gaussians = 2000;
    c.optim.lr_max_steps = 700;
    c.loss.coherence_samples = 64;
    c
}

/// Trains `cfg` on the scene; the trainer and its mean PSNR on the held-out views.
fn train_with(
    cfg: TrainConfig,
    train: &[ViewData<f32>],
    held_out: &[ViewData<f32>],
) -> (Trainer, f64) {
    let blobs = ground_truth();
    let pos: Vec<[f32; 3]> = blobs.iter().map(|b| b.0).collect();
    let col: Vec<[f32; 3]> = blobs.iter().map(|b| b.1).collect();
    let mut t = Trainer::new(cfg, train.to_vec(), Some((&pos, Some(&col)))).expect("trainer");
    while !t.finished() {
        t.step().expect("finite step");
    }
    let mut scratch = Splats::default();
    let mut sum = 0.0;
    for v in held_out {
        let img = render_frame(
            t.model_mut(),
            &v.camera,
            v.time,
            [1.0; 3],
            Par::best(),
            &mut scratch,
        );
        sum += -10.0 * f64::from(mse(&img, &v.image)).log10();
    }
    let psnr = sum / held_out.len() as f64;
    (t, psnr)
}

/// Trains `motion` with the test's configuration.
fn train(motion: Motion, train: &[ViewData<f32>], held_out: &[ViewData<f32>]) -> (Trainer, f64) {
    train_with(config(motion), train, held_out)
}

/// Training views (six cameras, nine times) and held-out views (other directions, times
/// between the training times).
fn views() -> (Vec<ViewData<f32>>, Vec<ViewData<f32>>) {
    let blobs = ground_truth();
    let mut train_views = Vec::new();
    for k in 0..TIMES {
        let t = k as f64 / (TIMES - 1) as f64;
        for c in 0..CAMERAS {
            train_views.push(view(&blobs, camera(c, 0.0), t));
        }
    }
    // Held out: other directions, at times between the training times.
    let held_out: Vec<ViewData<f32>> = (0..TIMES - 1)
        .map(|k| {
            let t = (k as f64 + 0.5) / (TIMES - 1) as f64;
            view(&blobs, camera(k % CAMERAS, 0.5), t)
        })
        .collect();
    (train_views, held_out)
}

/// How far the patch's Gaussians (canonical ones near its start, weighted by opacity: one that
/// has faded out carries nothing) move from t = 0 to t = 1: (Δx, Δy).
fn patch_travel(t: &mut Trainer) -> (f32, f32) {
    let model = t.model_mut();
    let near: Vec<usize> = model
        .canonical
        .means
        .iter()
        .enumerate()
        .filter(|(_, m)| {
            (m.x - START[0]).abs() < 0.15 && (m.y - START[1]).abs() < 0.15 && m.z > 0.0
        })
        .map(|(i, _)| i)
        .collect();
    assert!(near.len() >= 8, "the patch keeps Gaussians: {}", near.len());
    let mut stepper = None;
    let (mut s0, mut s1) = (Splats::default(), Splats::default());
    let _ = model.splats_at(0.0, &mut stepper, &mut s0);
    let _ = model.splats_at(1.0, &mut stepper, &mut s1);
    let opacity = |i: usize| 1.0 / (1.0 + (-model.canonical.opacity_logits[i]).exp());
    let w: f32 = near.iter().map(|&i| opacity(i)).sum();
    let mean = |s: &Splats<f32>, a: usize| -> f32 {
        near.iter()
            .map(|&i| opacity(i) * s.means[i][a])
            .sum::<f32>()
            / w
    };
    (mean(&s1, 0) - mean(&s0, 0), mean(&s1, 1) - mean(&s0, 1))
}

#[test]
fn velocity_motion_carries_a_sliding_patch_and_beats_the_static_model() {
    let (train_views, held_out) = views();
    let (_, psnr_static) = train(Motion::Static, &train_views, &held_out);
    let (mut velocity, psnr_velocity) = train(Motion::Velocity, &train_views, &held_out);
    println!("held-out PSNR: velocity {psnr_velocity:.2} dB, static {psnr_static:.2} dB");

    let (dx, dy) = patch_travel(&mut velocity);
    println!("patch moved by ({dx:.3}, {dy:.3}), true ({TRAVEL}, 0)");
    assert!(
        dx > 0.5 * TRAVEL && dx < 1.5 * TRAVEL && dy.abs() < 0.1 * TRAVEL,
        "the learnt motion carries the patch: moved ({dx}, {dy})"
    );
    assert!(
        psnr_velocity > psnr_static + 4.0,
        "the dynamics, not the appearance, carry the motion: velocity {psnr_velocity:.2} dB, \
         static {psnr_static:.2} dB"
    );
}

/// The ablation table of `docs/results.md` (run with `--ignored --nocapture`): each technique
/// on and off, velocity and deformation at equal settings.
#[test]
#[ignore = "an experiment (about two minutes in release): prints the ablation table"]
fn ablations_of_the_motion_learning_techniques() {
    let (train_views, held_out) = views();
    let (_, psnr_static) = train(Motion::Static, &train_views, &held_out);
    println!("static: held-out PSNR {psnr_static:.2} dB");
    type Tweak = fn(&mut TrainConfig);
    let variants: [(&str, Tweak); 8] = [
        ("defaults", |_| {}),
        ("waypoints off, steps of 1/2", |c| {
            c.dynamics.waypoints = Waypoints::Off;
            c.dynamics.step_fraction = 0.5;
        }),
        ("anchor loss every 2 steps, weight 10", |c| {
            c.loss.anchor_every = 2;
            c.loss.lambda_anchor = 10.0;
        }),
        ("RK4 instead of midpoint", |c| {
            c.dynamics.method = Method::Rk4;
        }),
        ("Euler instead of midpoint", |c| {
            c.dynamics.method = Method::Euler;
        }),
        ("no temporal curriculum", |c| {
            c.schedule.warmup_time_window = 1.0;
            c.schedule.curriculum_iters = 0;
            c.schedule.curriculum_focus = 0.0;
        }),
        ("velocity coherence 0.01", |c| {
            c.loss.lambda_coherence = 0.01;
        }),
        ("field learning rates x3", |c| {
            c.optim.grid_lr_init *= 3.0;
            c.optim.grid_lr_final *= 3.0;
            c.optim.deformation_lr_init *= 3.0;
            c.optim.deformation_lr_final *= 3.0;
        }),
    ];
    println!("| variant | motion | held-out PSNR (dB) | patch travel (of {TRAVEL}) |");
    println!("|---|---|---|---|");
    for (name, tweak) in variants {
        for motion in [Motion::Velocity, Motion::Deformation] {
            let mut c = config(motion);
            tweak(&mut c);
            let (mut t, psnr) = train_with(c, &train_views, &held_out);
            let (dx, _) = patch_travel(&mut t);
            println!("| {name} | {} | {psnr:.2} | {dx:.3} |", motion.as_str());
        }
    }
}
