//! One full training step's gradient (photometric L1 + D-SSIM through render(integrate(field)),
//! plane regularisers, velocity coherence and the anchor loss) against central differences of
//! the same step's loss, in f64, for every parameter group (sampled entries), in velocity and
//! deformation motion.

use evogs_cli::field::regularize::PlaneRegWeights;
use evogs_cli::field::{HexPlaneConfig, NeuralField, NeuralFieldConfig, TimeMapping};
use evogs_cli::model::{Model, ModelGrad, Motion, Waypoints};
use evogs_cli::train::step::{
    StepSettings, StepWorkspace, ViewData, loss_and_grad, render_options,
};
use evogs_math::Par;
use evogs_math::activation::logit;
use evogs_math::diff::GradCheck;
use evogs_math::rng::SplitMix64;
use evogs_math::{Quat, Vec3};
use evogs_ode::Method;
use evogs_splat::{Image, PinholeCamera, Splats};

const SIZE: usize = 20;

fn scene(motion: Motion, seed: u64) -> (Model<f64>, ViewData<f64>, StepSettings) {
    let mut rng = SplitMix64::new(seed);
    let mut splats = Splats::new(1);
    for _ in 0..10 {
        let mean = Vec3::new(
            rng.uniform(-0.4, 0.4),
            rng.uniform(-0.4, 0.4),
            rng.uniform(-0.4, 0.4),
        );
        let ls = Vec3::new(
            rng.uniform(-2.6, -2.0),
            rng.uniform(-2.6, -2.0),
            rng.uniform(-2.6, -2.0),
        );
        let q = Quat::new(rng.normal(), rng.normal(), rng.normal(), rng.normal());
        let sh = [
            [
                rng.uniform(0.2, 1.2),
                rng.uniform(0.2, 1.2),
                rng.uniform(0.2, 1.2),
            ],
            [0.1, -0.1, 0.05],
            [0.0, 0.1, -0.05],
            [0.05, 0.0, 0.1],
        ];
        splats.push(mean, ls, q, logit(rng.uniform(0.3, 0.7)), &sh);
    }
    let cfg = NeuralFieldConfig {
        hexplane: HexPlaneConfig {
            channels: 2,
            resolution: [4, 4, 4, 3],
            multires: vec![1],
        },
        width: 6,
        output_scales: [1.0, 1.0, 0.5],
    };
    let mut field = NeuralField::new(
        &cfg,
        [-0.8; 3],
        [0.8; 3],
        TimeMapping::Normalized {
            t_min: 0.0,
            t_max: 1.0,
        },
        seed,
    );
    for v in field.params_mut() {
        *v += rng.uniform(-0.3, 0.3);
    }
    let coherence_points: Vec<[f64; 3]> = [0, 2, 3, 5, 7, 8]
        .iter()
        .map(|&i: &usize| splats.means[i].to_array())
        .collect();
    let mut model = Model::new(
        splats,
        field,
        motion,
        Waypoints::Trainable,
        Method::Rk4,
        0.125,
        vec![0.0, 0.5, 1.0],
    );
    model.dynamics_active = true;
    let mut st = None;
    model.refresh_anchors_from_start(&mut st);
    for a in &mut model.anchors {
        for m in a.means.iter_mut().chain(a.log_scales.iter_mut()) {
            *m += Vec3::new(
                rng.uniform(-0.02, 0.02),
                rng.uniform(-0.02, 0.02),
                rng.uniform(-0.02, 0.02),
            );
        }
        for q in &mut a.quats {
            *q = evogs_math::update::exp_update_left(
                *q,
                Vec3::new(rng.normal(), rng.normal(), rng.normal()),
                0.02,
            );
        }
    }
    let camera = PinholeCamera::look_at(
        Vec3::new(0.3, -0.2, 2.5),
        Vec3::zero(),
        Vec3::new(0.0, 1.0, 0.0),
        0.9,
        SIZE,
        SIZE,
    )
    .expect("camera");
    let mut image = Image::new(SIZE, SIZE);
    for v in image.data_mut() {
        *v = rng.uniform(0.0, 1.0);
    }
    let settings = StepSettings {
        lambda_ssim: 0.2,
        plane_reg: PlaneRegWeights {
            plane_tv: 1e-2,
            time_smoothness: 1e-2,
            l1_time: 1e-3,
        },
        lambda_coherence: 0.05,
        lambda_anchor: 0.7,
        anchor_segment: Some(0),
        coherence_points,
    };
    (
        model,
        ViewData {
            camera,
            time: 0.7,
            image,
        },
        settings,
    )
}

fn loss(model: &mut Model<f64>, view: &ViewData<f64>, s: &StepSettings) -> f64 {
    let mut ws = StepWorkspace::default();
    let mut g = model.zero_grad();
    loss_and_grad(
        model,
        view,
        &render_options([1.0, 1.0, 1.0], 1, Par::Seq),
        s,
        &mut ws,
        &mut g,
    )
    .0
    .total
}

