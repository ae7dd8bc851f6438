//! Can the velocity field represent, and Adam at the training learning rates learn, the
//! motion of the `toys` cube when it is told the motion directly?
//!
//! Fits the `fast` (or `paper`) field by supervised regression to the cube's true velocity
//! `v = ω × (x − c)` (`ω = 2π·axis` per unit time; `c`, axis and half-size from the scene's
//! `meta.json`, copied in `tools/data/toys-meta.json`) at points sampled in the turning cube
//! at random times in `[0, 0.25]`, with the field's two Adam groups at the training rates
//! (`grid_lr_init`, `deformation_lr_init`, both × the camera extent), and prints the relative
//! error, to compare with how far photometric training turns the cube.
//!
//! ```text
//! cargo run --release -p evogs-cli --example field_fit -- [LR_MULT] [fast|paper]
//! ```

use evogs::config::TrainConfig;
use evogs::field::{Batch, BatchVjp, FieldRecord, NeuralField, TimeMapping};
use evogs_math::Vec3;
use evogs_math::rng::SplitMix64;
use evogs_math::so3::exp_quat;
use field_adam::FieldAdam;
use std::f64::consts::TAU;
use toys_cube::{AXIS, CENTRE, HALF};

#[path = "common/toys_cube.rs"]
mod toys_cube;

#[path = "common/field_adam.rs"]
mod field_adam;

/// Bounds of `data/toys-mini/points3d.ply` (rounded) and the `aabb_margin` of the presets.
const LO: [f64; 3] = [-1.3, -1.3, -1.0];
const HI: [f64; 3] = [1.3, 1.3, 1.0];
const MARGIN: f64 = 0.2;
/// The learning-rate scale of training: 1.1 × the largest camera distance from the cameras'
/// mean, about 4.4–4.8 for cameras on a sphere of radius 4.
const EXTENT: f64 = 4.8;
/// Points per iteration and iterations.
const POINTS: usize = 1000;
const ITERATIONS: usize = 3000;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let lr_mult: f64 = args
        .get(1)
        .map_or(1.0, |s| s.parse().expect("LR_MULT: a number"));
    let cfg = if args.get(2).is_some_and(|s| s == "paper") {
        TrainConfig::paper()
    } else {
        TrainConfig::fast()
    };
    let lo: [f64; 3] = core::array::from_fn(|a| LO[a] - MARGIN * (HI[a] - LO[a]));
    let hi: [f64; 3] = core::array::from_fn(|a| HI[a] + MARGIN * (HI[a] - LO[a]));
    let unit_time = TimeMapping::Normalized {
        t_min: 0.0,
        t_max: 1.0,
    };
    let mut field: NeuralField<f32> = NeuralField::new(&cfg.field, lo, hi, unit_time, cfg.seed);
    let lr = lr_mult * EXTENT;
    let o = &cfg.optim;
    let mut adam = FieldAdam::new(&field, o.grid_lr_init * lr, o.deformation_lr_init * lr);
    let omega = AXIS * TAU;
    let mut rng = SplitMix64::new(1);
    let mut pos = vec![0f32; 3 * POINTS];
    let mut target = vec![Vec3::zero(); POINTS];
    let mut out = vec![0f32; 9 * POINTS];
    let mut d_out = vec![0f32; 9 * POINTS];
    let mut d_pos = vec![0f32; 3 * POINTS];
    let mut g = vec![0f32; field.params().len()];
    let mut record = FieldRecord::default();
    let inv_n = 1.0 / POINTS as f64;
    for it in 1..=ITERATIONS {
        let t = rng.uniform(0.0, 0.25);
        let turn = exp_quat(omega * t);
        for (i, tg) in target.iter_mut().enumerate() {
            let u = Vec3::from_array(core::array::from_fn(|_| rng.uniform(-HALF, HALF)));
            let r = turn.rotate(u);
            *tg = omega.cross(r);
            for (a, p) in (r + CENTRE).to_array().into_iter().enumerate() {
                #[allow(clippy::cast_possible_truncation, reason = "the field runs in f32")]
                {
                    pos[3 * i + a] = p as f32;
                }
            }
        }
        #[allow(clippy::cast_possible_truncation, reason = "the field runs in f32")]
        let t32 = t as f32;
        let at = Batch {
            t: t32,
            positions: &pos,
            stride: 3,
            n: POINTS,
        };
        field.eval_batch(&at, &mut out, Some(&mut record));
        let (mut err, mut norm) = (0.0, 0.0);
        d_out.fill(0.0);
        for (i, tg) in target.iter().enumerate() {
            for (a, &ta) in tg.to_array().iter().enumerate() {
                let e = f64::from(out[9 * i + a]) - ta;
                err += e * e;
                norm += ta * ta;
                #[allow(clippy::cast_possible_truncation, reason = "the field runs in f32")]
                {
                    d_out[9 * i + a] = (2.0 * e * inv_n) as f32;
                }
            }
        }
        g.fill(0.0);
        field.vjp_batch(BatchVjp {
            at,
            record: Some(&record),
            d_out: &d_out,
            d_positions: &mut d_pos,
            d_stride: 3,
            d_params: &mut g,
        });
        adam.step(&mut field, &g, 1.0);
        if it.is_multiple_of(100) || it == 1 {
            println!(
                "iteration {it:4}: relative error {:.3}",
                (err / norm).sqrt()
            );
        }
    }
}
