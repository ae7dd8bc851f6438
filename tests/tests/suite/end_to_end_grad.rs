//! The end-to-end gradient of one training step — loss(render(integrate(field))) with every
//! loss term (L1 + D-SSIM, plane regularisers, velocity coherence, anchor loss) — against
//! central differences in f64 on a small random scene, for velocity motion with trainable
//! anchors: every parameter group (canonical Gaussians, anchor 1, field), sampled entries.

use evogs::model::Motion;
use evogs_verify::check::grad::model::{SAMPLES, training_step_rows};

#[test]
fn training_step_gradient_of_every_parameter_group() {
    let (losses, rows) = training_step_rows(Motion::Velocity, 21, SAMPLES);
    assert!(
        losses.planes > 0.0 && losses.coherence > 0.0 && losses.anchor > 0.0,
        "every loss term is active: {losses:?}"
    );
    let groups: Vec<&str> = rows.iter().map(|r| r.group.as_str()).collect();
    for g in [
        "canonical means",
        "canonical log-scales",
        "canonical quaternions",
        "opacity logits",
        "SH coefficients",
        "anchor 1 means",
        "anchor 1 log-scales",
        "anchor 1 quaternions",
        "field parameters",
    ] {
        assert!(
            groups.iter().any(|x| x.ends_with(g)),
            "group {g} checked: {groups:?}"
        );
    }
    for r in &rows {
        println!(
            "{:<60} {:>4} entries  max abs {:.2e}  max rel {:.2e}",
            r.group, r.entries, r.max_abs, r.max_rel
        );
        assert!(r.passed, "{r:?}");
    }
}

#[test]
fn check_grad_passes_every_group() {
    // The `evogs check-grad` table with sampled model entries (every entry in the command).
    let table = evogs_verify::check::grad::check_grad(SAMPLES);
    println!("{table}");
    assert!(table.rows.len() >= 30, "groups: {}", table.rows.len());
    assert!(table.passed(), "{table}");
}
