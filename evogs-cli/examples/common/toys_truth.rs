//! The true motion of every body of the `toys` scene, from its `meta.json` (copied in
//! `tools/data/toys-meta.json`): the rigid bodies' body-to-world transforms at every frame
//! (interpolated between frames: translation linearly, rotation along the geodesic) and the
//! flag's vertex formula. For diagnostics only: training never sees any of this.

use evogs_math::so3::{exp_quat, log_quat, quat_from_matrix};
use evogs_math::{Mat3, Quat, Vec3};
use serde_json::Value;
use std::f64::consts::TAU;

/// Which body a point belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Body {
    /// The platform, the pole, or empty space.
    Static,
    /// A rigid body (index into [`Truth::rigid`]).
    Rigid(usize),
    /// The flag, at flag coordinates `(s, w)` (stored by the caller).
    Flag,
}

/// A rigid body's motion between two times: the rotation `rel` about its origin, which moves
/// from `from` to `to`.
pub(crate) struct Carry {
    /// The rotation from the earlier pose to the later one.
    pub(crate) rel: Quat<f64>,
    from: Vec3<f64>,
    to: Vec3<f64>,
}

impl Carry {
    /// Where a point of the body at `p` at the earlier time is at the later one.
    pub(crate) fn apply(&self, p: Vec3<f64>) -> Vec3<f64> {
        self.rel.rotate(p - self.from) + self.to
    }
}

/// A rigid body's pose at the sampled times.
pub(crate) struct RigidTrack {
    /// Frame times, increasing.
    times: Vec<f64>,
    /// Body-to-world rotations and translations at those times.
    poses: Vec<(Quat<f64>, Vec3<f64>)>,
}

impl RigidTrack {
    /// The body-to-world pose at `t` (clamped to the sampled range).
    pub(crate) fn pose(&self, t: f64) -> (Quat<f64>, Vec3<f64>) {
        let j = self.times.partition_point(|&s| s <= t);
        if j == 0 {
            return self.poses[0];
        }
        if j == self.times.len() {
            return self.poses[j - 1];
        }
        let (t0, t1) = (self.times[j - 1], self.times[j]);
        let a = if t1 > t0 { (t - t0) / (t1 - t0) } else { 0.0 };
        let (q0, c0) = self.poses[j - 1];
        let (q1, c1) = self.poses[j];
        let mut rel = q0.conj().mul_quat(q1);
        if rel.w < 0.0 {
            rel = -rel;
        }
        let q = q0.mul_quat(exp_quat(log_quat(rel) * a));
        (q, c0 + (c1 - c0) * a)
    }

    /// The body's motion from its pose at `t0` to its pose at `t`.
    pub(crate) fn carry(&self, t0: f64, t: f64) -> Carry {
        let (qa, from) = self.pose(t0);
        let (qb, to) = self.pose(t);
        Carry {
            rel: qb.mul_quat(qa.conj()),
            from,
            to,
        }
    }

    /// The point `p` (world, at `t0`) in body coordinates.
    pub(crate) fn to_body(&self, t0: f64, p: Vec3<f64>) -> Vec3<f64> {
        let (q, c) = self.pose(t0);
        q.rotate_inv(p - c)
    }
}

/// The flag's vertex formula and its parameters (`meta.json`, `objects.flag`).
pub(crate) struct FlagMotion {
    a0: f64,
    f_hz: f64,
    k: f64,
    width: f64,
    height: f64,
    z0: f64,
    pole: [f64; 2],
    /// Physical seconds per unit of normalised time.
    seconds: f64,
}

impl FlagMotion {
    fn load(meta: &Value) -> Self {
        let flag = &meta["objects"]["flag"];
        let n = |v: &Value| v.as_f64().expect("a flag parameter");
        Self {
            a0: n(&flag["A0"]),
            f_hz: n(&flag["f_hz"]),
            k: n(&flag["k"]),
            width: n(&flag["W"]),
            height: n(&flag["H"]),
            z0: n(&flag["z0"]),
            pole: [n(&flag["pole_xy"][0]), n(&flag["pole_xy"][1])],
            seconds: n(&meta["time"]["T_phys_s"]),
        }
    }

