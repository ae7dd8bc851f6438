//! The learnt motion sampled on a time grid, and the bodies that move together in it.
//!
//! Positions are `Vec3<f64>` in world (scene) units; orientations are quaternions `(w, x, y,
//! z)` rotating body to world; times are the dataset's, over the training range `[t₀, t₁]`.

use super::SpinSearchConfig;
use super::ballistic::Ballistic;
use crate::model::Model;
use evogs_math::so3::exp_quat;
use evogs_math::so3_jacobians::left_jacobian;
use evogs_math::{Quat, Real, Vec3};
use evogs_ode::Stepper;
use evogs_splat::Splats;
use nalgebra::{Matrix3, Rotation3, Vector3};
use std::collections::HashMap;

/// Intervals of the time grid the learnt paths are sampled on.
pub const GRID: usize = 32;

/// Every Gaussian's learnt position and field output at `GRID + 1` evenly spaced times.
#[derive(Clone, Debug)]
pub struct Paths {
    /// Start of the time range.
    pub t_lo: f64,
    /// Length of the time range.
    pub span: f64,
    /// `means[k][i]`: Gaussian `i` at grid time `k`.
    pub means: Vec<Vec<Vec3<f64>>>,
    /// `outputs[k][9i..9i + 9]`: the field's `[v, ω, ṡ]` at Gaussian `i`'s position there.
    pub outputs: Vec<Vec<f32>>,
}

impl Paths {
    /// Samples `model` (dynamics on) over `range`.
    pub fn record(
        model: &mut Model<f32>,
        range: (f64, f64),
        stepper: &mut Option<Stepper<f32>>,
    ) -> Self {
        let n = model.len();
        let (t_lo, span) = (range.0, range.1 - range.0);
        model.field.set_count(n);
        let mut st = Splats::default();
        let mut pos = vec![0f32; 3 * n];
        let (mut means, mut outputs) = (Vec::new(), Vec::new());
        for k in 0..=GRID {
            let t = Self::grid_time(t_lo, span, k);
            model.splats_at(t, stepper, &mut st);
            for (i, m) in st.means.iter().enumerate() {
                m.write_to(&mut pos[3 * i..]);
            }
            let mut o = vec![0f32; 9 * n];
            #[allow(clippy::cast_possible_truncation, reason = "the field runs in f32")]
            model.field.eval_batch(t as f32, &pos, 3, n, &mut o);
            means.push(st.means.iter().map(|m| m.cast()).collect());
            outputs.push(o);
        }
        Self {
            t_lo,
            span,
            means,
            outputs,
        }
    }

    /// Grid time `k`.
    #[must_use]
    pub fn grid_time(t_lo: f64, span: f64, k: usize) -> f64 {
        #[allow(clippy::cast_precision_loss, reason = "a small count")]
        let f = k as f64 / GRID as f64;
        t_lo + span * f
    }

    /// The grid interval holding `t` and the fraction of the way through it.
    #[must_use]
    pub fn locate(t_lo: f64, span: f64, t: f64) -> (usize, f64) {
        #[allow(clippy::cast_precision_loss, reason = "a small count")]
        let u = ((t - t_lo) / span * GRID as f64).clamp(0.0, GRID as f64);
        #[allow(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "clamped to [0, GRID]"
        )]
        let k = (u.floor() as usize).min(GRID - 1);
        #[allow(clippy::cast_precision_loss, reason = "a small count")]
        (k, u - k as f64)
    }
}

/// The path of a body's centroid.
#[derive(Clone, Debug, PartialEq)]
pub enum CentrePath {
    /// The learnt centroid at each grid time, linear between them.
    Sampled(Vec<Vec3<f64>>),
    /// A circle: the centroid turns at `omega` about the axis through `centre`, from the
    /// body's `c0` at the range's start.
    Circle {
        /// A point on the axis.
        centre: Vec3<f64>,
        /// Angular velocity (world frame, radians per unit time).
        omega: Vec3<f64>,
    },
    /// A thrown body's flight, bouncing on a floor (its own start point; [`Ballistic`]).
    Ballistic(Ballistic),
}

