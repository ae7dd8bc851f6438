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
//! motion, to compare such runs with the ones that had to find the motion.
//!
//! ```text
//! cargo run --release -p evogs-cli --example oracle_motion -- RUN [MODE] [ITERS] [STATIC_WEIGHT] [LR_MULT] [STEP_FRACTION]
//! ```
//! `MODE` `velocity` (default) or `trajectory`; `ITERS` (2000) Adam steps; `STATIC_WEIGHT` (3);
//! `LR_MULT` (1); `STEP_FRACTION` (0: the run's) sets the stepper's largest step for the fit and
//! the report only (the checkpoint keeps the run's).

#[path = "common/stored_run.rs"]
mod stored_run;
use evogs_cli::app::paths::RunFolder;
use evogs_cli::model::{Model, ModelGrad};
use evogs_cli::run::checkpoint;
use evogs_math::rng::SplitMix64;
use evogs_math::{Par, Quat, Vec3};
use evogs_ode::Stepper;
use evogs_splat::{Splats, SplatsGrad};
use field_adam::FieldAdam;
use stats::pct;
use std::path::PathBuf;
use toys_truth::{Body, Truth, meta_path};

#[path = "common/field_adam.rs"]
mod field_adam;

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
/// Half the time step of the central difference that gives the true velocities.
const VELOCITY_EPS: f64 = 1e-3;

/// The reporting group of a body (an index into [`NAMES`]).
const fn group(b: Body) -> usize {
    match b {
        Body::Static => 0,
        Body::Rigid(k) => 1 + k,
        Body::Flag => 4,
    }
}

/// A Gaussian's true position and orientation.
type State = (Vec3<f64>, Quat<f64>);

