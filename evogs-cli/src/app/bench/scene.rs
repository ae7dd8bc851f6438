//! The synthetic scene of `evogs bench`: seeded random Gaussians in the unit cube, one
//! camera and a random target image (the same scene for every thread count and size).

use evogs_math::activation::logit;
use evogs_math::rng::SplitMix64;
use evogs_math::sh::SH_C0;
use evogs_math::{Quat, Vec3};
use evogs_splat::{CameraError, Image, PinholeCamera, Splats};

/// Image width and height in pixels.
pub const IMAGE_SIZE: usize = 400;
/// Horizontal field of view (degrees).
pub const FOV_X_DEG: f64 = 40.0;
/// Camera distance from the origin.
pub const DISTANCE: f64 = 4.0;
/// Camera azimuth about the world z axis, from the x axis (degrees).
pub const AZIMUTH_DEG: f64 = 30.0;
/// Camera elevation above the xy plane (degrees).
pub const ELEVATION_DEG: f64 = 20.0;
/// Range of the isotropic scales (log-uniform).
pub const SCALE_RANGE: [f64; 2] = [0.01, 0.03];
/// Range of the opacities (uniform).
pub const OPACITY_RANGE: [f64; 2] = [0.5, 0.9];
/// Standard deviation of the SH coefficients above degree 0.
pub const SH_REST_STD: f64 = 0.05;
/// SH degree of the Gaussians.
pub const SH_DEGREE: usize = 3;

/// The benchmark scene.
#[derive(Clone, Debug)]
pub struct BenchScene {
    /// The Gaussians (canonical state).
    pub splats: Splats<f32>,
    /// The camera.
    pub camera: PinholeCamera<f32>,
    /// The target image (uniform random colours).
    pub target: Image<f32>,
}

#[allow(clippy::cast_possible_truncation, reason = "scene values in f32")]
fn f(v: f64) -> f32 {
    v as f32
}

impl BenchScene {
    /// `n` Gaussians from `seed`: means uniform in `[−0.5, 0.5]³`, isotropic scales
    /// log-uniform in [`SCALE_RANGE`] (stored as log-scales), uniformly random unit
    /// quaternions, opacities uniform in [`OPACITY_RANGE`] (stored as logits), SH degree 3
    /// with the DC term from a uniformly random RGB colour and the other coefficients
    /// `N(0, 0.05²)`; a 400 × 400 pinhole camera with a 40° horizontal field of view at
    /// distance 4, azimuth 30° and elevation 20° (z up), looking at the origin (OpenCV
    /// axes: x right, y down, z forward); a target image of uniform random colours.
    ///
    /// # Errors
    /// The camera cannot be built (never for these constants).
    pub fn new(n: usize, seed: u64) -> Result<Self, CameraError> {
        let mut rng = SplitMix64::new(seed);
        let mut splats = Splats::new(SH_DEGREE);
        let (lo, hi) = (SCALE_RANGE[0].ln(), SCALE_RANGE[1].ln());
        let mut sh = [[0.0_f32; 3]; 16];
        for _ in 0..n {
            let mean = Vec3::new(
                f(rng.uniform(-0.5, 0.5)),
                f(rng.uniform(-0.5, 0.5)),
                f(rng.uniform(-0.5, 0.5)),
            );
            let s = f(rng.uniform(lo, hi));
            let q = Quat::new(rng.normal(), rng.normal(), rng.normal(), rng.normal()).normalize();
            let opacity = rng.uniform(OPACITY_RANGE[0], OPACITY_RANGE[1]);
            for (k, c) in sh.iter_mut().enumerate() {
                for ch in c.iter_mut() {
                    *ch = if k == 0 {
                        f((rng.next_f64() - 0.5) / SH_C0)
                    } else {
                        f(SH_REST_STD * rng.normal())
                    };
                }
            }
            splats.push(mean, Vec3::new(s, s, s), q.cast(), f(logit(opacity)), &sh);
        }
        let (az, el) = (AZIMUTH_DEG.to_radians(), ELEVATION_DEG.to_radians());
        let eye = Vec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin()) * DISTANCE;
        let camera = PinholeCamera::look_at(
            eye,
            Vec3::zero(),
            Vec3::new(0.0, 0.0, 1.0),
            FOV_X_DEG.to_radians(),
            IMAGE_SIZE,
            IMAGE_SIZE,
        )?;
        let mut target = Image::new(IMAGE_SIZE, IMAGE_SIZE);
        for v in target.data_mut() {
            *v = f(rng.next_f64());
        }
        Ok(Self {
            splats,
            camera,
            target,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scene_is_seeded_and_in_view() {
        let a = BenchScene::new(200, 3).expect("scene");
        let b = BenchScene::new(200, 3).expect("scene");
        assert_eq!(a.splats, b.splats, "same seed, same Gaussians");
        assert_eq!(a.target.data(), b.target.data(), "same target");
        assert_eq!(a.splats.len(), 200);
        let (lo, hi) = (SCALE_RANGE[0].ln() - 1e-6, SCALE_RANGE[1].ln() + 1e-6);
        for (i, m) in a.splats.means.iter().enumerate() {
            let ls = a.splats.log_scales[i];
            assert!(
                ls.x.to_bits() == ls.y.to_bits() && ls.y.to_bits() == ls.z.to_bits(),
                "isotropic"
            );
            assert!((lo..=hi).contains(&f64::from(ls.x)), "scale range");
            assert!(
                (a.splats.quats[i].norm() - 1.0).abs() < 1e-5,
                "unit quaternion"
            );
            // The whole cube is in front of the camera and projects into the image.
            let c = a.camera.world_to_camera(*m);
            assert!(c.z > 2.0, "in front");
            let u = a.camera.fx * c.x / c.z + a.camera.cx;
            let v = a.camera.fy * c.y / c.z + a.camera.cy;
            assert!(
                (0.0..400.0).contains(&u) && (0.0..400.0).contains(&v),
                "in view"
            );
        }
        // OpenCV axes with z up: the world's up direction points up in the image (−y).
        let up = a.camera.rotation.mul_vec(Vec3::new(0.0, 0.0, 1.0));
        assert!(up.y < -0.5, "z is up in the image");
    }
}
