//! `evogs check-grad`: every VJP of the stack against central differences in f64, live.
//!
//! For a map `f: Rⁿ → Rᵐ`, a random cotangent `w` and inputs `x`, the analytic `Jᵀw` (the
//! VJP) is compared with central differences of `⟨w, f(x)⟩` (step `ε^{1/3}·max(1, |xᵢ|)`),
//! entry by entry: pass if `|a − n| ≤ abs + rel·max(|a|, |n|)` ([`GradCheck`]). Where the
//! kernel is generic over the scalar, the **dot-product test** `|⟨Jv, w⟩ − ⟨v, Jᵀw⟩|`
//! (relative) with the forward-mode dual-number `Jv` is reported too (exact up to rounding:
//! tolerance [`DOT_TOL`]).
//!
//! Groups:
//!
//! | crate | groups |
//! |---|---|
//! | math | covariance, SH evaluation, exp map, Jl⁻¹·ω, left/right exp updates, activations |
//! | ode | one `step_vjp` per method on the MLP field (R³) and on the rigid body (SO(3) × R³) |
//! | splat | `project_vjp` (with the camera pose), SH colour, the reference raster VJP, SSIM, L1, the full `render_vjp` |
//! | cli | the neural field VJP, the velocity and deformation model backward, and one training step (render ∘ integrate ∘ field, all loss terms) per parameter group |
//!
//! Central differences are exact to about `ε^{2/3}·|f| ≈ 4e-11·|f|`, so the tolerances are
//! `1e-8` absolute plus `1e-6` relative (`1e-5` for the training step, whose loss sums
//! thousands of pixels). Scenes are generated away from the renderer's discrete decisions
//! (alpha threshold, transmittance stop, alpha clamp, colour clamp), where the loss is not
//! differentiable.

mod math;
pub mod model;
mod ode;
pub mod scene;
mod splat;

use core::fmt;
use evogs_math::diff::{GradCheck, GradReport, central_gradient, dual_jvp, vjp_dot_test};
use evogs_math::rng::SplitMix64;
use evogs_math::{Dual, Real};

/// Tolerance of the dot-product test against a dual-number JVP.
pub const DOT_TOL: f64 = 1e-12;
/// Tolerance of the kernel checks.
pub const KERNEL_TOL: GradCheck = GradCheck::new(1e-8, 1e-6);

/// One checked group.
#[derive(Clone, Debug, PartialEq)]
pub struct GradRow {
    /// Crate and VJP (e.g. `math: covariance_vjp`).
    pub group: String,
    /// Number of gradient entries compared.
    pub entries: usize,
    /// Largest `|analytic − numeric|`.
    pub max_abs: f64,
    /// Largest `|analytic − numeric|/max(|analytic|, |numeric|)`.
    pub max_rel: f64,
    /// The tolerance.
    pub tolerance: GradCheck,
    /// Largest dot-product-test mismatch, if run.
    pub dot: Option<f64>,
    /// Whether every entry (and the dot test) passed.
    pub passed: bool,
}

impl GradRow {
    /// A row from the reports of several points (and dot tests).
    #[must_use]
    pub fn from_reports(group: &str, reports: &[GradReport], dots: &[f64]) -> Self {
        let tolerance = reports.first().map_or(KERNEL_TOL, |r| r.tolerance);
        let dot = dots.iter().copied().reduce(f64::max);
        Self {
            group: group.to_string(),
            entries: reports.iter().map(|r| r.len).sum(),
            max_abs: reports.iter().map(|r| r.max_abs_err).fold(0.0, nan_max),
            max_rel: reports.iter().map(|r| r.max_rel_err).fold(0.0, nan_max),
            tolerance,
            dot,
            passed: !reports.is_empty()
                && reports.iter().all(GradReport::passed)
                && dot.is_none_or(|d| d <= DOT_TOL),
        }
    }
}

fn nan_max(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

/// The table of `evogs check-grad`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GradTable {
    /// One row per group.
    pub rows: Vec<GradRow>,
}

impl GradTable {
    /// `true` if every row passed.
    #[must_use]
    pub fn passed(&self) -> bool {
        !self.rows.is_empty() && self.rows.iter().all(|r| r.passed)
    }
}

