//! evogs-cli: the neural field's VJP, the model backward (velocity: ODE discrete adjoint
//! into anchors, canonical Gaussians and field; deformation: the displacement VJP), and one
//! full training step `loss(render(integrate(field)))` per parameter group, on the scene of
//! [`super::scene`]; with continuous waypoints the hop (velocity adjoint into the waypoint
//! displacement), the teacher loss and the whole step.
//!
//! Entries are sampled ([`SAMPLES`] per group, all of a smaller group); a group whose
//! analytic gradient is identically zero fails (the check could not see anything).

use super::scene::{
    GradScene, ParamGroup, batch_step_loss_and_grad, central_difference, continuous_grad_scene,
    grad_scene, param_groups, sample_entries, second_view, teacher_sample,
};
use super::{GradRow, check_fn, uniform};
use core::cell::RefCell;
use evogs::model::{HopLaw, HopRender, HopStart, Model, ModelGrad, Motion};
use evogs::train::step::{StepLosses, ViewData};
use evogs_math::diff::{GradCheck, GradReport};
use evogs_math::rng::SplitMix64;
use evogs_ode::VectorField;
use evogs_splat::Splats;

/// Entries checked per parameter group by the tests (`evogs check-grad` checks every entry).
pub const SAMPLES: usize = 40;
/// Tolerance of the model checks (losses that sum many pixels: `ε^{2/3}|L|` is larger).
pub const MODEL_TOL: GradCheck = GradCheck::new(1e-8, 1e-5);

fn with_nonzero(mut row: GradRow, analytic_nonzero: bool) -> GradRow {
    row.passed &= analytic_nonzero;
    row
}

/// Positions and every parameter of the scene's field, through `eval`/`vjp` on Gaussian
/// states (positions inside the field's box).
fn neural_field_row() -> GradRow {
    let mut f = grad_scene(Motion::Velocity, 11).model.field;
    let mut rng = SplitMix64::new(11);
    let n = 5;
    f.set_count(n);
    let np = f.n_params();
    let mut x: Vec<f64> = (0..n)
        .flat_map(|_| {
            [
                rng.uniform(-0.7, 0.7),
                rng.uniform(-0.7, 0.7),
                rng.uniform(-0.7, 0.7),
            ]
        })
        .collect();
    x.extend_from_slice(f.params());
    let state = |p: &[f64]| -> Vec<f64> {
        p.chunks(3)
            .flat_map(|c| [c[0], c[1], c[2], 1.0, 0.0, 0.0, 0.0, -3.0, -3.0, -3.0])
            .collect()
    };
    let t = 0.37;
    let field = RefCell::new(f);
    let rep = check_fn(
        MODEL_TOL,
        &x,
        9 * n,
        &mut |v, out| {
            let mut f = field.borrow_mut();
            f.params_mut().copy_from_slice(&v[3 * n..]);
            f.eval(t, &state(&v[..3 * n]), out);
        },
        &mut |v, w, d| {
            let mut f = field.borrow_mut();
            f.params_mut().copy_from_slice(&v[3 * n..]);
            let mut d_y = vec![0.0; 9 * n];
            let mut d_p = vec![0.0; np];
            f.vjp(t, &state(&v[..3 * n]), w, &mut d_y, &mut d_p);
            for i in 0..n {
                d[3 * i..3 * i + 3].copy_from_slice(&d_y[9 * i..9 * i + 3]);
            }
            d[3 * n..].copy_from_slice(&d_p);
        },
        21,
    );
    GradRow::from_reports("cli: neural field vjp (positions, all params)", &[rep], &[])
}

/// `L = Σ_t ⟨W_t, Gaussians(t)⟩` for random `W_t`: the model backward alone.
fn linear_loss(model: &mut Model<f64>, times: &[f64], w: &[Vec<f64>]) -> f64 {
    let mut out = Splats::default();
    let mut st = None;
    let mut flat = Vec::new();
    let mut l = 0.0;
    for (&t, w) in times.iter().zip(w) {
        model.splats_at(t, &mut st, &mut out);
        out.write_flat(&mut flat);
        l += super::dot(&flat, w);
    }
    l
}