impl CentrePath {
    /// The centroid at `t` and its rate, for a body whose centroid is `c0` at the start of
    /// `range` (start, length).
    #[must_use]
    pub fn at(&self, c0: Vec3<f64>, (t_lo, span): (f64, f64), t: f64) -> (Vec3<f64>, Vec3<f64>) {
        match self {
            Self::Circle { centre, omega } => {
                let c = circle_point(*centre, *omega, c0, t - t_lo);
                (c, omega.cross(c - *centre))
            }
            Self::Sampled(centroid) => {
                let (k, f) = Paths::locate(t_lo, span, t);
                let (a, b) = (centroid[k], centroid[k + 1]);
                #[allow(clippy::cast_precision_loss, reason = "a small count")]
                let rate = (b - a) * (GRID as f64 / span);
                (a + (b - a) * f, rate)
            }
            Self::Ballistic(b) => b.at(t - t_lo),
        }
    }
}

/// The point of the circle about the axis through `centre` (angular velocity `omega`)
/// through `c0`, at elapsed time `tau`.
pub fn circle_point<T: Real>(centre: Vec3<T>, omega: Vec3<T>, c0: Vec3<T>, tau: T) -> Vec3<T> {
    centre + exp_quat(omega * tau).rotate(c0 - centre)
}

/// The VJP of [`circle_point`] with respect to `centre` and `omega`, given the cotangent `g`
/// of the point.
pub fn circle_point_vjp<T: Real>(
    centre: Vec3<T>,
    omega: Vec3<T>,
    c0: Vec3<T>,
    tau: T,
    g: Vec3<T>,
) -> (Vec3<T>, Vec3<T>) {
    let r = exp_quat(omega * tau);
    let a = r.rotate(c0 - centre);
    let g_omega = left_jacobian(omega * tau).transpose().mul_vec(a.cross(g)) * tau;
    (g - r.rotate_inv(g), g_omega)
}

/// A group of Gaussians moving together, and its learnt motion as a constant spin.
#[derive(Clone, Debug)]
pub struct Body {
    /// Its Gaussians.
    pub members: Vec<usize>,
    /// How many of them move by more than the threshold.
    pub moving: usize,
    /// Centroid of the moving ones at the canonical time.
    pub c0: Vec3<f64>,
    /// Largest distance of a moving one from `c0`.
    pub radius: f64,
    /// The centroid's path.
    pub path: CentrePath,
    /// Fitted world-frame spin (radians per unit time).
    pub omega: Vec3<f64>,
    /// RMS distance of the members' learnt paths from the per-grid-time rigid fit.
    pub rigid_rms: f64,
    /// Start and length of the time range.
    pub range: (f64, f64),
}

impl Body {
    /// The centroid at `t` (on the circle, or linear between grid times) and its rate.
    #[must_use]
    pub fn centre(&self, t: f64) -> (Vec3<f64>, Vec3<f64>) {
        self.path.at(self.c0, self.range, t)
    }

    /// The largest distance of the centroid's path from its start (for a sampled path, over
    /// its samples; for an orbit or a flight, over the grid times).
    #[must_use]
    pub fn travel(&self) -> f64 {
        let (t_lo, span) = self.range;
        let start = self.centre(t_lo).0;
        (0..=GRID)
            .map(|k| (self.centre(Paths::grid_time(t_lo, span, k)).0 - start).norm())
            .fold(0.0, f64::max)
    }

    /// Position and orientation at `t`, with the spin multiplied by `s`, of a Gaussian at
    /// `p0` turned by `q0` at the canonical time.
    #[must_use]
    pub fn pose(&self, t: f64, s: f64, p0: Vec3<f64>, q0: Quat<f64>) -> (Vec3<f64>, Quat<f64>) {
        let (c, _) = self.centre(t);
        let turn = exp_quat(self.omega * (s * (t - self.range.0)));
        (c + turn.rotate(p0 - self.c0), turn.mul_quat(q0))
    }

    /// Velocity at `t` of the point at `x` on the body spun by `s`, and the spin itself.
    #[must_use]
    pub fn velocity(&self, t: f64, s: f64, x: Vec3<f64>) -> (Vec3<f64>, Vec3<f64>) {
        let (c, cdot) = self.centre(t);
        let w = self.omega * s;
        (cdot + w.cross(x - c), w)
    }
}