/// Where each Gaussian is at `t` and how it is turned, given its body and state at `t0`.
struct Oracle {
    truth: Truth,
    body: Vec<Body>,
    /// Flag coordinates `(s, w)` and the offset from that flag point at `t0` (flag only).
    flag: Vec<((f64, f64), Vec3<f64>)>,
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
        let ext = truth.extents;
        let p0: Vec<Vec3<f64>> = model.canonical.means.iter().map(|p| p.cast()).collect();
        let q0 = model
            .canonical
            .quats
            .iter()
            .map(|q| q.normalize().cast())
            .collect();
        let mut body = vec![Body::Static; n];
        let mut flag = vec![((0.0, 0.0), Vec3::zero()); n];
        let mut counts = [0usize; 5];
        for (i, &p) in p0.iter().enumerate() {
            let cube = truth.rigid[0].to_body(t0, p);
            if cube.x.abs().max(cube.y.abs()).max(cube.z.abs()) <= ext[0] + MARGIN {
                body[i] = Body::Rigid(0);
            } else if truth.rigid[1].to_body(t0, p).norm() <= ext[1] + MARGIN {
                body[i] = Body::Rigid(1);
            } else if truth.rigid[2].to_body(t0, p).norm() <= ext[2] + MARGIN {
                body[i] = Body::Rigid(2);
            } else if let Some((s, w)) = truth.flag.coords(p, t0, MARGIN) {
                body[i] = Body::Flag;
                flag[i] = ((s, w), p - truth.flag.point(s, w, t0));
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

    /// Every Gaussian's true state at `t`, into `out`.
    fn states(&self, t: f64, out: &mut Vec<State>) {
        let carries = self.truth.rigid.each_ref().map(|r| r.carry(self.t0, t));
        out.clear();
        out.extend(self.body.iter().enumerate().map(|(i, b)| match *b {
            Body::Static => (self.p0[i], self.q0[i]),
            Body::Rigid(k) => (
                carries[k].apply(self.p0[i]),
                carries[k].rel.mul_quat(self.q0[i]),
            ),
            Body::Flag => {
                let ((s, w), off) = self.flag[i];
                (self.truth.flag.point(s, w, t) + off, self.q0[i])
            }
        }));
    }

    fn weight(&self, i: usize, static_weight: f64) -> f64 {
        if self.body[i] == Body::Static {
            static_weight
        } else {
            1.0
        }
    }
}

/// Buffers reused by every step of a fit.
struct Workspace {
    stepper: Option<Stepper<f32>>,
    out: Splats<f32>,
    d: SplatsGrad<f32>,
    grad: ModelGrad<f32>,
    /// True states at the step's time and `VELOCITY_EPS` before and after it.
    now: Vec<State>,
    before: Vec<State>,
    after: Vec<State>,
    pos: Vec<f32>,
    field_out: Vec<f32>,
    d_out: Vec<f32>,
    d_pos: Vec<f32>,
    g: Vec<f32>,
}

impl Workspace {
    fn new(model: &Model<f32>) -> Self {
        let n = model.len();
        Self {
            stepper: None,
            out: Splats::default(),
            d: model.zero_grad().canonical,
            grad: model.zero_grad(),
            now: Vec::with_capacity(n),
            before: Vec::with_capacity(n),
            after: Vec::with_capacity(n),
            pos: vec![0.0; 3 * n],
            field_out: vec![0.0; 9 * n],
            d_out: vec![0.0; 9 * n],
            d_pos: vec![0.0; 3 * n],
            g: vec![0.0; model.field.params().len()],
        }
    }
}

/// Prints the position error per body over [`REPORT_TIMES`] evenly spaced times.
fn report(model: &mut Model<f32>, oracle: &Oracle, ws: &mut Workspace, it: usize) {
    let mut all: [Vec<f64>; 5] = Default::default();
    for k in 0..REPORT_TIMES {
        #[allow(clippy::cast_precision_loss, reason = "small counts")]
        let t = (k as f64 + 0.5) / REPORT_TIMES as f64;
        model.splats_at(t, &mut ws.stepper, &mut ws.out);
        oracle.states(t, &mut ws.now);
        for (i, m) in ws.out.means.iter().enumerate() {
            all[group(oracle.body[i])].push((m.cast() - ws.now[i].0).norm());
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

/// One step of the trajectory fit at `t`, through the stepper and the discrete adjoint; the
/// field's gradient lands in `ws.grad.field`.
fn trajectory_step(
    model: &mut Model<f32>,
    oracle: &Oracle,
    t: f64,
    static_weight: f64,
    ws: &mut Workspace,
) {
    #[allow(clippy::cast_precision_loss, reason = "a count")]
    let inv_n = 1.0 / model.len() as f64;
    let tape = model.splats_at(t, &mut ws.stepper, &mut ws.out);
    oracle.states(t, &mut ws.now);
    for (i, &(p, q)) in ws.now.iter().enumerate() {
        let w = 2.0 * oracle.weight(i, static_weight) * inv_n;
        ws.d.means[i] = ((ws.out.means[i].cast() - p) * w).cast();
        let qm: Quat<f64> = ws.out.quats[i].cast();
        let q = if qm.dot(q) < 0.0 { -q } else { q };
        ws.d.quats[i] = (qm - q).scale(w).cast();
        let ds = ws.out.log_scales[i].cast() - model.canonical.log_scales[i].cast();
        ws.d.log_scales[i] = (ds * w).cast();
    }
    ws.grad.fill_zero();
    model.backward_at(&tape, &mut ws.stepper, &ws.d, &mut ws.grad);
}

/// One step of the velocity regression at `t`, at the Gaussians' true positions (the true
/// velocity is a central difference, one-sided at the ends of `[0, 1]`); the field's gradient
/// lands in `ws.g`.
fn velocity_step(
    model: &mut Model<f32>,
    oracle: &Oracle,
    t: f64,
    static_weight: f64,
    ws: &mut Workspace,
) {
    let n = model.len();
    #[allow(clippy::cast_precision_loss, reason = "a count")]
    let inv_n = 1.0 / n as f64;
    let (a, b) = ((t - VELOCITY_EPS).max(0.0), (t + VELOCITY_EPS).min(1.0));
    oracle.states(t, &mut ws.now);
    oracle.states(a, &mut ws.before);
    oracle.states(b, &mut ws.after);
    for (i, s) in ws.now.iter().enumerate() {
        s.0.cast::<f32>().write_to(&mut ws.pos[3 * i..]);
    }
    #[allow(clippy::cast_possible_truncation, reason = "the field runs in f32")]
    let t32 = t as f32;
    model.field.set_count(n);
    model
        .field
        .eval_batch(t32, &ws.pos, 3, n, &mut ws.field_out);
    for i in 0..n {
        let v = (ws.after[i].0 - ws.before[i].0) * (1.0 / (b - a));
        let e = Vec3::<f32>::from_slice(&ws.field_out[9 * i..]).cast() - v;
        (e * (2.0 * oracle.weight(i, static_weight) * inv_n))
            .cast::<f32>()
            .write_to(&mut ws.d_out[9 * i..]);
    }
    ws.g.fill(0.0);
    model
        .field
        .vjp_batch(t32, &ws.pos, 3, n, &ws.d_out, &mut ws.d_pos, 3, &mut ws.g);
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
    let (_, mut tr) = stored_run::load(&run);
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
    let mut ws = Workspace::new(model);
    for k in 1..model.anchor_times.len() {
        oracle.states(model.anchor_times[k], &mut ws.now);
        let a = &mut model.anchors[k - 1];
        for (i, &(p, q)) in ws.now.iter().enumerate() {
            a.means[i] = p.cast();
            a.quats[i] = q.cast();
        }
    }
    model.dynamics_active = true;
    let o = &tr.cfg.optim;
    let mut adam = FieldAdam::new(
        &model.field,
        o.grid_lr_init * tr.extent * lr_mult,
        o.deformation_lr_init * tr.extent * lr_mult,
    );
    let mut rng = SplitMix64::new(7);
    report(model, &oracle, &mut ws, 0);
    for it in 1..=iters {
        let t = rng.uniform(0.0, 1.0);
        #[allow(clippy::cast_precision_loss, reason = "small counts")]
        let decay = 0.01f64.powf(it as f64 / iters as f64);
        if trajectory {
            trajectory_step(model, &oracle, t, static_weight, &mut ws);
            adam.step(&mut model.field, &ws.grad.field, decay);
        } else {
            velocity_step(model, &oracle, t, static_weight, &mut ws);
            adam.step(&mut model.field, &ws.g, decay);
        }
        if it.is_multiple_of(500) || it == iters {
            report(model, &oracle, &mut ws, it);
        }
    }
    model.max_step = run_step;
    checkpoint::save(&tr, &run.checkpoint()).expect("write the checkpoint");
    println!("wrote {}", run.checkpoint().display());
}
