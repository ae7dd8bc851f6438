//! One full training step's gradient (photometric L1 + D-SSIM through render(integrate(field)),
//! plane regularisers, velocity coherence (its twist form with the twist velocity) and the
//! anchor loss) against central differences of
//! the same step's loss, in f64, for every parameter group (sampled entries), in velocity and
//! deformation motion. The scene and the per-group check live in
//! `evogs_cli::check::grad` (shared with `evogs check-grad` and the cross-crate tests).

use evogs_cli::check::grad::GradRow;
use evogs_cli::check::grad::model::{SAMPLES, training_step_rows, twist_training_step_rows};
use evogs_cli::model::Motion;
use evogs_cli::train::step::StepLosses;

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
fn twist_velocity_step_gradient_matches_central_differences() {
    assert_rows(Motion::Velocity, twist_training_step_rows(3, SAMPLES), 9);
}