/// The rotation `R` minimising `Σ |R aᵢ − bᵢ|²` for centred point sets (Kabsch).
#[must_use]
pub fn kabsch(a: &[Vec3<f64>], b: &[Vec3<f64>]) -> Matrix3<f64> {
    let mut h = Matrix3::<f64>::zeros();
    for (p, q) in a.iter().zip(b) {
        for r in 0..3 {
            for c in 0..3 {
                h[(r, c)] += p[r] * q[c];
            }
        }
    }
    let svd = h.svd(true, true);
    let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
        return Matrix3::identity();
    };
    let v = vt.transpose();
    let d = (v * u.transpose()).determinant().signum();
    v * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * u.transpose()
}

/// Connected components of `points`, linked within `link` (grid hashing).
#[must_use]
pub fn components(points: &[Vec3<f64>], link: f64) -> Vec<Vec<usize>> {
    let key = |p: Vec3<f64>| {
        #[allow(clippy::cast_possible_truncation, reason = "cell indices")]
        let k = |v: f64| (v / link).floor() as i64;
        (k(p.x), k(p.y), k(p.z))
    };
    let mut cells: HashMap<(i64, i64, i64), Vec<usize>> = HashMap::new();
    for (i, &p) in points.iter().enumerate() {
        cells.entry(key(p)).or_default().push(i);
    }
    let mut label = vec![usize::MAX; points.len()];
    let mut out = Vec::new();
    for seed in 0..points.len() {
        if label[seed] != usize::MAX {
            continue;
        }
        let id = out.len();
        label[seed] = id;
        let (mut stack, mut comp) = (vec![seed], Vec::new());
        while let Some(i) = stack.pop() {
            comp.push(i);
            let (x, y, z) = key(points[i]);
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let Some(cell) = cells.get(&(x + dx, y + dy, z + dz)) else {
                            continue;
                        };
                        for &j in cell {
                            if label[j] == usize::MAX && (points[j] - points[i]).norm() <= link {
                                label[j] = id;
                                stack.push(j);
                            }
                        }
                    }
                }
            }
        }
        out.push(comp);
    }
    out
}

/// Mean of `f(i)` over `ids` (not empty).
fn mean(ids: &[usize], f: impl Fn(usize) -> Vec3<f64>) -> Vec3<f64> {
    #[allow(clippy::cast_precision_loss, reason = "a count")]
    let inv = 1.0 / ids.len() as f64;
    ids.iter().fold(Vec3::zero(), |a, &i| a + f(i)) * inv
}

