//! Bodies as clouds of small Gaussians in their own frame: a box, a sphere, a sheet (also the
//! static floor), each coloured with a pattern so that motion, rotation included, shows in
//! the images.

use evogs_math::rng::SplitMix64;
use evogs_math::so3::quat_from_matrix;
use evogs_math::{Mat3, Quat, Vec3};
use serde::{Deserialize, Serialize};

/// The shape of a body, centred at `centre` in the body frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Shape {
    /// The surface of a box with half-extents `half`; one colour per face pair.
    Box {
        /// Half-extents along body x, y, z.
        half: [f64; 3],
    },
    /// The surface of a sphere; coloured in longitude sectors and latitude bands.
    Sphere {
        /// Radius.
        radius: f64,
    },
    /// A rectangle in the body's xy plane (normal: body z), in a checkerboard.
    Sheet {
        /// Half-extents along body x and y.
        half: [f64; 2],
        /// Checker square side.
        square: f64,
    },
}

/// One Gaussian of a body, in the body frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyGaussian {
    /// Centre (body frame, before any deformation).
    pub position: Vec3<f64>,
    /// Orientation (body frame): local z is the surface normal.
    pub rotation: Quat<f64>,
    /// Standard deviations along the local axes.
    pub scale: Vec3<f64>,
    /// RGB colour in [0, 1].
    pub color: [f64; 3],
}

/// A frame whose third axis is `n` (unit).
fn frame_with_normal(n: Vec3<f64>) -> Quat<f64> {
    let helper = if n.x.abs() < 0.9 {
        Vec3::new(1.0, 0.0, 0.0)
    } else {
        Vec3::new(0.0, 1.0, 0.0)
    };
    let a = helper.cross(n);
    let a = a * (1.0 / a.norm());
    let b = n.cross(a);
    let m = Mat3::from_rows([[a.x, b.x, n.x], [a.y, b.y, n.y], [a.z, b.z, n.z]]);
    quat_from_matrix(m)
}

/// Colour jitter of ±`amount` per channel, clamped to [0, 1].
fn jitter(c: [f64; 3], amount: f64, rng: &mut SplitMix64) -> [f64; 3] {
    c.map(|x| (x + rng.uniform(-amount, amount)).clamp(0.0, 1.0))
}