/// The model backward of `L = Σ_t ⟨W_t, Gaussians(t)⟩` at `times` (random `W_t`), checked
/// against central differences in every parameter group: one row named `label`.
fn backward_row(
    mut model: Model<f64>,
    times: &[f64],
    seed: u64,
    samples: usize,
    label: &str,
) -> GradRow {
    let mut rng = SplitMix64::new(seed ^ 0x5eed);
    let mut st = None;
    let mut out = Splats::default();
    let mut grad = model.zero_grad();
    let mut ws = Vec::new();
    for &t in times {
        let tape = model.splats_at(t, &mut st, &mut out);
        let w = uniform(&mut rng, out.flat_len(), -1.0, 1.0);
        let mut d = out.zeros_like();
        d.read_flat(&w);
        model.backward_at(&tape, &mut st, &d, &mut grad);
        ws.push(w);
    }
    let (reports, nonzero) = groups(&mut model, &grad, samples, &mut rng, &mut |m| {
        linear_loss(m, times, &ws)
    })
    .into_iter()
    .fold((Vec::new(), true), |(mut r, nz), (_, rep, z)| {
        r.push(rep);
        (r, nz && z)
    });
    with_nonzero(GradRow::from_reports(label, &reports, &[]), nonzero)
}

/// The model backward at two times, one integrated from the canonical state (t = 0.3) and
/// one from anchor 1 (t = 0.7), so that every parameter group has a gradient.
fn model_backward_row(motion: Motion, seed: u64, samples: usize) -> GradRow {
    backward_row(
        grad_scene(motion, seed).model,
        &[0.3, 0.7],
        seed,
        samples,
        &format!("cli: {} model backward (all groups)", name(motion)),
    )
}

/// The model backward with continuous waypoints at times before the window (from its
/// start), inside it (hops from both sides, near either end) and after it (from its end), so
/// that every path of [`Model::splats_at`] is differentiated.
#[must_use]
pub fn continuous_backward_row(
    render: HopRender,
    law: HopLaw,
    seed: u64,
    samples: usize,
) -> GradRow {
    backward_row(
        continuous_grad_scene(render, law, HopStart::Before, seed).model,
        &[-0.15, 0.1, 0.45, 0.95, 1.25],
        seed,
        samples,
        &format!(
            "cli: continuous waypoints ({}, {}) model backward (all groups)",
            render_name(render),
            law_name(law)
        ),
    )
}

/// The teacher loss alone against central differences in the velocity field's parameters
/// (the waypoint states are held fixed, so its gradient there and in the Gaussians is zero).
#[must_use]
pub fn teacher_row(law: HopLaw, seed: u64, samples: usize) -> GradRow {
    let GradScene { mut model, .. } =
        continuous_grad_scene(HopRender::Hop, law, HopStart::Before, seed);
    let teacher = teacher_sample();
    let mut loss = |m: &mut Model<f64>| {
        let mut g = m.zero_grad();
        m.teacher_loss(teacher.window, &teacher.indices, teacher.weight, &mut g)
    };
    let mut grad = model.zero_grad();
    let value = model.teacher_loss(teacher.window, &teacher.indices, teacher.weight, &mut grad);
    let held_fixed = grad.waypoint_field.iter().all(|&v| v == 0.0)
        && grad.canonical.means.iter().all(|v| v.norm_squared() == 0.0);
    let mut rng = SplitMix64::new(seed ^ 0x7eac);
    let field = param_groups(&model)
        .into_iter()
        .find(|g| g.name == "field parameters")
        .expect("a field group");
    let picks = sample_entries(field.len, samples, &mut rng);
    let analytic: Vec<f64> = picks.iter().map(|&i| (field.read)(&grad, i)).collect();
    let numeric: Vec<f64> = picks
        .iter()
        .map(|&i| central_difference(&mut model, &field, i, &mut loss))
        .collect();
    let nonzero = value > 0.0 && analytic.iter().any(|v| v.abs() > 1e-9);
    with_nonzero(
        GradRow::from_reports(
            &format!("cli: teacher loss ({}, the field)", law_name(law)),
            &[MODEL_TOL.check(&analytic, &numeric)],
            &[],
        ),
        nonzero && held_fixed,
    )
}

/// One training step with continuous waypoints (photometric and both fields' plane
/// regularisers; the teacher is checked by [`teacher_row`]) per parameter group, the view
/// hopping from `side`.
#[must_use]
pub fn continuous_step_rows(
    render: HopRender,
    law: HopLaw,
    side: HopStart,
    seed: u64,
    samples: usize,
) -> (StepLosses, Vec<GradRow>) {
    let label = format!(
        "continuous waypoints, {}, {}, hop {}",
        render_name(render),
        law_name(law),
        match side {
            HopStart::Before => "from before",
            HopStart::After => "from after",
        }
    );
    step_rows(
        continuous_grad_scene(render, law, side, seed),
        None,
        &label,
        seed,
        samples,
    )
}

