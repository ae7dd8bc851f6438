//! Would the model reach the gate if it were given the true motion, and how well can its field
//! be taught a motion through the stepper? (A diagnostic: it uses the `toys` scene's
//! ground-truth motions, which training never sees.)
//!
//! Takes a `toys` run stopped at the end of its static warm-up (`evogs train --iters W`, `W` =
//! the preset's `warmup_iters`) and decides for every canonical Gaussian which body it lies on
//! at t = 0 (within a margin of the cube, the torus, the ball or the flag's surface; else
//! static). It sets the trainable anchors to the true states at their times, then fits the
//! velocity field to the true motion in one of two ways, with Adam at the training rates
//! (× `LR_MULT`, falling to 1 % over the fit):
//!
//! - `velocity`: regression of the field's velocity at every Gaussian's true position at a
//!   random time to its true velocity (a central difference of the true trajectory);
//! - `trajectory`: the true trajectories themselves, through the run's own stepper and the
//!   exact discrete adjoint, `Σ |p(t) − p*(t)|² + |q(t) − q*(t)|² + |s(t) − s(0)|²` at a random
//!   time, which is how photometric training reaches the field (through positions only).
//!
//! Static Gaussians' errors are weighed by `STATIC_WEIGHT`. It prints the position error per
//! body (RMS and percentiles over 16 evenly spaced times, integrating from the anchors with the
//! run's stepper) as it goes, and writes the checkpoint back with the dynamics on, so that
//! `evogs train --out RUN --resume --iters N` continues photometric training from the true
//! motion. The README compares such runs with the ones that had to find the motion.
//!
//! ```text
//! cargo run --release -p evogs-cli --example oracle_motion -- RUN [MODE] [ITERS] [STATIC_WEIGHT] [LR_MULT] [STEP_FRACTION]
//! ```
//! `MODE` `velocity` (default) or `trajectory`; `ITERS` (2000) Adam steps; `STATIC_WEIGHT` (3);
//! `LR_MULT` (1); `STEP_FRACTION` (0: the run's) sets the stepper's largest step for the fit and
//! the report only (the checkpoint keeps the run's).

use evogs_cli::app::paths::RunFolder;
use evogs_cli::app::train::load_dataset;
use evogs_cli::model::Model;
use evogs_cli::run::checkpoint;
use evogs_cli::train::adam::{Adam, AdamState};
use evogs_cli::train::views::training_views;
use evogs_math::rng::SplitMix64;
use evogs_math::{Par, Quat, Vec3};
use evogs_splat::Splats;
use stats::pct;
use std::path::PathBuf;
use toys_truth::{Body, Truth, meta_path};

#[path = "common/stats.rs"]
mod stats;

#[path = "common/toys_truth.rs"]
mod toys_truth;

/// How far outside a body (scene units) a Gaussian still counts as on it.
const MARGIN: f64 = 0.05;
/// Evenly spaced times at which the fit is reported.
const REPORT_TIMES: usize = 16;
/// Reporting groups.
const NAMES: [&str; 5] = ["static", "cube", "torus", "ball", "flag"];

fn v64(v: Vec3<f32>) -> Vec3<f64> {
    Vec3::new(v.x.into(), v.y.into(), v.z.into())
}

#[allow(clippy::cast_possible_truncation, reason = "the model runs in f32")]
fn v32(v: Vec3<f64>) -> Vec3<f32> {
    Vec3::new(v.x as f32, v.y as f32, v.z as f32)
}

#[allow(clippy::cast_possible_truncation, reason = "the model runs in f32")]
fn q32(q: Quat<f64>) -> Quat<f32> {
    Quat::new(q.w as f32, q.x as f32, q.y as f32, q.z as f32)
}

/// The reporting group of a body (an index into [`NAMES`]).
const fn group(b: Body) -> usize {
    match b {
        Body::Static => 0,
        Body::Rigid(k) => 1 + k,
        Body::Flag => 4,
    }
}

/// Where each Gaussian is at `t` and how it is turned, given its body and state at `t0`.
struct Oracle {
    truth: Truth,
    body: Vec<Body>,
    flag: Vec<(f64, f64)>,
    p0: Vec<Vec3<f64>>,
    q0: Vec<Quat<f64>>,
    t0: f64,
    counts: [usize; 5],
}

