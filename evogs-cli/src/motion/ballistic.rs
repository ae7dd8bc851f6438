//! A ballistic centroid path that bounces on a floor: a thrown body (the `toys` ball).
//!
//! Conventions: positions in world (scene) units, times elapsed from the range's start `τ =
//! t − t₀` (unit time). The body flies under a constant acceleration `a` (gravity: it points
//! *down*, `â = a/|a|`). The floor is the plane of depth `x·â = f`; while the centroid is
//! above it (`x·â < f`) the path is the parabola
//!
//! ```text
//! x(τ) = xₖ + vₖ (τ − τₖ) + ½ a (τ − τₖ)²,
//! ```
//!
//! and when it reaches the floor the velocity's normal part turns back, scaled by the
//! restitution `e ∈ [0, 1]`: `v ← v − (1 + e)(v·â) â`. The bounce times follow in closed
//! form, so the path is differentiable in its 11 parameters (start, velocity, acceleration,
//! floor depth, restitution) wherever the number of bounces before `τ` does not change. After
//! [`MAX_BOUNCES`] bounces the body slides along the floor at its tangential velocity. A
//! start below the floor never bounces.
//!
//! [`ballistic_point`] is one generic kernel; [`ballistic_point_vjp`] takes its exact
//! Jacobian by forward-mode dual numbers (eleven evaluations, cheap for one centroid).

use evogs_math::{Dual, Real, Vec3};

/// Number of parameters of a ballistic path (the layout of [`Ballistic::to_flat`]).
pub const BALLISTIC_PARAMS: usize = 11;
/// Bounces before the body is taken to rest on the floor (with `e = 0.8` the last flight
/// is `0.8⁶⁴ ≈ 10⁻⁶` of the first).
pub const MAX_BOUNCES: usize = 64;

/// A ballistic path with bounces (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ballistic {
    /// Centroid at the range's start.
    pub start: Vec3<f64>,
    /// Velocity at the range's start (scene units per unit time).
    pub velocity: Vec3<f64>,
    /// Constant acceleration (gravity; points down).
    pub accel: Vec3<f64>,
    /// Depth of the floor along the acceleration's direction.
    pub floor: f64,
    /// Coefficient of restitution (clamped to `[0, 1]` where it is used).
    pub restitution: f64,
}

impl Ballistic {
    /// The parameters in the order start, velocity, acceleration, floor, restitution.
    #[must_use]
    pub fn to_flat(&self) -> [f64; BALLISTIC_PARAMS] {
        let mut p = [0.0; BALLISTIC_PARAMS];
        p[..3].copy_from_slice(&self.start.to_array());
        p[3..6].copy_from_slice(&self.velocity.to_array());
        p[6..9].copy_from_slice(&self.accel.to_array());
        p[9] = self.floor;
        p[10] = self.restitution;
        p
    }

    /// The inverse of [`Self::to_flat`].
    #[must_use]
    pub fn from_flat(p: &[f64]) -> Self {
        Self {
            start: Vec3::from_slice(&p[..3]),
            velocity: Vec3::from_slice(&p[3..6]),
            accel: Vec3::from_slice(&p[6..9]),
            floor: p[9],
            restitution: p[10],
        }
    }

    /// A first guess from a learnt centroid path, `samples` at elapsed `times` (increasing,
    /// from 0): the path starts at the first sample and accelerates at `accel`; its velocity
    /// is the least-squares fit of the samples up to `until` as one flight, its floor at the
    /// deepest sample and its restitution ½ (neutral between a dead and a perfect bounce).
    #[must_use]
    pub fn guess(samples: &[Vec3<f64>], times: &[f64], accel: Vec3<f64>, until: f64) -> Self {
        let start = samples.first().copied().unwrap_or_else(Vec3::zero);
        let (mut num, mut den) = (Vec3::zero(), 0.0);
        for (&c, &t) in samples.iter().zip(times) {
            if t > 0.0 && t <= until {
                num += (c - start - accel * (0.5 * t * t)) * t;
                den += t * t;
            }
        }
        let velocity = if den > 0.0 {
            num * den.recip()
        } else {
            Vec3::zero()
        };
        let g = accel.norm();
        let floor = if g > 0.0 {
            let down = accel * g.recip();
            samples
                .iter()
                .map(|c| c.dot(down))
                .fold(f64::NEG_INFINITY, f64::max)
        } else {
            0.0
        };
        Self {
            start,
            velocity,
            accel,
            floor,
            restitution: 0.5,
        }
    }