/// Groups the Gaussians of `paths` (canonical positions `p0`) into bodies, largest first:
/// the moving Gaussians linked within `cfg.link`, groups of at least `cfg.min_body`, each
/// joined by the Gaussians within its radius whose learnt path its rigid fit explains at
/// least as well as staying put. Each body's spin is fitted to its per-grid-time rigid
/// rotations up to `cfg.spin_fit_until` of the range.
#[must_use]
pub fn find_bodies(paths: &Paths, p0: &[Vec3<f64>], cfg: &SpinSearchConfig) -> Vec<Body> {
    let n = p0.len();
    let travel = |i: usize| {
        paths
            .means
            .iter()
            .map(|p| (p[i] - p0[i]).norm())
            .fold(0.0, f64::max)
    };
    let moving: Vec<usize> = (0..n).filter(|&i| travel(i) > cfg.move_threshold).collect();
    let mpts: Vec<Vec3<f64>> = moving.iter().map(|&i| p0[i]).collect();
    let mut comps = components(&mpts, cfg.link);
    comps.sort_by_key(|c| std::cmp::Reverse(c.len()));
    let mut bodies = Vec::new();
    let mut taken = vec![false; n];
    for comp in comps.iter().filter(|c| c.len() >= cfg.min_body) {
        let core: Vec<usize> = comp.iter().map(|&j| moving[j]).collect();
        let mut in_core = vec![false; n];
        for &i in &core {
            in_core[i] = true;
        }
        let c0 = mean(&core, |i| p0[i]);
        let radius = core
            .iter()
            .map(|&i| (p0[i] - c0).norm())
            .fold(0.0, f64::max);
        let a: Vec<Vec3<f64>> = core.iter().map(|&i| p0[i] - c0).collect();
        let (mut rots, mut centroid) = (Vec::new(), Vec::new());
        for path in &paths.means {
            let c = mean(&core, |i| path[i]);
            let b: Vec<Vec3<f64>> = core.iter().map(|&i| path[i] - c).collect();
            rots.push(kabsch(&a, &b));
            centroid.push(c);
        }
        let rigid_err = |i: usize| {
            let d = p0[i] - c0;
            paths
                .means
                .iter()
                .zip(&rots)
                .zip(&centroid)
                .map(|((path, r), c)| {
                    let v = r * Vector3::new(d.x, d.y, d.z);
                    (path[i] - (*c + Vec3::new(v.x, v.y, v.z))).norm_squared()
                })
                .sum::<f64>()
        };
        let still_err = |i: usize| {
            paths
                .means
                .iter()
                .map(|path| (path[i] - p0[i]).norm_squared())
                .sum::<f64>()
        };
        let members: Vec<usize> = (0..n)
            .filter(|&i| {
                !taken[i]
                    && (p0[i] - c0).norm() <= radius
                    && (in_core[i] || rigid_err(i) <= still_err(i))
            })
            .collect();
        for &i in &members {
            taken[i] = true;
        }
        let (mut num, mut den) = (Vec3::zero(), 0.0);
        for (k, r) in rots.iter().enumerate() {
            let t = Paths::grid_time(0.0, paths.span, k);
            if k == 0 || t > cfg.spin_fit_until * paths.span {
                continue;
            }
            let th = Rotation3::from_matrix_unchecked(*r).scaled_axis();
            num += Vec3::new(th.x, th.y, th.z) * t;
            den += t * t;
        }
        let omega = if den > 0.0 {
            num * (1.0 / den)
        } else {
            Vec3::zero()
        };
        #[allow(clippy::cast_precision_loss, reason = "counts")]
        let rigid_rms = (members.iter().map(|&i| rigid_err(i)).sum::<f64>()
            / (members.len() * (GRID + 1)).max(1) as f64)
            .sqrt();
        bodies.push(Body {
            members,
            moving: core.len(),
            c0,
            radius,
            path: CentrePath::Sampled(centroid),
            omega,
            rigid_rms,
            range: (paths.t_lo, paths.span),
        });
    }
    bodies
}

#[cfg(test)]
mod tests {
    use super::*;
    use evogs_math::rng::SplitMix64;

    fn random_points(rng: &mut SplitMix64, n: usize, half: f64) -> Vec<Vec3<f64>> {
        (0..n)
            .map(|_| {
                Vec3::new(
                    rng.uniform(-half, half),
                    rng.uniform(-half, half),
                    rng.uniform(-half, half),
                )
            })
            .collect()
    }