impl fmt::Display for GradTable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let w = self
            .rows
            .iter()
            .map(|r| r.group.chars().count())
            .max()
            .unwrap_or(5);
        writeln!(
            f,
            "{:<w$}  {:>7}  {:>9}  {:>9}  {:<17}  {:>9}  ok",
            "group", "entries", "max abs", "max rel", "tolerance", "dot test"
        )?;
        for r in &self.rows {
            let dot = r.dot.map_or("-".to_string(), |d| format!("{d:.1e}"));
            writeln!(
                f,
                "{:<w$}  {:>7}  {:>9.2e}  {:>9.2e}  {:<17}  {:>9}  {}",
                r.group,
                r.entries,
                r.max_abs,
                r.max_rel,
                format!(
                    "{:.0e} + {:.0e}·|g|",
                    r.tolerance.abs_tol, r.tolerance.rel_tol
                ),
                dot,
                if r.passed { "pass" } else { "FAIL" }
            )?;
        }
        let failed = self.rows.iter().filter(|r| !r.passed).count();
        write!(
            f,
            "{}: {} groups, {failed} failed (max rel = max |a − n|/max(|a|, |n|) over every \
             entry, large only where |g| is tiny and the absolute tolerance governs; dot \
             test: relative, tolerance {DOT_TOL:.0e})",
            if self.passed() { "PASS" } else { "FAIL" },
            self.rows.len()
        )
    }
}

/// A differentiable map `Rⁿ → Rᵐ` generic over the scalar, with its VJP in f64.
pub(crate) trait Kernel {
    /// Number of inputs.
    fn n_in(&self) -> usize;
    /// Number of outputs.
    fn n_out(&self) -> usize;
    /// `out = f(x)`.
    fn eval<T: Real>(&self, x: &[T], out: &mut [T]);
    /// `d_x = J(x)ᵀ w` (overwritten).
    fn vjp(&self, x: &[f64], w: &[f64], d_x: &mut [f64]);
}

/// Random numbers in `[lo, hi)`.
pub(crate) fn uniform(rng: &mut SplitMix64, n: usize, lo: f64, hi: f64) -> Vec<f64> {
    (0..n).map(|_| rng.uniform(lo, hi)).collect()
}

/// `⟨a, b⟩`.
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// A VJP `(x, w, d_x)`: `d_x = J(x)ᵀw`.
pub(crate) type VjpFn<'a> = dyn FnMut(&[f64], &[f64], &mut [f64]) + 'a;

/// Checks a VJP against central differences of `⟨w, f(x)⟩` at `x` (random `w`).
pub(crate) fn check_fn(
    tol: GradCheck,
    x: &[f64],
    m: usize,
    f: &mut dyn FnMut(&[f64], &mut [f64]),
    vjp: &mut VjpFn<'_>,
    seed: u64,
) -> GradReport {
    let mut rng = SplitMix64::new(seed);
    let w = uniform(&mut rng, m, -1.0, 1.0);
    let mut analytic = vec![0.0; x.len()];
    vjp(x, &w, &mut analytic);
    let mut xs = x.to_vec();
    let mut numeric = vec![0.0; x.len()];
    let mut out = vec![0.0; m];
    central_gradient(
        |v: &[f64]| {
            f(v, &mut out);
            dot(&out, &w)
        },
        &mut xs,
        &mut numeric,
    );
    tol.check(&analytic, &numeric)
}

/// The central-difference reports and dual dot-test mismatches of a [`Kernel`] at every
/// point.
pub(crate) fn kernel_reports<K: Kernel>(
    k: &K,
    points: &[Vec<f64>],
    seed: u64,
) -> (Vec<GradReport>, Vec<f64>) {
    let (n, m) = (k.n_in(), k.n_out());
    let mut reports = Vec::new();
    let mut dots = Vec::new();
    for (i, x) in (0_u64..).zip(points) {
        let s = seed.wrapping_mul(1000).wrapping_add(i);
        reports.push(check_fn(
            KERNEL_TOL,
            x,
            m,
            &mut |v, o| k.eval(v, o),
            &mut |v, w, d| k.vjp(v, w, d),
            s,
        ));
        dots.push(vjp_dot_test(
            |v: &[f64], jv: &mut [f64]| {
                dual_jvp(
                    |xd: &[Dual<f64>], yd: &mut [Dual<f64>]| k.eval(xd, yd),
                    x,
                    v,
                    jv,
                );
            },
            |w: &[f64], jtw: &mut [f64]| k.vjp(x, w, jtw),
            n,
            m,
            s ^ 0x9e37,
        ));
    }
    (reports, dots)
}

/// Checks a [`Kernel`] at every point: central differences and the dual dot-product test.
pub(crate) fn check_kernel<K: Kernel>(
    group: &str,
    k: &K,
    points: &[Vec<f64>],
    seed: u64,
) -> GradRow {
    let (reports, dots) = kernel_reports(k, points, seed);
    GradRow::from_reports(group, &reports, &dots)
}

/// Runs every group; the model groups check `samples` entries per parameter array
/// (`usize::MAX`: every entry, as `evogs check-grad` does).
#[must_use]
pub fn check_grad(samples: usize) -> GradTable {
    let mut rows = Vec::new();
    rows.extend(math::rows());
    rows.extend(ode::rows());
    rows.extend(splat::rows());
    rows.extend(model::rows(samples));
    GradTable { rows }
}