impl Oracle {
    /// Assigns the canonical Gaussians of `model` to bodies.
    fn new(truth: Truth, model: &Model<f32>) -> Self {
        let n = model.len();
        let t0 = model.anchor_times[0];
        let ext = truth.extents();
        let p0: Vec<Vec3<f64>> = model.canonical.means.iter().map(|&p| v64(p)).collect();
        let q0 = model
            .canonical
            .quats
            .iter()
            .map(|q| q.normalize().cast())
            .collect();
        let (mut body, mut flag) = (vec![Body::Static; n], vec![(0.0, 0.0); n]);
        let mut counts = [0usize; 5];
        for (i, &p) in p0.iter().enumerate() {
            let cube = truth.rigid[0].to_body(t0, p);
            if cube.x.abs().max(cube.y.abs()).max(cube.z.abs()) <= ext[0] + MARGIN {
                body[i] = Body::Rigid(0);
            } else if truth.rigid[1].to_body(t0, p).norm() <= ext[1] + MARGIN {
                body[i] = Body::Rigid(1);
            } else if truth.rigid[2].to_body(t0, p).norm() <= ext[2] + MARGIN {
                body[i] = Body::Rigid(2);
            } else if let Some(sw) = truth.flag_coords(p, t0, MARGIN) {
                body[i] = Body::Flag;
                flag[i] = sw;
            }
            counts[group(body[i])] += 1;
        }
        Self {
            truth,
            body,
            flag,
            p0,
            q0,
            t0,
            counts,
        }
    }

    fn state(&self, i: usize, t: f64) -> (Vec3<f64>, Quat<f64>) {
        match self.body[i] {
            Body::Static => (self.p0[i], self.q0[i]),
            Body::Rigid(b) => {
                let (rel, p) = self.truth.rigid[b].carry(self.t0, t, self.p0[i]);
                (p, rel.mul_quat(self.q0[i]))
            }
            Body::Flag => {
                let (s, w) = self.flag[i];
                let off = self.p0[i] - self.truth.flag_point(s, w, self.t0);
                (self.truth.flag_point(s, w, t) + off, self.q0[i])
            }
        }
    }

    /// The true velocity of Gaussian `i` at `t` (a central difference, one-sided at the ends
    /// of `[0, 1]`).
    fn velocity(&self, i: usize, t: f64) -> Vec3<f64> {
        let (a, b) = ((t - 1e-3).max(0.0), (t + 1e-3).min(1.0));
        (self.state(i, b).0 - self.state(i, a).0) * (1.0 / (b - a))
    }

    fn weight(&self, i: usize, static_weight: f64) -> f64 {
        if self.body[i] == Body::Static {
            static_weight
        } else {
            1.0
        }
    }
}

/// Prints the position error per body over [`REPORT_TIMES`] evenly spaced times.
fn report(model: &mut Model<f32>, oracle: &Oracle, it: usize) {
    let (mut stepper, mut out) = (None, Splats::default());
    let mut all: [Vec<f64>; 5] = Default::default();
    for k in 0..REPORT_TIMES {
        #[allow(clippy::cast_precision_loss, reason = "small counts")]
        let t = (k as f64 + 0.5) / REPORT_TIMES as f64;
        model.splats_at(t, &mut stepper, &mut out);
        for (i, &m) in out.means.iter().enumerate() {
            all[group(oracle.body[i])].push((v64(m) - oracle.state(i, t).0).norm());
        }
    }
    let parts: Vec<String> = all
        .iter_mut()
        .zip(NAMES)
        .filter(|(a, _)| !a.is_empty())
        .map(|(a, name)| {
            a.sort_by(f64::total_cmp);
            #[allow(clippy::cast_precision_loss, reason = "a count")]
            let rms = (a.iter().map(|e| e * e).sum::<f64>() / a.len() as f64).sqrt();
            format!(
                "{name} {rms:.3} (p50 {:.3}, p90 {:.3})",
                pct(a, 0.5),
                pct(a, 0.9)
            )
        })
        .collect();
    println!("iteration {it:5}: position error RMS {}", parts.join(", "));
}

/// The field's two Adam groups at the run's initial rates.
struct FieldAdam {
    grid: AdamState,
    mlp: AdamState,
    adam: Adam,
    grid_lr: f64,
    mlp_lr: f64,
}

impl FieldAdam {
    fn step(&mut self, model: &mut Model<f32>, g: &[f32], scale: f64) {
        let (gr, mr) = (model.field.grid_range(), model.field.mlp_range());
        let p = model.field.params_mut();
        self.grid
            .step(&self.adam, self.grid_lr * scale, &mut p[gr.clone()], &g[gr]);
        self.mlp
            .step(&self.adam, self.mlp_lr * scale, &mut p[mr.clone()], &g[mr]);
    }
}

/// One step of the trajectory fit at `t`: through the stepper and the discrete adjoint.
fn trajectory_step(
    model: &mut Model<f32>,
    oracle: &Oracle,
    t: f64,
    static_weight: f64,
) -> Vec<f32> {
    let n = model.len();
    #[allow(clippy::cast_precision_loss, reason = "a count")]
    let inv_n = 1.0 / n as f64;
    let (mut stepper, mut out) = (None, Splats::default());
    let tape = model.splats_at(t, &mut stepper, &mut out);
    let mut d = model.zero_grad().canonical;
    for i in 0..n {
        let (p, q) = oracle.state(i, t);
        let w = 2.0 * oracle.weight(i, static_weight) * inv_n;
        d.means[i] = v32((v64(out.means[i]) - p) * w);
        let qm: Quat<f64> = out.quats[i].cast();
        let q = if qm.dot(q) < 0.0 { q.scale(-1.0) } else { q };
        d.quats[i] = q32(Quat::new(qm.w - q.w, qm.x - q.x, qm.y - q.y, qm.z - q.z).scale(w));
        let ds = v64(out.log_scales[i]) - v64(model.canonical.log_scales[i]);
        d.log_scales[i] = v32(ds * w);
    }
    let mut grad = model.zero_grad();
    model.backward_at(&tape, &mut stepper, &d, &mut grad);
    grad.field
}

