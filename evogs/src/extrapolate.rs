//! No-training baselines for prediction beyond the training window: the Gaussians of a
//! fitted model at the end of the window, frozen ([`Extrapolation::Hold`]) or carried on at
//! constant velocity or constant acceleration estimated by finite differences at the end of
//! the window.
//!
//! With the states `x₀ = x(τ)`, `x₁ = x(τ − h)`, `x₂ = x(τ − 2h)` and `s = t − τ`:
//!
//! ```text
//! hold       x(t) = x₀
//! const-vel  x(t) = x₀ + v s,              v = (x₀ − x₁)/h
//! const-acc  x(t) = x₀ + v s + ½ a s²,     v = (3x₀ − 4x₁ + x₂)/(2h),  a = (x₀ − 2x₁ + x₂)/h²
//! ```
//!
//! Rotations follow the same rule on the rotation vector `r(t) = Log(q(τ)⁻¹ q(t))`
//! (`r₀ = 0`), and `q(t) = q(τ) Exp(r(t))`. Log-scales, opacity and colour are held at `τ`.
//! Const-vel is exact on trajectories linear in `t`, const-acc on quadratic ones.

use crate::data::{SplitName, View};
use crate::eval::{SplitMetrics, evaluate_renders};
use crate::field::Gemm;
use crate::model::Model;
use crate::model::render_options;
use evogs_math::so3::{exp_quat, log_quat};
use evogs_math::{Par, Quat, Vec3};
use evogs_splat::{Image, PinholeCamera, Splats, TiledRasterizer, render_tiled};
use serde::{Deserialize, Serialize};

/// A no-training baseline.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Extrapolation {
    /// The state at the end of the window, frozen.
    Hold,
    /// Constant velocity from a backward difference.
    ConstVel,
    /// Constant acceleration from second-order backward differences.
    ConstAcc,
}

impl Extrapolation {
    /// Every baseline, in table order.
    pub const ALL: [Self; 3] = [Self::Hold, Self::ConstVel, Self::ConstAcc];

    /// Name (`hold`, `const-vel`, `const-acc`).
    #[must_use]
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::Hold => "hold",
            Self::ConstVel => "const-vel",
            Self::ConstAcc => "const-acc",
        }
    }
}

/// Per-Gaussian polynomial extrapolation of positions and rotations from the end of a window.
#[derive(Clone, Debug)]
pub struct Extrapolator {
    /// The end of the window `τ`.
    pub end: f64,
    /// The Gaussians at `τ`.
    at_end: Splats<f64>,
    /// Position velocity and acceleration per Gaussian.
    vel: Vec<Vec3<f64>>,
    acc: Vec<Vec3<f64>>,
    /// Rotation-vector velocity and acceleration per Gaussian (body side: `q(τ) Exp(r)`).
    rot_vel: Vec<Vec3<f64>>,
    rot_acc: Vec<Vec3<f64>>,
}

impl Extrapolator {
    /// The extrapolation `kind` from the Gaussians at `end`, `end − h` and `end − 2h`.
    ///
    /// # Panics
    /// If the three sets differ in size or `h` is not positive.
    #[must_use]
    pub fn new(
        kind: Extrapolation,
        end: f64,
        h: f64,
        x0: &Splats<f64>,
        x1: &Splats<f64>,
        x2: &Splats<f64>,
    ) -> Self {
        assert!(h > 0.0, "the difference step must be positive");
        assert!(
            x0.len() == x1.len() && x0.len() == x2.len(),
            "the three states must hold the same Gaussians"
        );
        let n = x0.len();
        let zero = vec![Vec3::zero(); n];
        let (mut vel, mut acc, mut rot_vel, mut rot_acc) =
            (zero.clone(), zero.clone(), zero.clone(), zero);
        let rel =
            |q0: Quat<f64>, q: Quat<f64>| log_quat(q0.normalize().conj().mul_quat(q.normalize()));
        for i in 0..n {
            let (p0, p1, p2) = (x0.means[i], x1.means[i], x2.means[i]);
            let r1 = rel(x0.quats[i], x1.quats[i]);
            let r2 = rel(x0.quats[i], x2.quats[i]);
            match kind {
                Extrapolation::Hold => {}
                Extrapolation::ConstVel => {
                    vel[i] = (p0 - p1) * (1.0 / h);
                    rot_vel[i] = -r1 * (1.0 / h);
                }
                Extrapolation::ConstAcc => {
                    vel[i] = (p0 * 3.0 - p1 * 4.0 + p2) * (0.5 / h);
                    acc[i] = (p0 - p1 * 2.0 + p2) * (1.0 / (h * h));
                    rot_vel[i] = (-r1 * 4.0 + r2) * (0.5 / h);
                    rot_acc[i] = (-r1 * 2.0 + r2) * (1.0 / (h * h));
                }
            }
        }
        Self {
            end,
            at_end: x0.clone(),
            vel,
            acc,
            rot_vel,
            rot_acc,
        }
    }

