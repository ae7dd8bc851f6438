//! The small random f64 scene of the end-to-end gradient checks (shared by `evogs
//! check-grad`, the evogs-cli test `train_step_grad` and the cross-crate tests): ten
//! Gaussians with SH degree 1, a small HexPlane + MLP field, three anchor times with
//! perturbed trainable anchor states, a 20×20 view at `t = 0.7`, and every loss term on
//! (L1 + D-SSIM, plane regularisers, velocity coherence, anchor loss).
//!
//! [`param_groups`] names every trainable array of a [`Model`] with access to an entry and to
//! its gradient, so a check can perturb any parameter and read the matching gradient.

use evogs::field::regularize::PlaneRegWeights;
use evogs::field::{HexPlaneConfig, NeuralField, NeuralFieldConfig, TimeMapping};
use evogs::model::{
    HopLaw, HopRender, HopSettings, HopStart, Model, ModelGrad, Motion, Waypoints, render_options,
};
use evogs::train::batch::batch_loss_and_grad;
use evogs::train::step::{StepLosses, StepSettings, StepWorkspace, TeacherSample, ViewData};
use evogs_math::activation::logit;
use evogs_math::rng::SplitMix64;
use evogs_math::{Par, Quat, Vec3};
use evogs_ode::Method;
use evogs_splat::{Image, PinholeCamera, Splats};

/// Image size of the view.
pub const SIZE: usize = 20;

/// A model, one supervised view and the step settings.
#[derive(Debug)]
pub struct GradScene {
    /// The model (dynamics on).
    pub model: Model<f64>,
    /// The view (camera, time 0.7, random target image).
    pub view: ViewData<f64>,
    /// Loss weights; every term is active.
    pub settings: StepSettings,
}

fn random_splats(rng: &mut SplitMix64) -> Splats<f64> {
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
    splats
}

fn field(rng: &mut SplitMix64, seed: u64) -> NeuralField<f64> {
    let cfg = NeuralFieldConfig {
        hexplane: HexPlaneConfig {
            channels: 2,
            resolution: [4, 4, 4, 3],
            multires: vec![1],
        },
        width: 6,
        output_scales: [1.0, 1.0, 0.5],
        zero_init_output: false,
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
    field
}

/// The scene for `motion` (velocity: trainable anchors at 0, 0.5, 1; deformation: the same
/// model read as displacements).
///
/// # Panics
/// Never for the built-in camera.
#[must_use]
pub fn grad_scene(motion: Motion, seed: u64) -> GradScene {
    build(motion, seed)
}

fn build(motion: Motion, seed: u64) -> GradScene {
    let mut rng = SplitMix64::new(seed);
    let splats = random_splats(&mut rng);
    let field = field(&mut rng, seed);
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
    let view = random_view(Vec3::new(0.3, -0.2, 2.5), 0.7, &mut rng);
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
        hop_start: HopStart::Before,
        teacher: None,
    };
    GradScene {
        model,
        view,
        settings,
    }
}

/// The scene with continuous waypoints in velocity motion: a waypoint field of the same
/// shape (perturbed like the velocity field), window `[0, 1]`, hops of 0.2 in two steps of
/// 0.1 under `law` rendering `render`; the view at `t = 0.7` hops from the side `side` (0.5 or 0.9).
/// The settings have no teacher loss: it holds the waypoint states fixed, a stop-gradient
/// that central differences of the whole step cannot see, so it is checked on its own
/// ([`teacher_sample`]).
///
/// # Panics
/// Never for the built-in camera.
#[must_use]
pub fn continuous_grad_scene(
    render: HopRender,
    law: HopLaw,
    side: HopStart,
    seed: u64,
) -> GradScene {
    let mut rng = SplitMix64::new(seed);
    let splats = random_splats(&mut rng);
    let velocity = field(&mut rng, seed);
    let waypoint = field(&mut rng, seed ^ 0x0a1f);
    let mut model = Model::new(
        splats,
        velocity,
        Motion::Velocity,
        Waypoints::Continuous,
        Method::Rk4,
        0.1,
        vec![0.0],
    );
    model.waypoint_field = Some(waypoint);
    model.hop = HopSettings {
        window: (0.0, 1.0),
        length: 0.2,
        render,
        law,
    };
    model.dynamics_active = true;
    let view = random_view(Vec3::new(0.3, -0.2, 2.5), 0.7, &mut rng);
    let settings = StepSettings {
        lambda_ssim: 0.2,
        plane_reg: PlaneRegWeights {
            plane_tv: 1e-2,
            time_smoothness: 1e-2,
            l1_time: 1e-3,
        },
        lambda_coherence: 0.0,
        lambda_anchor: 0.0,
        anchor_segment: None,
        coherence_points: Vec::new(),
        hop_start: side,
        teacher: None,
    };
    GradScene {
        model,
        view,
        settings,
    }
}