impl Shape {
    /// The Gaussians of the shape at about `spacing` apart, centred at `centre`, coloured from
    /// `palette` (at least two colours) with a small jitter from `rng`.
    ///
    /// # Panics
    /// If `palette` has fewer than two colours or `spacing` is not positive.
    #[must_use]
    pub fn gaussians(
        &self,
        centre: Vec3<f64>,
        spacing: f64,
        palette: &[[f64; 3]],
        rng: &mut SplitMix64,
    ) -> Vec<BodyGaussian> {
        assert!(palette.len() >= 2, "a palette needs two colours");
        assert!(spacing > 0.0, "spacing must be positive");
        let flat = Vec3::new(0.6 * spacing, 0.6 * spacing, 0.15 * spacing);
        let mut out = Vec::new();
        let mut push = |p: Vec3<f64>, n: Vec3<f64>, c: [f64; 3], rng: &mut SplitMix64| {
            out.push(BodyGaussian {
                position: centre + p,
                rotation: frame_with_normal(n),
                scale: flat,
                color: jitter(c, 0.04, rng),
            });
        };
        match *self {
            Self::Box { half } => {
                for axis in 0..3 {
                    let (i, j) = ((axis + 1) % 3, (axis + 2) % 3);
                    let ni = cells(2.0 * half[i], spacing);
                    let nj = cells(2.0 * half[j], spacing);
                    for sign in [-1.0, 1.0] {
                        let face = 2 * axis + usize::from(sign > 0.0);
                        for a in 0..ni {
                            for b in 0..nj {
                                let mut p = [0.0; 3];
                                p[axis] = sign * half[axis];
                                p[i] =
                                    -half[i] + (f64::from(a) + 0.5) * 2.0 * half[i] / f64::from(ni);
                                p[j] =
                                    -half[j] + (f64::from(b) + 0.5) * 2.0 * half[j] / f64::from(nj);
                                let mut n = [0.0; 3];
                                n[axis] = sign;
                                // A stripe across each face makes its orientation visible.
                                let stripe = usize::from(a * 3 < ni);
                                let c = palette[(face + stripe) % palette.len()];
                                push(
                                    Vec3::new(p[0], p[1], p[2]),
                                    Vec3::new(n[0], n[1], n[2]),
                                    c,
                                    rng,
                                );
                            }
                        }
                    }
                }
            }
            Self::Sphere { radius } => {
                let area = 4.0 * std::f64::consts::PI * radius * radius;
                let n = cells(area, spacing * spacing).max(8);
                let golden = std::f64::consts::PI * (3.0 - 5.0_f64.sqrt());
                for k in 0..n {
                    let z = 1.0 - (f64::from(k) + 0.5) * 2.0 / f64::from(n);
                    let r = (1.0 - z * z).sqrt();
                    let phi = golden * f64::from(k);
                    let dir = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                    let lon = phi.rem_euclid(std::f64::consts::TAU);
                    #[allow(clippy::cast_possible_truncation, reason = "a sector index in 0..4")]
                    let sector = (lon / std::f64::consts::FRAC_PI_2) as usize % 4;
                    let band = usize::from(z > 0.3);
                    push(
                        dir * radius,
                        dir,
                        palette[(sector + band) % palette.len()],
                        rng,
                    );
                }
            }
            Self::Sheet { half, square } => {
                let ni = cells(2.0 * half[0], spacing);
                let nj = cells(2.0 * half[1], spacing);
                for a in 0..ni {
                    for b in 0..nj {
                        let x = -half[0] + (f64::from(a) + 0.5) * 2.0 * half[0] / f64::from(ni);
                        let y = -half[1] + (f64::from(b) + 0.5) * 2.0 * half[1] / f64::from(nj);
                        #[allow(
                            clippy::cast_possible_truncation,
                            reason = "checker square indices are small"
                        )]
                        let parity = ((x / square).floor() as i64 + (y / square).floor() as i64)
                            .rem_euclid(2);
                        let c = palette[usize::from(parity == 1)];
                        push(Vec3::new(x, y, 0.0), Vec3::new(0.0, 0.0, 1.0), c, rng);
                    }
                }
            }
        }
        out
    }
}

/// How many cells of size `step` cover `length` (at least 1).
fn cells(length: f64, step: f64) -> u32 {
    #[allow(clippy::cast_possible_truncation, reason = "small positive counts")]
    let n = (length / step).round().max(1.0) as u32;
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    const PALETTE: [[f64; 3]; 3] = [[0.9, 0.2, 0.1], [0.1, 0.3, 0.9], [0.95, 0.85, 0.1]];

    #[test]
    fn shapes_put_their_gaussians_on_their_surface() {
        let mut rng = SplitMix64::new(1);
        let c = Vec3::new(0.5, 0.0, 0.0);
        let boxed = Shape::Box {
            half: [0.2, 0.3, 0.1],
        }
        .gaussians(c, 0.05, &PALETTE, &mut rng);
        assert!(boxed.len() > 50, "{}", boxed.len());
        for g in &boxed {
            let d = g.position - c;
            let on_face = (d.x.abs() - 0.2).abs() < 1e-12
                || (d.y.abs() - 0.3).abs() < 1e-12
                || (d.z.abs() - 0.1).abs() < 1e-12;
            assert!(on_face, "{d:?}");
            // Local z (the normal) points out of the box.
            let n = g.rotation.rotate(Vec3::new(0.0, 0.0, 1.0));
            assert!(n.dot(d) > 0.0, "{n:?} {d:?}");
        }
        let ball = Shape::Sphere { radius: 0.25 }.gaussians(c, 0.05, &PALETTE, &mut rng);
        for g in &ball {
            assert!(
                ((g.position - c).norm() - 0.25).abs() < 1e-12,
                "on the sphere"
            );
        }
        let sheet = Shape::Sheet {
            half: [1.0, 0.5],
            square: 0.25,
        }
        .gaussians(c, 0.1, &PALETTE, &mut rng);
        assert_eq!(sheet.len(), 20 * 10, "a 20 × 10 grid");
    }
}