    /// The centroid at elapsed time `tau` and its velocity.
    #[must_use]
    pub fn at(&self, tau: f64) -> (Vec3<f64>, Vec3<f64>) {
        ballistic_point(&self.to_flat(), tau)
    }
}

/// Number of a flight's numbers a refit moves ([`Ballistic::refit_params`]).
pub const REFIT_PARAMS: usize = 9;

/// Adam rates of a refit's velocity (per unit time), floor depth and restitution logit, and
/// of gravity's magnitude relative to itself: each about a hundredth of the block's scale
/// on `toys` (velocities of order 1, gravity of order 40, a logit of order 5), so that a
/// refit can move a guess by its own size.
const REFIT_RATES: [f64; 4] = [0.02, 0.01, 0.05, 0.02];

/// The logit a refit moves a restitution by (kept off 0 and 1, where it would be infinite):
/// a logistic restitution stays in `(0, 1)`, where its gradient never vanishes as a clamped
/// one's would.
fn restitution_logit(e: f64) -> f64 {
    let e = e.clamp(1e-4, 1.0 - 1e-4);
    (e / (1.0 - e)).ln()
}

/// The logistic function, the inverse of [`restitution_logit`] on `(0, 1)`.
fn sigmoid(x: f64) -> f64 {
    1.0 / (1.0 + (-x).exp())
}

impl Ballistic {
    /// Gravity's direction (unit; zero gravity gives a tiny-norm vector, not a NaN).
    fn down(&self) -> Vec3<f64> {
        self.accel * self.accel.norm().max(f64::MIN_POSITIVE).recip()
    }

    /// The numbers a refit moves: start, velocity, gravity's magnitude (its direction is
    /// held: free, it trades against the horizontal velocity), floor depth and the
    /// restitution's logit.
    #[must_use]
    pub fn refit_params(&self) -> [f64; REFIT_PARAMS] {
        let (s, v) = (self.start.to_array(), self.velocity.to_array());
        [
            s[0],
            s[1],
            s[2],
            v[0],
            v[1],
            v[2],
            self.accel.norm(),
            self.floor,
            restitution_logit(self.restitution),
        ]
    }

    /// Sets the flight from [`Self::refit_params`]' layout, gravity keeping its direction
    /// (and a magnitude above zero, to keep it).
    pub fn set_refit_params(&mut self, p: &[f64; REFIT_PARAMS]) {
        let down = self.down();
        *self = Self {
            start: Vec3::from_slice(&p[..3]),
            velocity: Vec3::from_slice(&p[3..6]),
            accel: down * p[6].max(1e-9),
            floor: p[7],
            restitution: sigmoid(p[8]),
        };
    }

    /// Adam rates of [`Self::refit_params`]' blocks `(start, end, rate)`, the start's
    /// `start_rate` (scene units).
    #[must_use]
    pub fn refit_rates(&self, start_rate: f64) -> [(usize, usize, f64); 5] {
        let [v, f, e, g] = REFIT_RATES;
        [
            (0, 3, start_rate),
            (3, 6, v),
            (6, 7, g * self.accel.norm()),
            (7, 8, f),
            (8, 9, e),
        ]
    }