/// A `SIZE`×`SIZE` view from `eye` looking at the origin, at time `t`, with a random target.
fn random_view(eye: Vec3<f64>, t: f64, rng: &mut SplitMix64) -> ViewData<f64> {
    let camera =
        PinholeCamera::look_at(eye, Vec3::zero(), Vec3::new(0.0, 1.0, 0.0), 0.9, SIZE, SIZE)
            .expect("camera");
    let mut image = Image::new(SIZE, SIZE);
    for v in image.data_mut() {
        *v = rng.uniform(0.0, 1.0);
    }
    ViewData {
        camera,
        time: t,
        image: image.into(),
    }
}

/// One training step's loss terms and gradient on `view` (white background, SH degree 1).
pub fn step_loss_and_grad(
    model: &mut Model<f64>,
    view: &ViewData<f64>,
    settings: &StepSettings,
) -> (StepLosses, ModelGrad<f64>) {
    batch_step_loss_and_grad(model, &[view], settings)
}

/// One training step's loss terms and gradient on a batch of views
/// ([`batch_loss_and_grad`]; white background, SH degree 1).
pub fn batch_step_loss_and_grad(
    model: &mut Model<f64>,
    views: &[&ViewData<f64>],
    settings: &StepSettings,
) -> (StepLosses, ModelGrad<f64>) {
    let mut ws = StepWorkspace::default();
    let mut g = model.zero_grad();
    let (l, _) = batch_loss_and_grad(
        model,
        views,
        &render_options([1.0, 1.0, 1.0], 1, Par::Seq),
        settings,
        &mut ws,
        &mut g,
    );
    (l, g)
}

/// A second view for batch checks: another camera, time 0.3 (the first segment, where
/// [`grad_scene`]'s view is in the second) and its own random target image.
///
/// # Panics
/// Never for the built-in camera.
#[must_use]
pub fn second_view(seed: u64) -> ViewData<f64> {
    random_view(
        Vec3::new(-0.6, 0.3, 2.3),
        0.3,
        &mut SplitMix64::new(seed ^ 0xba7c),
    )
}

impl GradScene {
    /// One training step's loss terms and gradient.
    pub fn loss_and_grad(&mut self) -> (StepLosses, ModelGrad<f64>) {
        step_loss_and_grad(&mut self.model, &self.view, &self.settings)
    }
}

/// A trainable array of a [`Model`]: its name, length, an entry and the entry's gradient.
#[derive(Clone, Copy, Debug)]
pub struct ParamGroup {
    /// Name (e.g. `canonical means`).
    pub name: &'static str,
    /// Number of scalars.
    pub len: usize,
    /// Entry `i` of the model.
    pub get: fn(&mut Model<f64>, usize) -> &mut f64,
    /// Entry `i` of a gradient.
    pub read: fn(&ModelGrad<f64>, usize) -> f64,
}

fn quat_entry(q: &mut Quat<f64>, k: usize) -> &mut f64 {
    match k {
        0 => &mut q.w,
        1 => &mut q.x,
        2 => &mut q.y,
        _ => &mut q.z,
    }
}

/// The teacher loss of the continuous-waypoint checks: over `[0.2, 0.6]`, four Gaussians.
#[must_use]
pub fn teacher_sample() -> TeacherSample {
    TeacherSample {
        window: (0.2, 0.6),
        indices: vec![0, 3, 4, 8],
        weight: 0.6,
    }
}

