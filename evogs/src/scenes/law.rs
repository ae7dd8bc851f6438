//! Closed-form motion laws of a scene's bodies.
//!
//! A body's Gaussians are given in its own frame (body coordinates `b`); at time `t` a point
//! is at `x(t) = R(t)·d(b, t) + p(t)`, where `(R, p)` is the rigid `world_from_body`
//! transform of the law and `d` its non-rigid deformation in the body frame (the identity
//! for every law but [`Law::Wave`]).

use evogs_math::so3::exp_matrix;
use evogs_math::{Mat3, Vec3};
use serde::{Deserialize, Serialize};

/// A motion law with its parameters (times are in the scene's units: the training window is
/// `[0, 1]`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Law {
    /// No motion: `R = Exp(tilt)`, `p = origin`.
    Still {
        /// Position of the body frame.
        origin: [f64; 3],
        /// Orientation of the body frame (rotation vector, radians).
        tilt: [f64; 3],
    },
    /// Constant velocity: `R = I`, `p = origin + velocity·t`.
    Translate {
        /// Position at `t = 0`.
        origin: [f64; 3],
        /// Velocity.
        velocity: [f64; 3],
    },
    /// Constant acceleration (a throw, no bounce): `R = I`,
    /// `p = origin + velocity·t + ½·acceleration·t²`.
    Throw {
        /// Position at `t = 0`.
        origin: [f64; 3],
        /// Velocity at `t = 0`.
        velocity: [f64; 3],
        /// Constant acceleration.
        acceleration: [f64; 3],
    },
    /// Spin about a fixed axis through `centre`: `R = Exp(axis·(phase + rate·t))`,
    /// `p = centre`.
    Spin {
        /// The fixed point.
        centre: [f64; 3],
        /// Unit axis.
        axis: [f64; 3],
        /// Angular rate (radians per unit time).
        rate: f64,
        /// Angle at `t = 0` (radians).
        phase: f64,
    },
    /// A circular orbit at constant orientation: `R = I`,
    /// `p = centre + Exp(axis·rate·t)·radius`.
    Orbit {
        /// Centre of the circle.
        centre: [f64; 3],
        /// Unit axis of the orbit.
        axis: [f64; 3],
        /// Offset from the centre at `t = 0` (perpendicular to the axis).
        radius: [f64; 3],
        /// Angular rate (radians per unit time).
        rate: f64,
    },
    /// A pendulum swinging about a fixed pivot, in the small-angle closed form
    /// `θ(t) = amplitude·cos(frequency·t + phase)`: `R = Exp(axis·θ(t))`, `p = pivot` (the
    /// body hangs below the pivot in its own frame).
    Pendulum {
        /// The pivot.
        pivot: [f64; 3],
        /// Unit swing axis (horizontal).
        axis: [f64; 3],
        /// Angular amplitude (radians).
        amplitude: f64,
        /// Angular frequency `√(g/L)` (radians per unit time).
        frequency: f64,
        /// Phase at `t = 0` (radians).
        phase: f64,
    },
    /// A travelling wave on a sheet (non-rigid): the rigid part is still
    /// (`R = Exp(tilt)`, `p = origin`) and a body point `(u, v, w)` moves along the sheet's
    /// normal (body z): `d = (u, v, w + amplitude·sin(wavenumber·u − frequency·t))`.
    Wave {
        /// Position of the body frame.
        origin: [f64; 3],
        /// Orientation of the body frame (rotation vector, radians).
        tilt: [f64; 3],
        /// Amplitude of the normal displacement.
        amplitude: f64,
        /// Wave number along body x (radians per unit length).
        wavenumber: f64,
        /// Angular frequency (radians per unit time).
        frequency: f64,
    },
}

fn v(a: [f64; 3]) -> Vec3<f64> {
    Vec3::new(a[0], a[1], a[2])
}

impl Law {
    /// The rigid `world_from_body` transform at `t`: rotation and translation.
    #[must_use]
    pub fn world_from_body(&self, t: f64) -> (Mat3<f64>, Vec3<f64>) {
        match *self {
            Self::Still { origin, tilt } | Self::Wave { origin, tilt, .. } => {
                (exp_matrix(v(tilt)), v(origin))
            }
            Self::Translate { origin, velocity } => (Mat3::identity(), v(origin) + v(velocity) * t),
            Self::Throw {
                origin,
                velocity,
                acceleration,
            } => (
                Mat3::identity(),
                v(origin) + v(velocity) * t + v(acceleration) * (0.5 * t * t),
            ),
            Self::Spin {
                centre,
                axis,
                rate,
                phase,
            } => (exp_matrix(v(axis) * (phase + rate * t)), v(centre)),
            Self::Orbit {
                centre,
                axis,
                radius,
                rate,
            } => (
                Mat3::identity(),
                v(centre) + exp_matrix(v(axis) * (rate * t)).mul_vec(v(radius)),
            ),
            Self::Pendulum {
                pivot,
                axis,
                amplitude,
                frequency,
                phase,
            } => {
                let theta = amplitude * (frequency * t + phase).cos();
                (exp_matrix(v(axis) * theta), v(pivot))
            }
        }
    }