    #[test]
    fn kabsch_recovers_a_rotation() {
        let mut rng = SplitMix64::new(3);
        let a = random_points(&mut rng, 50, 1.0);
        let q = exp_quat(Vec3::new(0.3, -1.2, 2.0));
        let b: Vec<Vec3<f64>> = a.iter().map(|&p| q.rotate(p)).collect();
        let r = kabsch(&a, &b);
        for (p, want) in a.iter().zip(&b) {
            let got = r * Vector3::new(p.x, p.y, p.z);
            assert!((Vec3::new(got.x, got.y, got.z) - *want).norm() < 1e-12);
        }
        assert!((r.determinant() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn components_link_chains_and_split_gaps() {
        let p = |x: f64| Vec3::new(x, 0.0, 0.0);
        // A chain 0.03 apart (linked at 0.04), a gap of 0.1, a pair.
        let pts = vec![p(0.0), p(0.03), p(0.06), p(0.09), p(0.19), p(0.22)];
        let mut comps = components(&pts, 0.04);
        for c in &mut comps {
            c.sort_unstable();
        }
        comps.sort();
        assert_eq!(comps, vec![vec![0, 1, 2, 3], vec![4, 5]]);
    }

    /// A static slab and a ball spinning at `omega` about `c` (which drifts at `drift`).
    fn scene(omega: Vec3<f64>, c: Vec3<f64>, drift: Vec3<f64>) -> (Paths, Vec<Vec3<f64>>, usize) {
        let mut rng = SplitMix64::new(9);
        let mut p0: Vec<Vec3<f64>> = random_points(&mut rng, 400, 1.0)
            .into_iter()
            .map(|p| Vec3::new(p.x, p.y, 0.02 * p.z - 1.0))
            .collect();
        let statics = p0.len();
        p0.extend(
            random_points(&mut rng, 4000, 0.2)
                .into_iter()
                .filter(|p| p.norm() <= 0.2)
                .map(|p| p + c),
        );
        let means = (0..=GRID)
            .map(|k| {
                let t = Paths::grid_time(0.0, 1.0, k);
                let turn = exp_quat(omega * t);
                p0.iter()
                    .enumerate()
                    .map(|(i, &p)| {
                        if i < statics {
                            p
                        } else {
                            c + drift * t + turn.rotate(p - c)
                        }
                    })
                    .collect()
            })
            .collect();
        let paths = Paths {
            t_lo: 0.0,
            span: 1.0,
            means,
            outputs: Vec::new(),
        };
        (paths, p0, statics)
    }

    #[test]
    fn find_bodies_recovers_a_spinning_ball() {
        let omega = Vec3::new(0.5, -1.0, 2.5);
        let (c, drift) = (Vec3::new(0.3, 0.2, 0.1), Vec3::new(0.2, 0.0, -0.1));
        let (paths, p0, statics) = scene(omega, c, drift);
        let bodies = find_bodies(&paths, &p0, &SpinSearchConfig::default());
        assert_eq!(bodies.len(), 1);
        let b = &bodies[0];
        // Every ball Gaussian, near the axis too, and no static one.
        assert_eq!(b.members, (statics..p0.len()).collect::<Vec<_>>());
        assert!((b.omega - omega).norm() < 1e-9, "{:?}", b.omega);
        assert!(b.rigid_rms < 1e-9);
        // The pose at ×1 is the path (at a grid time: the centroid is linear between them);
        // the velocity is the pose's time derivative.
        let q0 = Quat::new(1.0, 0.0, 0.0, 0.0);
        let i = statics + 5;
        let t = Paths::grid_time(0.0, 1.0, 12);
        let want = c + drift * t + exp_quat(omega * t).rotate(p0[i] - c);
        let (x, q) = b.pose(t, 1.0, p0[i], q0);
        assert!((x - want).norm() < 1e-9);
        assert!(
            (q.rotate(Vec3::new(1.0, 0.0, 0.0))
                - exp_quat(omega * t).rotate(Vec3::new(1.0, 0.0, 0.0)))
            .norm()
                < 1e-12
        );
        let (t, h) = (0.37, 1e-5);
        let (v, w) = b.velocity(t, 2.0, b.pose(t, 2.0, p0[i], q0).0);
        let fd = (b.pose(t + h, 2.0, p0[i], q0).0 - b.pose(t - h, 2.0, p0[i], q0).0) * (0.5 / h);
        assert!((v - fd).norm() < 1e-6, "{v:?} vs {fd:?}");
        assert!((w - omega * 2.0).norm() < 1e-12);
    }

    #[test]
    fn travel_is_the_farthest_the_centroid_gets() {
        // Half a turn of a circle of radius 1 over the range: a diameter.
        let body = Body {
            members: Vec::new(),
            moving: 0,
            c0: Vec3::new(1.0, 0.0, 0.0),
            radius: 0.1,
            path: CentrePath::Circle {
                centre: Vec3::zero(),
                omega: Vec3::new(0.0, 0.0, std::f64::consts::PI / 2.0),
            },
            omega: Vec3::zero(),
            rigid_rms: 0.0,
            range: (1.0, 2.0),
        };
        assert!((body.travel() - 2.0).abs() < 1e-12, "{}", body.travel());
        let still = Body {
            path: CentrePath::Sampled(vec![body.c0; GRID + 1]),
            ..body
        };
        assert!(still.travel() == 0.0);
    }

    #[test]
    fn still_gaussians_make_no_body() {
        let (paths, p0, _) = scene(Vec3::zero(), Vec3::new(0.3, 0.2, 0.1), Vec3::zero());
        assert!(find_bodies(&paths, &p0, &SpinSearchConfig::default()).is_empty());
    }
}
