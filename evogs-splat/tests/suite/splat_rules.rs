//! The compositing rules of `raster_ref`: the σ cutoff shortcut never changes a decision,
//! and the thresholds behave as documented.

use evogs_math::rng::SplitMix64;
use evogs_math::{Real, Vec2};
use evogs_splat::raster_ref::{ALPHA_MAX, ALPHA_MIN, should_stop, sigma_cutoff};
use evogs_splat::{splat_alpha, splat_alpha_cut};

/// Pairs (opacity, σ) concentrated around the α = 1/255 boundary, evaluated at a pixel with
/// `dx = sqrt(2σ)` under a unit conic.
fn agree<T: Real>(seed: u64, n: usize) -> usize {
    let mut rng = SplitMix64::new(seed);
    let mut near = 0;
    for _ in 0..n {
        let o = if rng.next_f64() < 0.1 {
            rng.uniform(0.0, 0.005)
        } else {
            rng.uniform(0.003, 1.0)
        };
        let boundary = (255.0 * o).ln();
        let sigma = (boundary + rng.uniform(-2e-3, 2e-3) * rng.next_f64().powi(4)).max(0.0);
        let dx = T::from_f64((2.0 * sigma).sqrt());
        let (m, conic, op) = (
            Vec2::new(dx, T::ZERO),
            [T::ONE, T::ZERO, T::ONE],
            T::from_f64(o),
        );
        let a = splat_alpha(m, conic, op, T::ZERO, T::ZERO);
        let b = splat_alpha_cut(m, conic, op, sigma_cutoff(op), T::ZERO, T::ZERO);
        assert!(
            a == b,
            "cutoff changed a decision at o = {o}, σ = {sigma}: {a:?} vs {b:?}"
        );
        near += usize::from((sigma - boundary).abs() < 1e-4);
    }
    near
}

#[test]
fn sigma_cutoff_never_changes_a_decision() {
    let near32 = agree::<f32>(1, 200_000);
    let near64 = agree::<f64>(2, 200_000);
    assert!(
        near32 > 1000 && near64 > 1000,
        "samples straddle the threshold"
    );
}

#[test]
fn thresholds_are_as_documented() {
    let m = Vec2::new(0.0, 0.0);
    let c = [1.0, 0.0, 1.0];
    // α clamps at 0.999 and reports it.
    let hit = splat_alpha(m, c, 0.9999, 0.0, 0.0).expect("opaque");
    assert!(
        hit.clamped && (hit.alpha - ALPHA_MAX).abs() < 1e-15,
        "clamp"
    );
    // Exactly at the threshold the Gaussian is kept (α ≥ 1/255), just below it is skipped.
    assert!(
        splat_alpha(m, c, ALPHA_MIN, 0.0, 0.0).is_some(),
        "α = 1/255 kept"
    );
    assert!(
        splat_alpha(m, c, ALPHA_MIN * (1.0 - 1e-12), 0.0, 0.0).is_none(),
        "α < 1/255 skipped"
    );
    // σ < 0 (a non-PSD conic) is skipped.
    assert!(
        splat_alpha(Vec2::new(1.0, 0.0), [-1.0, 0.0, 1.0], 0.9, 0.0, 0.0).is_none(),
        "σ < 0"
    );
    // The stop is inclusive of 1e-4: next_T = 1e-4 stops.
    assert!(
        should_stop(1e-4_f64) && !should_stop(1.000_001e-4_f64),
        "T stop"
    );
}