fn law_name(law: HopLaw) -> &'static str {
    match law {
        HopLaw::FirstOrder => "first order",
        HopLaw::SecondOrder => "second order",
    }
}

fn render_name(render: HopRender) -> &'static str {
    match render {
        HopRender::Hop => "render the hop",
        HopRender::Direct => "render the waypoint",
    }
}

fn name(motion: Motion) -> &'static str {
    match motion {
        Motion::Velocity => "velocity",
        Motion::Deformation => "deformation",
        Motion::Static => "static",
    }
}

/// Central differences of `loss` against `grad` for sampled entries of every group:
/// `(group, report, analytic not identically zero)`.
fn groups(
    model: &mut Model<f64>,
    grad: &ModelGrad<f64>,
    samples: usize,
    rng: &mut SplitMix64,
    loss: &mut dyn FnMut(&mut Model<f64>) -> f64,
) -> Vec<(ParamGroup, GradReport, bool)> {
    param_groups(model)
        .into_iter()
        .map(|g| {
            let picks = sample_entries(g.len, samples, rng);
            let analytic: Vec<f64> = picks.iter().map(|&i| (g.read)(grad, i)).collect();
            let numeric: Vec<f64> = picks
                .iter()
                .map(|&i| central_difference(model, &g, i, loss))
                .collect();
            let nonzero = analytic.iter().any(|v| v.abs() > 1e-9);
            (g, MODEL_TOL.check(&analytic, &numeric), nonzero)
        })
        .collect()
}

/// One training step (every loss term) per parameter group: the end-to-end check of
/// `loss(render(integrate(field)))` on [`grad_scene`]`(motion, seed)`, `samples` entries per
/// group (all of a smaller group). Returns the step's loss terms and one row per group.
#[must_use]
pub fn training_step_rows(motion: Motion, seed: u64, samples: usize) -> (StepLosses, Vec<GradRow>) {
    step_rows(grad_scene(motion, seed), None, name(motion), seed, samples)
}

/// [`training_step_rows`] in velocity motion on a batch of two views (the scene's view at
/// t = 0.7 and [`second_view`] at t = 0.3, in another segment): the mean of their
/// photometric terms plus the regularisers once.
#[must_use]
pub fn batch_training_step_rows(seed: u64, samples: usize) -> (StepLosses, Vec<GradRow>) {
    let scene = grad_scene(Motion::Velocity, seed);
    let second = second_view(seed);
    step_rows(scene, Some(second), "velocity, two views", seed, samples)
}

fn step_rows(
    scene: GradScene,
    second: Option<ViewData<f64>>,
    label: &str,
    seed: u64,
    samples: usize,
) -> (StepLosses, Vec<GradRow>) {
    let GradScene {
        mut model,
        view,
        settings,
    } = scene;
    let views: Vec<&ViewData<f64>> = core::iter::once(&view).chain(second.as_ref()).collect();
    let (losses, grad) = batch_step_loss_and_grad(&mut model, &views, &settings);
    let mut rng = SplitMix64::new(seed + 100);
    let rows = groups(&mut model, &grad, samples, &mut rng, &mut |m| {
        batch_step_loss_and_grad(m, &views, &settings).0.total
    })
    .into_iter()
    .map(|(g, rep, nonzero)| {
        with_nonzero(
            GradRow::from_reports(
                &format!("cli: training step ({label}): {}", g.name),
                &[rep],
                &[],
            ),
            nonzero,
        )
    })
    .collect();
    (losses, rows)
}

/// The cli rows with `samples` entries per parameter group.
pub(super) fn rows(samples: usize) -> Vec<GradRow> {
    let mut rows = vec![
        neural_field_row(),
        model_backward_row(Motion::Velocity, 3, samples),
        model_backward_row(Motion::Deformation, 5, samples),
    ];
    rows.extend(training_step_rows(Motion::Velocity, 3, samples).1);
    rows.extend(training_step_rows(Motion::Deformation, 5, samples).1);
    rows.extend(batch_training_step_rows(11, samples).1);
    for law in [HopLaw::FirstOrder, HopLaw::SecondOrder] {
        rows.push(continuous_backward_row(HopRender::Hop, law, 13, samples));
        rows.push(continuous_backward_row(HopRender::Direct, law, 17, samples));
        rows.push(teacher_row(law, 19, samples));
        rows.extend(continuous_step_rows(HopRender::Hop, law, HopStart::After, 23, samples).1);
        rows.extend(continuous_step_rows(HopRender::Direct, law, HopStart::Before, 29, samples).1);
    }
    rows
}