/// Every trainable array of `model` (anchor 1 only with velocity motion and anchors).
#[must_use]
pub fn param_groups(model: &Model<f64>) -> Vec<ParamGroup> {
    let n = model.len();
    let k = model.canonical.coeffs_per_gaussian();
    let mut g = vec![
        ParamGroup {
            name: "canonical means",
            len: 3 * n,
            get: |m, i| &mut m.canonical.means[i / 3][i % 3],
            read: |g, i| g.canonical.means[i / 3][i % 3],
        },
        ParamGroup {
            name: "canonical log-scales",
            len: 3 * n,
            get: |m, i| &mut m.canonical.log_scales[i / 3][i % 3],
            read: |g, i| g.canonical.log_scales[i / 3][i % 3],
        },
        ParamGroup {
            name: "canonical quaternions",
            len: 4 * n,
            get: |m, i| quat_entry(&mut m.canonical.quats[i / 4], i % 4),
            read: |g, i| g.canonical.quats[i / 4].to_array()[i % 4],
        },
        ParamGroup {
            name: "opacity logits",
            len: n,
            get: |m, i| &mut m.canonical.opacity_logits[i],
            read: |g, i| g.canonical.opacity_logits[i],
        },
        ParamGroup {
            name: "SH coefficients",
            len: 3 * k * n,
            get: |m, i| &mut m.canonical.sh[i / 3][i % 3],
            read: |g, i| g.canonical.sh[i / 3][i % 3],
        },
    ];
    if model.motion == Motion::Velocity && !model.anchors.is_empty() {
        g.extend([
            ParamGroup {
                name: "anchor 1 means",
                len: 3 * n,
                get: |m, i| &mut m.anchors[0].means[i / 3][i % 3],
                read: |g, i| g.anchors[0].means[i / 3][i % 3],
            },
            ParamGroup {
                name: "anchor 1 log-scales",
                len: 3 * n,
                get: |m, i| &mut m.anchors[0].log_scales[i / 3][i % 3],
                read: |g, i| g.anchors[0].log_scales[i / 3][i % 3],
            },
            ParamGroup {
                name: "anchor 1 quaternions",
                len: 4 * n,
                get: |m, i| quat_entry(&mut m.anchors[0].quats[i / 4], i % 4),
                read: |g, i| g.anchors[0].quats[i / 4].to_array()[i % 4],
            },
        ]);
    }
    g.push(ParamGroup {
        name: "field parameters",
        len: model.field.params().len(),
        get: |m, i| &mut m.field.params_mut()[i],
        read: |g, i| g.field[i],
    });
    if let Some(f) = &model.waypoint_field {
        g.push(ParamGroup {
            name: "waypoint field parameters",
            len: f.params().len(),
            get: |m, i| {
                &mut m
                    .waypoint_field
                    .as_mut()
                    .expect("a waypoint field")
                    .params_mut()[i]
            },
            read: |g, i| g.waypoint_field[i],
        });
    }
    g
}

/// The entries of a group to check: all of them up to `samples`, else `samples` random ones.
#[must_use]
pub fn sample_entries(len: usize, samples: usize, rng: &mut SplitMix64) -> Vec<usize> {
    if len <= samples {
        (0..len).collect()
    } else {
        (0..samples).map(|_| rng.below(len)).collect()
    }
}

/// Central differences `(L(x + h) − L(x − h))/2h`, `h = 1e-6·max(1, |x|)`, of a loss of the
/// model at entry `i` of `group`.
pub fn central_difference(
    model: &mut Model<f64>,
    group: &ParamGroup,
    i: usize,
    loss: &mut dyn FnMut(&mut Model<f64>) -> f64,
) -> f64 {
    let x0 = *(group.get)(model, i);
    let h = 1e-6 * x0.abs().max(1.0);
    *(group.get)(model, i) = x0 + h;
    let lp = loss(model);
    *(group.get)(model, i) = x0 - h;
    let lm = loss(model);
    *(group.get)(model, i) = x0;
    (lp - lm) / (2.0 * h)
}