/// A parameter slot: (group name, getter/setter through a closure on the model).
type Slot = (
    &'static str,
    fn(&mut Model<f64>, usize) -> &mut f64,
    fn(&ModelGrad<f64>, usize) -> f64,
    usize,
);

fn slots(n: usize, n_field: usize) -> Vec<Slot> {
    vec![
        (
            "canonical means",
            |m, i| &mut m.canonical.means[i / 3][i % 3],
            |g, i| g.canonical.means[i / 3][i % 3],
            3 * n,
        ),
        (
            "canonical log-scales",
            |m, i| &mut m.canonical.log_scales[i / 3][i % 3],
            |g, i| g.canonical.log_scales[i / 3][i % 3],
            3 * n,
        ),
        (
            "canonical quaternions",
            |m, i| {
                let q = &mut m.canonical.quats[i / 4];
                match i % 4 {
                    0 => &mut q.w,
                    1 => &mut q.x,
                    2 => &mut q.y,
                    _ => &mut q.z,
                }
            },
            |g, i| g.canonical.quats[i / 4].to_array()[i % 4],
            4 * n,
        ),
        (
            "opacity logits",
            |m, i| &mut m.canonical.opacity_logits[i],
            |g, i| g.canonical.opacity_logits[i],
            n,
        ),
        (
            "SH coefficients",
            |m, i| &mut m.canonical.sh[i / 3][i % 3],
            |g, i| g.canonical.sh[i / 3][i % 3],
            3 * 4 * n,
        ),
        (
            "anchor 1 means",
            |m, i| &mut m.anchors[0].means[i / 3][i % 3],
            |g, i| g.anchors[0].means[i / 3][i % 3],
            3 * n,
        ),
        (
            "anchor 1 log-scales",
            |m, i| &mut m.anchors[0].log_scales[i / 3][i % 3],
            |g, i| g.anchors[0].log_scales[i / 3][i % 3],
            3 * n,
        ),
        (
            "anchor 1 quaternions",
            |m, i| {
                let q = &mut m.anchors[0].quats[i / 4];
                match i % 4 {
                    0 => &mut q.w,
                    1 => &mut q.x,
                    2 => &mut q.y,
                    _ => &mut q.z,
                }
            },
            |g, i| g.anchors[0].quats[i / 4].to_array()[i % 4],
            4 * n,
        ),
        (
            "field parameters",
            |m, i| &mut m.field.params_mut()[i],
            |g, i| g.field[i],
            n_field,
        ),
    ]
}

fn check(motion: Motion, seed: u64) {
    let (mut model, view, s) = scene(motion, seed);
    let mut ws = StepWorkspace::default();
    let mut grad = model.zero_grad();
    let (losses, _) = loss_and_grad(
        &mut model,
        &view,
        &render_options([1.0, 1.0, 1.0], 1, Par::Seq),
        &s,
        &mut ws,
        &mut grad,
    );
    assert!(
        losses.planes > 0.0 && (motion != Motion::Velocity || losses.coherence > 0.0),
        "every term is active: {losses:?}"
    );
    if motion == Motion::Velocity {
        assert!(losses.anchor > 0.0, "anchor term active");
    }
    let n = model.len();
    let n_field = model.field.params().len();
    let mut rng = SplitMix64::new(seed + 100);
    for (name, get, read, len) in slots(n, n_field) {
        if motion == Motion::Deformation && name.starts_with("anchor") {
            continue;
        }
        // Sampled entries (all of them for small groups).
        let picks: Vec<usize> = if len <= 40 {
            (0..len).collect()
        } else {
            (0..40).map(|_| rng.below(len)).collect()
        };
        let mut analytic = Vec::new();
        let mut numeric = Vec::new();
        for &i in &picks {
            let x0 = *get(&mut model, i);
            let h = 1e-6 * x0.abs().max(1.0);
            *get(&mut model, i) = x0 + h;
            let lp = loss(&mut model, &view, &s);
            *get(&mut model, i) = x0 - h;
            let lm = loss(&mut model, &view, &s);
            *get(&mut model, i) = x0;
            numeric.push((lp - lm) / (2.0 * h));
            analytic.push(read(&grad, i));
        }
        let rep = GradCheck::new(1e-8, 1e-5).check(&analytic, &numeric);
        println!("{motion:?} {name}: {rep}");
        rep.assert_passed(name);
        assert!(
            analytic.iter().any(|v| v.abs() > 1e-9),
            "{name}: gradient is not identically zero"
        );
    }
}

#[test]
fn velocity_step_gradient_matches_central_differences() {
    check(Motion::Velocity, 3);
}

#[test]
fn deformation_step_gradient_matches_central_differences() {
    check(Motion::Deformation, 5);
}