    /// The baseline `kind` of `model` at the end `end` of its window, from its Gaussians at
    /// `end`, `end − h` and `end − 2h`.
    pub fn from_model<T: Gemm>(
        model: &mut Model<T>,
        kind: Extrapolation,
        end: f64,
        h: f64,
    ) -> Self {
        let mut at = |t: f64| {
            let mut s = Splats::default();
            let mut stepper = None;
            let _tape = model.splats_at(t, &mut stepper, &mut s);
            s.cast::<f64>()
        };
        let (x0, x1, x2) = (at(end), at(end - h), at(end - 2.0 * h));
        Self::new(kind, end, h, &x0, &x1, &x2)
    }

    /// The Gaussians at `t` (the polynomial is applied on both sides of `τ`).
    pub fn splats_at(&self, t: f64, out: &mut Splats<f64>) {
        out.clone_from(&self.at_end);
        let s = t - self.end;
        for i in 0..out.len() {
            out.means[i] = self.at_end.means[i] + self.vel[i] * s + self.acc[i] * (0.5 * s * s);
            let r = self.rot_vel[i] * s + self.rot_acc[i] * (0.5 * s * s);
            out.quats[i] = self.at_end.quats[i].normalize().mul_quat(exp_quat(r));
        }
    }

    /// Evaluates the baseline on `views` as [`crate::eval::evaluate_views`] evaluates a model
    /// (renders clamped to [0, 1], PSNR and the 3DGS SSIM; no motion masks).
    ///
    /// # Errors
    /// An image that cannot be decoded, or a bad camera.
    pub fn evaluate(
        &self,
        views: &[&View],
        split: SplitName,
        background: [f32; 3],
        par: Par,
    ) -> Result<SplitMetrics, String> {
        let mut at = Splats::default();
        let mut rast = TiledRasterizer::new();
        let opts = render_options::<f32>(background, self.at_end.sh_degree, par);
        let render = |cam: &PinholeCamera<f32>, t: f64| {
            self.splats_at(t, &mut at);
            let mut img = render_tiled(&at.cast::<f32>(), cam, &opts, &mut rast)
                .raster
                .rgb;
            for x in img.data_mut() {
                *x = x.clamp(0.0, 1.0);
            }
            img
        };
        let mut no_masks = |_: &View, _: &Image<f32>| Ok(None);
        evaluate_renders(
            views,
            split,
            &[],
            par,
            &mut no_masks,
            self.at_end.len(),
            render,
            |_, _| {},
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use evogs_math::rng::SplitMix64;

    /// Gaussians whose positions are `a + b t + c t²` and whose rotations are
    /// `q₀ Exp(axis (β t + γ t²))`, per Gaussian.
    struct Truth {
        a: Vec<Vec3<f64>>,
        b: Vec<Vec3<f64>>,
        c: Vec<Vec3<f64>>,
        q0: Vec<Quat<f64>>,
        axis: Vec<Vec3<f64>>,
        beta: Vec<f64>,
        gamma: Vec<f64>,
    }

    impl Truth {
        fn new(n: usize, quadratic: bool, seed: u64) -> Self {
            let mut rng = SplitMix64::new(seed);
            let mut v =
                |s: f64| Vec3::new(rng.uniform(-s, s), rng.uniform(-s, s), rng.uniform(-s, s));
            let a = (0..n).map(|_| v(1.0)).collect();
            let b = (0..n).map(|_| v(2.0)).collect();
            let c = (0..n)
                .map(|_| if quadratic { v(3.0) } else { Vec3::zero() })
                .collect();
            let q0 = (0..n).map(|_| exp_quat(v(2.0))).collect();
            let axis: Vec<Vec3<f64>> = (0..n)
                .map(|_| {
                    let x = v(1.0);
                    x * (1.0 / x.norm())
                })
                .collect();
            let mut rng = SplitMix64::new(seed + 1);
            let beta = (0..n).map(|_| rng.uniform(-3.0, 3.0)).collect();
            let gamma = (0..n)
                .map(|_| {
                    if quadratic {
                        rng.uniform(-2.0, 2.0)
                    } else {
                        0.0
                    }
                })
                .collect();
            Self {
                a,
                b,
                c,
                q0,
                axis,
                beta,
                gamma,
            }
        }

        fn at(&self, t: f64) -> Splats<f64> {
            let mut s = Splats::new(0);
            for i in 0..self.a.len() {
                s.push(
                    self.a[i] + self.b[i] * t + self.c[i] * (t * t),
                    Vec3::splat(-3.0),
                    self.q0[i].mul_quat(exp_quat(
                        self.axis[i] * (self.beta[i] * t + self.gamma[i] * t * t),
                    )),
                    0.0,
                    &[[0.1, 0.2, 0.3]],
                );
            }
            s
        }
    }

    fn worst(e: &Extrapolator, truth: &Truth, t: f64) -> (f64, f64) {
        let mut got = Splats::default();
        e.splats_at(t, &mut got);
        let want = truth.at(t);
        let mut worst = (0.0_f64, 0.0_f64);
        for i in 0..got.len() {
            worst.0 = worst.0.max((got.means[i] - want.means[i]).norm());
            let d = log_quat(got.quats[i].conj().mul_quat(want.quats[i].normalize()));
            worst.1 = worst.1.max(d.norm());
        }
        worst
    }

    #[test]
    fn constant_velocity_is_exact_on_linear_trajectories() {
        let truth = Truth::new(50, false, 7);
        let (end, h) = (0.75, 0.05);
        let e = Extrapolator::new(
            Extrapolation::ConstVel,
            end,
            h,
            &truth.at(end),
            &truth.at(end - h),
            &truth.at(end - 2.0 * h),
        );
        for t in [0.8, 1.0, 1.3] {
            let (p, r) = worst(&e, &truth, t);
            assert!(
                p < 1e-12 && r < 1e-12,
                "t = {t}: position {p:e}, rotation {r:e}"
            );
        }
        // Holding is wrong on the same trajectories (the test can fail).
        let hold = Extrapolator::new(
            Extrapolation::Hold,
            end,
            h,
            &truth.at(end),
            &truth.at(end - h),
            &truth.at(end - 2.0 * h),
        );
        let (p, _) = worst(&hold, &truth, 1.3);
        assert!(p > 0.1, "{p}");
    }

    #[test]
    fn constant_acceleration_is_exact_on_quadratic_trajectories() {
        let truth = Truth::new(50, true, 9);
        let (end, h) = (0.75, 0.05);
        let (x0, x1, x2) = (truth.at(end), truth.at(end - h), truth.at(end - 2.0 * h));
        let e = Extrapolator::new(Extrapolation::ConstAcc, end, h, &x0, &x1, &x2);
        for t in [0.8, 1.0, 1.3] {
            let (p, r) = worst(&e, &truth, t);
            assert!(
                p < 1e-11 && r < 1e-10,
                "t = {t}: position {p:e}, rotation {r:e}"
            );
        }
        let vel = Extrapolator::new(Extrapolation::ConstVel, end, h, &x0, &x1, &x2);
        let (p, _) = worst(&vel, &truth, 1.3);
        assert!(p > 0.01, "constant velocity misses a curved path: {p}");
        // At the end of the window every baseline is the state there.
        let hold = Extrapolator::new(Extrapolation::Hold, end, h, &x0, &x1, &x2);
        for e in [&e, &vel, &hold] {
            let (p, r) = worst(e, &truth, end);
            assert!(p < 1e-15 && r < 1e-12, "{p:e} {r:e}");
        }
    }

    #[test]
    fn names_are_the_table_rows() {
        let names: Vec<&str> = Extrapolation::ALL.iter().map(|e| e.as_str()).collect();
        assert_eq!(names, ["hold", "const-vel", "const-acc"]);
    }
}