    /// The flag's surface point at flag coordinates `(s, w)` and normalised time `t`.
    pub(crate) fn point(&self, s: f64, w: f64, t: f64) -> Vec3<f64> {
        let tau = t * self.seconds;
        let amp = self.a0 * (1.0 + 0.3 * (TAU * 0.4 * tau).sin());
        Vec3::new(
            self.pole[0]
                + amp
                    * s.max(0.0).powf(1.3)
                    * (TAU * (self.k * s - self.f_hz * tau) + 0.8 * w).sin(),
            self.pole[1]
                + 0.035
                + self.width * s * (1.0 - 0.04 * s * (1.0 + (TAU * self.f_hz * tau).sin())),
            self.z0 + self.height * w - 0.05 * s * s,
        )
    }

    /// The flag coordinates `(s, w)` of a point at time `t0` if it lies within `margin` of
    /// the flag.
    pub(crate) fn coords(&self, p: Vec3<f64>, t0: f64, margin: f64) -> Option<(f64, f64)> {
        // Invert y and z by a few fixed-point sweeps (the x wave does not enter them).
        let tau = t0 * self.seconds;
        let bend = 0.04 * (1.0 + (TAU * self.f_hz * tau).sin());
        let py = self.pole[1];
        let mut s = (p.y - py - 0.035) / self.width;
        for _ in 0..20 {
            s = (p.y - py - 0.035) / (self.width * (1.0 - bend * s));
        }
        let w = (p.z - self.z0 + 0.05 * s * s) / self.height;
        let inside = (-0.05..=1.05).contains(&s) && (-0.05..=1.05).contains(&w);
        (inside && (self.point(s, w, t0) - p).norm() <= margin).then_some((s, w))
    }
}

/// The scene's motions.
pub(crate) struct Truth {
    /// Cube, torus and ball.
    pub(crate) rigid: [RigidTrack; 3],
    /// The flag.
    pub(crate) flag: FlagMotion,
    /// Sizes used to decide membership: the cube's half edge, the torus's outer radius, the
    /// ball's radius.
    pub(crate) extents: [f64; 3],
}

/// The meta file shipped with the repository.
pub(crate) fn meta_path() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../tools/data/toys-meta.json")
}

impl Truth {
    /// Reads `meta.json`.
    pub(crate) fn load(path: &std::path::Path) -> Self {
        let text = std::fs::read_to_string(path).expect("toys meta.json");
        let meta: Value = serde_json::from_str(&text).expect("meta.json: JSON");
        let rigid = ["cube", "torus", "ball"].map(|name| {
            let mut frames: Vec<(f64, Quat<f64>, Vec3<f64>)> = Vec::new();
            for split in ["train", "val", "test"] {
                for f in meta["frames"][split].as_array().expect("frames") {
                    let m = &f["objects"][name];
                    let e = |r: usize, c: usize| m[r][c].as_f64().expect("a 4x4 matrix");
                    let rot = Mat3::from_rows(core::array::from_fn(|r| {
                        core::array::from_fn(|c| e(r, c))
                    }));
                    let t = f["time"].as_f64().expect("time");
                    frames.push((
                        t,
                        quat_from_matrix(rot),
                        Vec3::new(e(0, 3), e(1, 3), e(2, 3)),
                    ));
                }
            }
            frames.sort_by(|a, b| a.0.total_cmp(&b.0));
            frames.dedup_by(|a, b| (a.0 - b.0).abs() < 1e-12);
            RigidTrack {
                times: frames.iter().map(|f| f.0).collect(),
                poses: frames.iter().map(|f| (f.1, f.2)).collect(),
            }
        });
        let o = &meta["objects"];
        let n = |v: &Value| v.as_f64().expect("a size");
        let extents = [
            n(&o["cube"]["half_size"]),
            n(&o["torus"]["major_radius"]) + n(&o["torus"]["minor_radius"]),
            n(&o["ball"]["radius"]),
        ];
        Self {
            rigid,
            flag: FlagMotion::load(&meta),
            extents,
        }
    }
}