/// One step of the velocity regression at `t`, at the Gaussians' true positions.
fn velocity_step(model: &mut Model<f32>, oracle: &Oracle, t: f64, static_weight: f64) -> Vec<f32> {
    let n = model.len();
    #[allow(clippy::cast_precision_loss, reason = "a count")]
    let inv_n = 1.0 / n as f64;
    let pos: Vec<f32> = (0..n)
        .flat_map(|i| v32(oracle.state(i, t).0).to_array())
        .collect();
    let (mut out, mut d_out) = (vec![0f32; 9 * n], vec![0f32; 9 * n]);
    #[allow(clippy::cast_possible_truncation, reason = "the field runs in f32")]
    let t32 = t as f32;
    model.field.set_count(n);
    model.field.eval_batch(t32, &pos, 3, n, &mut out);
    for i in 0..n {
        let e = v64(Vec3::from_slice(&out[9 * i..])) - oracle.velocity(i, t);
        v32(e * (2.0 * oracle.weight(i, static_weight) * inv_n)).write_to(&mut d_out[9 * i..]);
    }
    let mut d_pos = vec![0f32; 3 * n];
    let mut g = vec![0f32; model.field.params().len()];
    model
        .field
        .vjp_batch(t32, &pos, 3, n, &d_out, &mut d_pos, 3, &mut g);
    g
}

fn main() {
    let usage = "usage: oracle_motion RUN [velocity|trajectory] [ITERS] [STATIC_WEIGHT] [LR_MULT] [STEP_FRACTION]";
    let args: Vec<String> = std::env::args().collect();
    let run = RunFolder::new(&PathBuf::from(args.get(1).expect(usage)));
    let trajectory = match args.get(2).map_or("velocity", String::as_str) {
        "velocity" => false,
        "trajectory" => true,
        _ => panic!("{usage}"),
    };
    let num = |k: usize, default: f64| {
        args.get(k)
            .map_or(default, |s| s.parse().expect("a number"))
    };
    #[allow(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "a count"
    )]
    let iters = num(3, 2000.0) as usize;
    let (static_weight, lr_mult, step_fraction) = (num(4, 3.0), num(5, 1.0), num(6, 0.0));
    let l = checkpoint::load_model(&run.checkpoint()).expect("checkpoint");
    let ds = load_dataset(&run.data_dir().expect("data folder"), &l.cfg, true).expect("dataset");
    let views = training_views(&ds.train, &(0..ds.train.len()).collect::<Vec<_>>()).expect("views");
    let mut tr = checkpoint::resume(&run.checkpoint(), views).expect("checkpoint");
    assert!(
        !tr.model.dynamics_active,
        "the run must stop at the end of its static warm-up"
    );
    let model = &mut tr.model;
    model.field.set_par(Par::best());
    let run_step = model.max_step;
    if step_fraction > 0.0 {
        model.max_step = step_fraction * (tr.time_range.1 - tr.time_range.0);
    }
    let oracle = Oracle::new(Truth::load(&meta_path()), model);
    println!("{} Gaussians: {NAMES:?} = {:?}", model.len(), oracle.counts);
    for k in 1..model.anchor_times.len() {
        let tk = model.anchor_times[k];
        let a = &mut model.anchors[k - 1];
        for i in 0..a.means.len() {
            let (p, q) = oracle.state(i, tk);
            a.means[i] = v32(p);
            a.quats[i] = q32(q);
        }
    }
    model.dynamics_active = true;
    let (gr, mr) = (model.field.grid_range(), model.field.mlp_range());
    let mut opt = FieldAdam {
        grid: AdamState::new(gr.len()),
        mlp: AdamState::new(mr.len()),
        adam: Adam::default(),
        grid_lr: tr.cfg.optim.grid_lr_init * tr.extent * lr_mult,
        mlp_lr: tr.cfg.optim.deformation_lr_init * tr.extent * lr_mult,
    };
    let mut rng = SplitMix64::new(7);
    report(model, &oracle, 0);
    for it in 1..=iters {
        let t = rng.uniform(0.0, 1.0);
        let g = if trajectory {
            trajectory_step(model, &oracle, t, static_weight)
        } else {
            velocity_step(model, &oracle, t, static_weight)
        };
        #[allow(clippy::cast_precision_loss, reason = "small counts")]
        let decay = 0.01f64.powf(it as f64 / iters as f64);
        opt.step(model, &g, decay);
        if it.is_multiple_of(500) || it == iters {
            report(model, &oracle, it);
        }
    }
    model.max_step = run_step;
    checkpoint::save(&tr, &run.checkpoint()).expect("write the checkpoint");
    println!("wrote {}", run.checkpoint().display());
}
