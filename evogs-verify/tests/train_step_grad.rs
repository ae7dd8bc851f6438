//! One full training step's gradient (photometric L1 + D-SSIM through render(integrate(field)),
//! plane regularisers, velocity coherence and the anchor loss) against central differences of
//! the same step's loss, in f64, for every parameter group (sampled entries), in velocity and
//! deformation motion, on a batch of two views, and with continuous waypoints (hops and the
//! teacher loss). The scene and the per-group check live in
//! `evogs_verify::check::grad` (shared with `evogs check-grad` and the cross-crate tests).

use evogs::model::{HopLaw, HopRender, HopStart, Motion};
use evogs::train::step::StepLosses;
use evogs_verify::check::grad::GradRow;
use evogs_verify::check::grad::model::{
    SAMPLES, batch_training_step_rows, continuous_backward_row, continuous_step_rows, teacher_row,
    training_step_rows,
};
use evogs_verify::check::grad::scene::{
    batch_step_loss_and_grad, continuous_grad_scene, grad_scene, param_groups, second_view,
    teacher_sample,
};

fn check(motion: Motion, seed: u64, groups: usize) {
    assert_rows(motion, training_step_rows(motion, seed, SAMPLES), groups);
}

fn assert_rows(motion: Motion, (losses, rows): (StepLosses, Vec<GradRow>), groups: usize) {
    assert!(
        losses.planes > 0.0 && (motion != Motion::Velocity || losses.coherence > 0.0),
        "every term is active: {losses:?}"
    );
    if motion == Motion::Velocity {
        assert!(losses.anchor > 0.0, "anchor term active");
    }
    assert_eq!(rows.len(), groups, "parameter groups checked");
    for r in &rows {
        println!(
            "{}: {} entries, max abs {:.2e}, max rel {:.2e}",
            r.group, r.entries, r.max_abs, r.max_rel
        );
        assert!(
            r.passed,
            "{} (or an identically zero gradient): {r:?}",
            r.group
        );
    }
}

#[test]
fn velocity_step_gradient_matches_central_differences() {
    check(Motion::Velocity, 3, 9);
}

#[test]
fn deformation_step_gradient_matches_central_differences() {
    check(Motion::Deformation, 5, 6);
}

#[test]
fn two_view_batch_gradient_matches_central_differences() {
    assert_rows(Motion::Velocity, batch_training_step_rows(11, SAMPLES), 9);
}

/// A batch's loss and gradient are the mean of its views' own photometric terms plus the regularisers once (at the first view's time), not the mean of two whole
/// steps.
#[test]
fn a_batch_averages_the_photometric_terms_and_counts_the_regularisers_once() {
    let mut scene = grad_scene(Motion::Velocity, 11);
    let second = second_view(11);
    let s = scene.settings.clone();
    let mut photo_only = s.clone();
    photo_only.plane_reg.plane_tv = 0.0;
    photo_only.plane_reg.time_smoothness = 0.0;
    photo_only.plane_reg.l1_time = 0.0;
    photo_only.lambda_coherence = 0.0;
    photo_only.anchor_segment = None;
    let m = &mut scene.model;
    let (l_batch, g_batch) = batch_step_loss_and_grad(m, &[&scene.view, &second], &s);
    let (l_one, g_one) = batch_step_loss_and_grad(m, &[&scene.view], &s);
    let (l_p1, g_p1) = batch_step_loss_and_grad(m, &[&scene.view], &photo_only);
    let (l_p2, g_p2) = batch_step_loss_and_grad(m, &[&second], &photo_only);
    let regs = l_one.planes + l_one.coherence + l_one.anchor;
    assert!(regs > 0.0 && l_p1.planes == 0.0 && l_p1.anchor == 0.0);
    assert!(
        (l_batch.planes - l_one.planes).abs() <= 1e-15
            && (l_batch.coherence - l_one.coherence).abs() <= 1e-15
            && (l_batch.anchor - l_one.anchor).abs() <= 1e-15,
        "regularisers once: {l_batch:?} vs {l_one:?}"
    );
    let want = 0.5 * (l_p1.total + l_p2.total) + regs;
    assert!(
        (l_batch.total - want).abs() <= 1e-12,
        "{} vs {want}",
        l_batch.total
    );
    assert!((l_batch.mse - 0.5 * (l_p1.mse + l_p2.mse)).abs() <= 1e-15);
    for g in param_groups(m) {
        for i in 0..g.len {
            // g_batch = ½·(photo₁ + photo₂) + regs, where regs = g_one − photo₁.
            let want = 0.5 * ((g.read)(&g_p1, i) + (g.read)(&g_p2, i))
                + ((g.read)(&g_one, i) - (g.read)(&g_p1, i));
            let got = (g.read)(&g_batch, i);
            assert!(
                (got - want).abs() <= 1e-12 * (1.0 + want.abs()),
                "{}[{i}]: {got} vs {want}",
                g.name
            );
        }
    }
}