    /// The VJP of the centroid at elapsed `tau` with respect to [`Self::refit_params`],
    /// given the position's cotangent `g`.
    #[must_use]
    pub fn refit_vjp(&self, tau: f64, g: Vec3<f64>) -> [f64; REFIT_PARAMS] {
        let gb = ballistic_point_vjp(&self.to_flat(), tau, g);
        let e = self.restitution;
        let mut out = [0.0; REFIT_PARAMS];
        out[..6].copy_from_slice(&gb[..6]);
        out[6] = Vec3::from_slice(&gb[6..9]).dot(self.down());
        out[7] = gb[9];
        // Through the logistic map of the logit.
        out[8] = gb[10] * e * (1.0 - e);
        out
    }
}

/// The depth of the surface a thrown body lands on: the `quantile` (a fraction) of the depths
/// along `down` (unit) of the opaque points (`opaque[i]`) not in `exclude` that lie deeper
/// than every point of the body's `track` and within `reach` of it across `down` (so under
/// it). `None` when there is no such point.
#[must_use]
pub fn support_depth(
    points: &[Vec3<f64>],
    opaque: impl Fn(usize) -> bool,
    exclude: &[usize],
    (track, down, reach): (&[Vec3<f64>], Vec3<f64>, f64),
    quantile: f64,
) -> Option<f64> {
    let deepest = track
        .iter()
        .map(|c| c.dot(down))
        .fold(f64::NEG_INFINITY, f64::max);
    let across = |p: Vec3<f64>| p - down * p.dot(down);
    let mut skip = vec![false; points.len()];
    for &i in exclude {
        skip[i] = true;
    }
    let mut depths: Vec<f64> = (0..points.len())
        .filter(|&i| !skip[i] && opaque(i))
        .filter(|&i| {
            let p = points[i];
            p.dot(down) > deepest
                && track
                    .iter()
                    .any(|&c| across(p - c).norm_squared() <= reach * reach)
        })
        .map(|i| points[i].dot(down))
        .collect();
    if depths.is_empty() {
        return None;
    }
    depths.sort_by(f64::total_cmp);
    #[allow(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        clippy::cast_precision_loss,
        reason = "an index into the sorted depths"
    )]
    let k = ((depths.len() - 1) as f64 * quantile.clamp(0.0, 1.0)).round() as usize;
    Some(depths[k])
}

/// Time of flight from depth `d` with normal velocity `u` (down positive) under `g` until
/// the depth reaches `f`, or `None` if it never does. Both branches add positive terms, so
/// neither cancels.
fn flight_time<T: Real>(d: T, u: T, g: T, f: T) -> Option<T> {
    let gap = f - d;
    if gap < T::ZERO {
        return None;
    }
    let root = (u * u + T::TWO * g * gap).max(T::ZERO).sqrt();
    if u >= T::ZERO {
        let den = u + root;
        (den > T::ZERO).then(|| T::TWO * gap / den)
    } else {
        (g > T::ZERO).then(|| (root - u) / g)
    }
}

/// The centroid of the ballistic path with parameters `p` (the layout of
/// [`Ballistic::to_flat`]) at elapsed time `tau ≥ 0`, and its velocity (module doc).
pub fn ballistic_point<T: Real>(p: &[T; BALLISTIC_PARAMS], tau: T) -> (Vec3<T>, Vec3<T>) {
    let (mut x, mut v) = (Vec3::new(p[0], p[1], p[2]), Vec3::new(p[3], p[4], p[5]));
    let a = Vec3::new(p[6], p[7], p[8]);
    let (floor, e) = (p[9], p[10].clamp(T::ZERO, T::ONE));
    let g = a.norm();
    let parabola = |x: Vec3<T>, v: Vec3<T>, s: T| (x + v * s + a * (T::HALF * s * s), v + a * s);
    if g <= T::EPSILON {
        return parabola(x, v, tau);
    }
    let down = a * g.recip();
    let mut elapsed = T::ZERO;
    // At rest on the floor: it slides at its tangential velocity.
    let rest = |x: Vec3<T>, v: Vec3<T>, s: T| {
        let vt = v - down * v.dot(down);
        (x + vt * s, vt)
    };
    for k in 0..=MAX_BOUNCES {
        // After a bounce the centroid is on the floor by construction.
        let d = if k == 0 { x.dot(down) } else { floor };
        let Some(s) = flight_time(d, v.dot(down), g, floor) else {
            if k == 0 {
                break;
            }
            return rest(x, v, tau - elapsed);
        };
        if elapsed + s >= tau {
            break;
        }
        if k == MAX_BOUNCES {
            return rest(x, v, tau - elapsed);
        }
        let (xb, vb) = parabola(x, v, s);
        x = xb;
        v = vb - down * ((T::ONE + e) * vb.dot(down));
        elapsed += s;
    }
    parabola(x, v, tau - elapsed)
}

