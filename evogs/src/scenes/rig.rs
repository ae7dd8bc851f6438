//! The cameras of a generated scene: one random camera per time on the upper hemisphere
//! (monocular), or a fixed ring (multi-view). Camera-to-world matrices are in the D-NeRF
//! (OpenGL / Blender) axes: x right, y up, looking along −z.

use evogs_math::Vec3;
use evogs_math::rng::SplitMix64;

/// Where every camera looks.
pub const TARGET: [f64; 3] = [0.0, 0.0, 0.45];
/// Distance of every camera from [`TARGET`].
pub const DISTANCE: f64 = 4.2;
/// Horizontal field of view (radians).
pub const FOV_X: f64 = 0.75;
/// Elevation range of the monocular cameras (radians above the horizon).
pub const ELEVATION: [f64; 2] = [0.3, 1.05];
/// Elevation of the ring cameras (radians).
pub const RING_ELEVATION: f64 = 0.5;

/// The D-NeRF camera-to-world matrix of a camera at `eye` looking at [`TARGET`] with world
/// z up.
#[must_use]
pub fn look_at_c2w(eye: Vec3<f64>) -> [[f64; 4]; 4] {
    c2w_looking_at(eye, Vec3::new(TARGET[0], TARGET[1], TARGET[2]))
}

/// The D-NeRF camera-to-world matrix of a camera at `eye` looking at `target` with world z
/// up (OpenGL axes: the camera's back axis points from `target` to `eye`).
#[must_use]
pub fn c2w_looking_at(eye: Vec3<f64>, target: Vec3<f64>) -> [[f64; 4]; 4] {
    let back = eye - target;
    let back = back * (1.0 / back.norm());
    let right = Vec3::new(0.0, 0.0, 1.0).cross(back);
    let right = right * (1.0 / right.norm());
    let up = back.cross(right);
    [
        [right.x, up.x, back.x, eye.x],
        [right.y, up.y, back.y, eye.y],
        [right.z, up.z, back.z, eye.z],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

/// The camera at azimuth `az` and elevation `el` (radians) on the sphere of radius
/// [`DISTANCE`] around [`TARGET`].
#[must_use]
pub fn orbit_c2w(az: f64, el: f64) -> [[f64; 4]; 4] {
    let eye = Vec3::new(
        TARGET[0] + DISTANCE * el.cos() * az.cos(),
        TARGET[1] + DISTANCE * el.cos() * az.sin(),
        TARGET[2] + DISTANCE * el.sin(),
    );
    look_at_c2w(eye)
}

/// A random camera on the upper hemisphere (uniform azimuth, elevation uniform in
/// [`ELEVATION`]).
#[must_use]
pub fn random_c2w(rng: &mut SplitMix64) -> [[f64; 4]; 4] {
    let az = rng.uniform(0.0, std::f64::consts::TAU);
    let el = rng.uniform(ELEVATION[0], ELEVATION[1]);
    orbit_c2w(az, el)
}

/// Camera `k` of a ring of `n` at [`RING_ELEVATION`].
#[must_use]
pub fn ring_c2w(k: usize, n: usize) -> [[f64; 4]; 4] {
    let az = std::f64::consts::TAU * (k as f64 + 0.25) / n as f64;
    orbit_c2w(az, RING_ELEVATION)
}

#[cfg(test)]
mod tests {
    use super::*;
    use evogs_splat::PinholeCamera;

    #[test]
    fn the_target_projects_to_the_image_centre_with_z_up() {
        let mut rng = SplitMix64::new(3);
        for _ in 0..10 {
            let c2w = random_c2w(&mut rng);
            let cam = PinholeCamera::<f64>::from_dnerf(c2w, FOV_X, 64, 64).expect("a pose");
            let p = cam.world_to_camera(Vec3::new(TARGET[0], TARGET[1], TARGET[2]));
            assert!(p.x.abs() < 1e-9 && p.y.abs() < 1e-9, "{p:?}");
            assert!((p.z - DISTANCE).abs() < 1e-9, "in front: {p:?}");
            // A point above the target is above the image centre (image y points down).
            let q = cam.world_to_camera(Vec3::new(TARGET[0], TARGET[1], TARGET[2] + 0.5));
            assert!(q.y < 0.0, "{q:?}");
            assert!(c2w[2][3] > TARGET[2], "upper hemisphere");
        }
    }
}
