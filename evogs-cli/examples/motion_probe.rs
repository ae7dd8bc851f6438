//! Is the cube's true motion a better fit than what training learnt, for the model it learnt?
//!
//! Loads a trained run on `toys` or `toys-mini` and, for training views at early times,
//! compares the photometric training loss `(1 − λ)·L1 + λ·(1 − SSIM)` of the model's own
//! Gaussians at the view's time with the same Gaussians except that the cube's (those inside
//! the cube at t = 0, from the scene's `meta.json`, copied in `tools/data/toys-meta.json`)
//! are replaced by the model's t = 0 cube turned rigidly about the true axis and centre by a
//! fraction φ of the true angle `2π·t` (positions and orientations; scales, opacities and
//! colours as at t = 0). A loss that keeps falling up to φ ≈ 1 means the photometric
//! gradient along this path points at the true motion and the training stopped short of
//! it; a minimum at small φ means the learnt appearance fits the wrong motion better.
//! Losses are printed relative to the model's own (×10⁴; negative: better than the model).
//!
//! ```text
//! cargo run --release -p evogs-cli --example motion_probe -- RUN [TIMES]
//! ```
//! `TIMES`: comma-separated target times (default 0.06,0.12,0.18,0.25); the training view
//! nearest to each is used.

use evogs_cli::app::load::load_dataset;
use evogs_cli::app::paths::RunFolder;
use evogs_cli::run::checkpoint;
use evogs_cli::train::step::render_options;
use evogs_cli::train::views::training_views;
use evogs_math::so3::exp_quat;
use evogs_math::{Par, Vec3};
use evogs_splat::loss::photometric_loss;
use evogs_splat::ssim::SsimWorkspace;
use evogs_splat::{Splats, TiledRasterizer, render_tiled};
use std::f64::consts::TAU;
use std::path::PathBuf;
use toys_cube::{AXIS, CENTRE, HALF};

#[path = "common/toys_cube.rs"]
mod toys_cube;

/// The cube's fixed initial tilt `Rot([1, 1, 0], TILT)` (its pose at t = 0).
const TILT: f64 = 0.5;
/// Fractions of the true angle tried.
const FRACTIONS: [f64; 9] = [-0.2, 0.0, 0.2, 0.4, 0.6, 0.8, 1.0, 1.2, 1.4];

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let run = RunFolder::new(&PathBuf::from(
        args.get(1).expect("usage: motion_probe RUN [TIMES]"),
    ));
    let times: Vec<f64> = args.get(2).map_or(vec![0.06, 0.12, 0.18, 0.25], |s| {
        s.split(',')
            .map(|v| v.parse().expect("TIMES: numbers"))
            .collect()
    });
    let l = checkpoint::load_model(&run.checkpoint()).expect("checkpoint");
    let mut model = l.model;
    let dir = run.data_dir().expect("data folder");
    let ds = load_dataset(&dir, &l.cfg, true).expect("dataset");
    let views = training_views(&ds.train, &(0..ds.train.len()).collect::<Vec<_>>()).expect("views");
    model.field.set_count(model.len());
    model.field.set_par(Par::best());
    let opts = render_options(
        l.cfg.data.background,
        model.canonical.sh_degree,
        Par::best(),
    );
    #[allow(clippy::cast_possible_truncation, reason = "the loss runs in f32")]
    let lambda = l.cfg.loss.lambda_ssim as f32;
    let (mut stepper, mut rast, mut ssim) =
        (None, TiledRasterizer::new(), SsimWorkspace::default());
    let mut s0 = Splats::default();
    model.splats_at(0.0, &mut stepper, &mut s0);
    // The cube's Gaussians at t = 0: inside the (slightly enlarged) cube in its t = 0 pose.
    let pose0 = exp_quat(Vec3::new(1.0, 1.0, 0.0) * (TILT / 2f64.sqrt()));
    let cube: Vec<usize> = (0..s0.len())
        .filter(|&i| {
            let u = pose0.rotate_inv(s0.means[i].cast::<f64>() - CENTRE);
            u.to_array().iter().all(|c| c.abs() <= 1.1 * HALF)
        })
        .collect();
    println!(
        "{} Gaussians, {} in the cube at t = 0",
        s0.len(),
        cube.len()
    );
    print!("{:>6} {:>6} {:>8} |", "t", "deg", "model");
    for f in FRACTIONS {
        print!(" {:>7}", format!("φ={f}"));
    }
    println!("   (loss − model's loss) × 1e4");
    let mut st = Splats::default();
    let mut probe = Splats::default();
    for &target in &times {
        let v = views
            .iter()
            .min_by(|a, b| (a.time - target).abs().total_cmp(&(b.time - target).abs()))
            .expect("views");
        let mut loss = |s: &Splats<f32>| -> f64 {
            let r = render_tiled(s, &v.camera, &opts, &mut rast);
            f64::from(
                photometric_loss(&mut ssim, &r.raster.rgb, &v.image, lambda, Par::best()).total,
            )
        };
        model.splats_at(v.time, &mut stepper, &mut st);
        let own = loss(&st);
        print!("{:>6.3} {:>6.1} {:>8.5} |", v.time, v.time * 360.0, own);
        for f in FRACTIONS {
            let turn = exp_quat(AXIS * (f * TAU * v.time));
            probe.clone_from(&st);
            for &i in &cube {
                let x = CENTRE + turn.rotate(s0.means[i].cast::<f64>() - CENTRE);
                probe.means[i] = x.cast();
                probe.quats[i] = (turn.cast() * s0.quats[i]).normalize();
                probe.log_scales[i] = s0.log_scales[i];
            }
            print!(" {:>7.2}", (loss(&probe) - own) * 1e4);
        }
        println!();
    }
}