/// The VJP of [`ballistic_point`]'s position with respect to its parameters, given the
/// position's cotangent `g`: `Jᵀ g`, the Jacobian's columns taken exactly by dual numbers.
#[must_use]
pub fn ballistic_point_vjp(
    p: &[f64; BALLISTIC_PARAMS],
    tau: f64,
    g: Vec3<f64>,
) -> [f64; BALLISTIC_PARAMS] {
    let mut out = [0.0; BALLISTIC_PARAMS];
    for (j, o) in out.iter_mut().enumerate() {
        let mut pd = p.map(Dual::constant);
        pd[j] = Dual::variable(p[j]);
        let (x, _) = ballistic_point(&pd, Dual::constant(tau));
        *o = g.x * x.x.eps + g.y * x.y.eps + g.z * x.z.eps;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The `toys` ball in normalised time (`meta.json`: T = 2 s, g = 9.81 m/s², e = 0.8,
    /// centre floor at z = −0.68): bounces at 0.5889 s, 1.4007 s and 2.0501 s.
    fn toys_ball() -> Ballistic {
        Ballistic {
            start: Vec3::new(-0.85, -0.7, 0.55),
            velocity: Vec3::new(1.2, 0.0, 1.6),
            accel: Vec3::new(0.0, 0.0, -9.81 * 4.0),
            floor: 0.68,
            restitution: 0.8,
        }
    }

    #[test]
    fn bounces_when_and_where_the_closed_form_says() {
        let b = toys_ball();
        for t_s in [0.588_910_097_116_604_6, 1.400_687_149_547_004_6] {
            let tau = t_s / 2.0;
            let (x, _) = b.at(tau);
            assert!((x.z + 0.68).abs() < 1e-9, "on the floor at {t_s} s: {x:?}");
            // Just before, falling; just after, rising.
            let (_, vb) = b.at(tau - 1e-6);
            let (_, va) = b.at(tau + 1e-6);
            assert!(vb.z < 0.0 && va.z > 0.0, "{vb:?} {va:?}");
            assert!(
                (va.z + 0.8 * vb.z).abs() < 1e-3,
                "restitution: {vb:?} {va:?}"
            );
            // The horizontal motion is untouched.
            assert!((x.x - (-0.85 + 1.2 * tau)).abs() < 1e-12);
        }
        // Never below the floor.
        for k in 0..=1000 {
            let tau = f64::from(k) / 1000.0;
            assert!(b.at(tau).0.z >= -0.68 - 1e-12);
        }
        // The first arc: a parabola.
        let (x, v) = b.at(0.1);
        assert!((x.z - (0.55 + 0.16 - 0.5 * 39.24 * 0.01)).abs() < 1e-12);
        assert!((v.z - (1.6 - 3.924)).abs() < 1e-12);
    }

    #[test]
    fn comes_to_rest_and_slides() {
        let mut b = toys_ball();
        b.restitution = 0.3;
        let (x, v) = b.at(5.0);
        assert!((x.z + 0.68).abs() < 1e-9 && v.z == 0.0, "{x:?} {v:?}");
        assert!((v.x - 1.2).abs() < 1e-12);
        // With no restitution it stops at the first landing.
        b.restitution = 0.0;
        let (x, v) = b.at(0.5);
        assert!((x.z + 0.68).abs() < 1e-9 && v.z == 0.0, "{x:?} {v:?}");
    }

    #[test]
    fn vjp_matches_central_differences() {
        let p = toys_ball().to_flat();
        let g = Vec3::new(0.3, -0.7, 1.1);
        // Inside the first, second and third flights and before any bounce.
        for tau in [0.1, 0.45, 0.85, 0.2] {
            let got = ballistic_point_vjp(&p, tau, g);
            let h = 1e-6;
            for j in 0..BALLISTIC_PARAMS {
                let (mut a, mut b) = (p, p);
                a[j] += h;
                b[j] -= h;
                let fd =
                    (ballistic_point(&a, tau).0 - ballistic_point(&b, tau).0).dot(g) / (2.0 * h);
                assert!(
                    (got[j] - fd).abs() < 1e-6 * (1.0 + fd.abs()),
                    "τ {tau}, parameter {j}: {} vs {fd}",
                    got[j]
                );
            }
        }
    }

    #[test]
    fn velocity_is_the_time_derivative() {
        let b = toys_ball();
        for tau in [0.1, 0.45, 0.85] {
            let h = 1e-6;
            let fd = (b.at(tau + h).0 - b.at(tau - h).0) * (0.5 / h);
            assert!((b.at(tau).1 - fd).norm() < 1e-6);
        }
    }

    #[test]
    fn the_guess_recovers_a_flight_it_samples() {
        let b = toys_ball();
        // Samples of the first flight only (it lands at τ ≈ 0.294), to τ = 0.25.
        let times: Vec<f64> = (0..=8).map(|k| f64::from(k) / 32.0).collect();
        let samples: Vec<Vec3<f64>> = times.iter().map(|&t| b.at(t).0).collect();
        let g = Ballistic::guess(&samples, &times, b.accel, 0.25);
        assert!((g.start - b.start).norm() < 1e-12);
        assert!((g.velocity - b.velocity).norm() < 1e-12, "{:?}", g.velocity);
        // Its floor is the deepest sample: above the true one, so it bounces early.
        assert!((g.floor + samples[8].z).abs() < 1e-12 && g.floor < b.floor);
        assert_eq!((g.accel, g.restitution), (b.accel, 0.5));
    }

    #[test]
    fn the_support_is_the_top_of_what_lies_under_the_track() {
        let down = Vec3::new(0.0, 0.0, -1.0);
        // A slab with its top at z = −1 (depth 1) under x ∈ [−2, 2], a floater at z = 0.5
        // above the track, one far to the side, a transparent one and the body's own.
        let mut points: Vec<Vec3<f64>> = (0..=40)
            .flat_map(|i| {
                (0..5).map(move |k| {
                    Vec3::new(f64::from(i) * 0.1 - 2.0, 0.0, -1.0 - f64::from(k) * 0.1)
                })
            })
            .collect();
        let n = points.len();
        points.extend([
            Vec3::new(0.0, 0.0, 0.5),
            Vec3::new(0.0, 3.0, -0.5),
            Vec3::new(0.1, 0.0, -0.6),
            Vec3::new(0.0, 0.0, -0.7),
        ]);
        let track = [Vec3::new(-0.5, 0.0, 0.0), Vec3::new(0.5, 0.0, -0.2)];
        let top = support_depth(&points, |i| i != n + 2, &[n + 3], (&track, down, 0.3), 0.0);
        assert_eq!(top, Some(1.0));
        // The median of the slab's depths under the track (1.0 to 1.4).
        let mid = support_depth(&points, |_| true, &[n + 2, n + 3], (&track, down, 0.3), 0.5);
        assert!((mid.expect("some") - 1.2).abs() < 1e-12, "{mid:?}");
        assert_eq!(
            support_depth(&points, |_| false, &[], (&track, down, 0.3), 0.0),
            None
        );
    }

    #[test]
    fn flat_layout_round_trips() {
        let b = toys_ball();
        assert_eq!(Ballistic::from_flat(&b.to_flat()), b);
    }
}