    /// The non-rigid deformation of the body point `b` at `t`, in the body frame.
    #[must_use]
    pub fn deform(&self, b: Vec3<f64>, t: f64) -> Vec3<f64> {
        match *self {
            Self::Wave {
                amplitude,
                wavenumber,
                frequency,
                ..
            } => Vec3::new(
                b.x,
                b.y,
                b.z + amplitude * (wavenumber * b.x - frequency * t).sin(),
            ),
            _ => b,
        }
    }

    /// The inverse of [`Law::deform`]: the body point that is at `d` (body frame) at `t`.
    #[must_use]
    pub fn undeform(&self, d: Vec3<f64>, t: f64) -> Vec3<f64> {
        match *self {
            Self::Wave {
                amplitude,
                wavenumber,
                frequency,
                ..
            } => Vec3::new(
                d.x,
                d.y,
                d.z - amplitude * (wavenumber * d.x - frequency * t).sin(),
            ),
            _ => d,
        }
    }

    /// Where the body point `b` is at `t` (world).
    #[must_use]
    pub fn position(&self, b: Vec3<f64>, t: f64) -> Vec3<f64> {
        let (r, p) = self.world_from_body(t);
        r.mul_vec(self.deform(b, t)) + p
    }

    /// The body point that is at the world point `x` at `t` (inverse of [`Law::position`]).
    #[must_use]
    pub fn body_point(&self, x: Vec3<f64>, t: f64) -> Vec3<f64> {
        let (r, p) = self.world_from_body(t);
        self.undeform(r.tr_mul_vec(x - p), t)
    }

    /// `false` for [`Law::Still`].
    #[must_use]
    pub const fn is_moving(&self) -> bool {
        !matches!(self, Self::Still { .. })
    }

    /// The law's name, as in `motion.json` (`still`, `translate`, ...).
    #[must_use]
    pub const fn name(&self) -> &'static str {
        match self {
            Self::Still { .. } => "still",
            Self::Translate { .. } => "translate",
            Self::Throw { .. } => "throw",
            Self::Spin { .. } => "spin",
            Self::Orbit { .. } => "orbit",
            Self::Pendulum { .. } => "pendulum",
            Self::Wave { .. } => "wave",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn laws() -> Vec<Law> {
        vec![
            Law::Still {
                origin: [0.1, 0.2, 0.3],
                tilt: [0.0, 0.4, 0.0],
            },
            Law::Translate {
                origin: [0.0, 1.0, 0.0],
                velocity: [1.0, -0.5, 0.2],
            },
            Law::Throw {
                origin: [0.0, 0.0, 1.0],
                velocity: [1.0, 0.0, 1.5],
                acceleration: [0.0, 0.0, -3.0],
            },
            Law::Spin {
                centre: [0.0, 0.0, 0.5],
                axis: [0.0, 0.6, 0.8],
                rate: 4.0,
                phase: 0.3,
            },
            Law::Orbit {
                centre: [0.0, 0.0, 0.5],
                axis: [0.0, 0.0, 1.0],
                radius: [0.9, 0.0, 0.0],
                rate: 2.0,
            },
            Law::Pendulum {
                pivot: [0.0, 0.0, 1.6],
                axis: [1.0, 0.0, 0.0],
                amplitude: 0.35,
                frequency: 7.0,
                phase: 0.0,
            },
            Law::Wave {
                origin: [0.0, 0.0, 0.6],
                tilt: [1.2, 0.0, 0.0],
                amplitude: 0.1,
                wavenumber: 8.0,
                frequency: 9.0,
            },
        ]
    }

    #[test]
    fn body_point_inverts_position() {
        let b = Vec3::new(0.2, -0.1, 0.05);
        for law in laws() {
            for &t in &[-0.3, 0.0, 0.37, 1.3] {
                let x = law.position(b, t);
                let back = law.body_point(x, t);
                assert!((back - b).norm() < 1e-12, "{} at {t}: {back:?}", law.name());
            }
        }
    }

    #[test]
    fn the_laws_follow_their_formulas() {
        let b = Vec3::new(0.0, 0.0, 0.0);
        let Law::Throw { .. } = laws()[2] else {
            panic!("order")
        };
        // A throw: the second difference is the acceleration.
        let law = laws()[2];
        let h = 0.1;
        let a = (law.position(b, 0.5 + h) - law.position(b, 0.5) * 2.0 + law.position(b, 0.5 - h))
            * (1.0 / (h * h));
        assert!((a - Vec3::new(0.0, 0.0, -3.0)).norm() < 1e-9, "{a:?}");
        // An orbit keeps its distance to the centre and its orientation.
        let law = laws()[4];
        for &t in &[0.0, 0.5, 1.3] {
            let (r, p) = law.world_from_body(t);
            assert!((r - Mat3::identity()).max_abs() < 1e-15, "orientation");
            assert!(
                ((p - Vec3::new(0.0, 0.0, 0.5)).norm() - 0.9).abs() < 1e-12,
                "radius"
            );
        }
        // A pendulum's angle stays within its amplitude and starts at it (phase 0).
        let law = laws()[5];
        let x0 = law.position(Vec3::new(0.0, 0.0, -1.0), 0.0);
        let want = Vec3::new(0.0, 0.35_f64.sin(), 1.6 - 0.35_f64.cos());
        assert!((x0 - want).norm() < 1e-12, "{x0:?}");
    }
}