fn assert_passed(rows: &[GradRow]) {
    for r in rows {
        println!(
            "{}: {} entries, max abs {:.2e}, max rel {:.2e}",
            r.group, r.entries, r.max_abs, r.max_rel
        );
        assert!(
            r.passed,
            "{} (or an identically zero gradient): {r:?}",
            r.group
        );
    }
}

/// Continuous waypoints: the hop (its velocity adjoint into the waypoint displacement) at
/// times before, inside and after the window, rendering the hop or the waypoint state.
#[test]
fn continuous_waypoint_backward_matches_central_differences() {
    for law in [HopLaw::FirstOrder, HopLaw::SecondOrder] {
        assert_passed(&[
            continuous_backward_row(HopRender::Hop, law, 13, SAMPLES),
            continuous_backward_row(HopRender::Direct, law, 17, SAMPLES),
        ]);
    }
}

/// The teacher loss moves the velocity field only, with the exact gradient.
#[test]
fn teacher_loss_gradient_matches_central_differences() {
    assert_passed(&[
        teacher_row(HopLaw::FirstOrder, 19, SAMPLES),
        teacher_row(HopLaw::SecondOrder, 19, SAMPLES),
    ]);
}

/// A whole training step with continuous waypoints (photometric and both fields' plane
/// regularisers), every parameter group: 5 canonical groups and 2 fields.
#[test]
fn continuous_waypoint_step_gradient_matches_central_differences() {
    for (render, law, side, seed) in [
        (HopRender::Hop, HopLaw::FirstOrder, HopStart::After, 23),
        (HopRender::Direct, HopLaw::FirstOrder, HopStart::Before, 29),
        (HopRender::Hop, HopLaw::SecondOrder, HopStart::Before, 31),
        (HopRender::Hop, HopLaw::SecondOrder, HopStart::After, 37),
    ] {
        let (losses, rows) = continuous_step_rows(render, law, side, seed, SAMPLES);
        assert!(losses.planes > 0.0, "every term is active: {losses:?}");
        assert_eq!(rows.len(), 7, "parameter groups checked");
        assert_passed(&rows);
    }
}

/// With a teacher the step's loss and gradient are the step's without it plus the teacher
/// loss and its gradient (checked on its own above), exactly.
#[test]
fn the_teacher_adds_its_own_loss_and_gradient_to_the_step() {
    let mut scene = continuous_grad_scene(HopRender::Hop, HopLaw::SecondOrder, HopStart::After, 23);
    let plain = scene.settings.clone();
    let mut taught = plain.clone();
    let t = teacher_sample();
    taught.teacher = Some(t.clone());
    let m = &mut scene.model;
    let (l_plain, g_plain) = batch_step_loss_and_grad(m, &[&scene.view], &plain);
    let (l_taught, g_taught) = batch_step_loss_and_grad(m, &[&scene.view], &taught);
    let mut g_teacher = m.zero_grad();
    let teacher = m.teacher_loss(t.window, &t.indices, t.weight, &mut g_teacher);
    assert!(teacher > 0.0 && l_plain.teacher == 0.0);
    assert_eq!(
        l_taught.teacher.to_bits(),
        teacher.to_bits(),
        "the same teacher loss"
    );
    assert!((l_taught.total - (l_plain.total + teacher)).abs() <= 1e-12);
    for g in param_groups(m) {
        for i in 0..g.len {
            let want = (g.read)(&g_plain, i) + (g.read)(&g_teacher, i);
            let got = (g.read)(&g_taught, i);
            assert!(
                (got - want).abs() <= 1e-12 * (1.0 + want.abs()),
                "{}[{i}]: {got} vs {want}",
                g.name
            );
        }
    }
}
