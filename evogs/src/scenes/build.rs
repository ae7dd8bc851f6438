//! A scene built from its specification: every body's Gaussians in its own frame, and the
//! Gaussians of the whole scene (or of its moving bodies alone) at any time.

use super::body::BodyGaussian;
use super::catalogue::{BodySpec, SceneSpec, floor};
use super::ground_truth::{BodyTruth, FORMAT, GroundTruth, RigidSample};
use evogs_math::activation::logit;
use evogs_math::rng::SplitMix64;
use evogs_math::sh::SH_C0;
use evogs_math::so3::quat_from_matrix;
use evogs_math::{Quat, Vec3};
use evogs_splat::{SH_OFFSET, Splats};

/// Opacity of every Gaussian.
const OPACITY: f64 = 0.97;
/// The colours bodies pick from (floor: the first two).
const PALETTE: [[f64; 3]; 8] = [
    [0.82, 0.80, 0.74],
    [0.35, 0.38, 0.42],
    [0.90, 0.25, 0.15],
    [0.15, 0.45, 0.90],
    [0.95, 0.80, 0.10],
    [0.20, 0.70, 0.30],
    [0.75, 0.20, 0.75],
    [0.10, 0.75, 0.80],
];
/// The sample spacing of `motion.json`'s rigid transforms.
const SAMPLE_STEP: f64 = 0.01;
/// The time range of `motion.json`'s samples.
pub const SAMPLE_RANGE: [f64; 2] = [-0.3, 1.3];

/// Gaussian spacing of the floor and of the bodies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spacing {
    /// Floor spacing (world units).
    pub floor: f64,
    /// Body spacing (world units).
    pub body: f64,
}

impl Default for Spacing {
    fn default() -> Self {
        Self {
            floor: 0.1,
            body: 0.045,
        }
    }
}

/// One body of a built scene.
#[derive(Clone, Debug)]
pub struct BuiltBody {
    /// Its specification.
    pub spec: BodySpec,
    /// Its Gaussians in the body frame.
    pub gaussians: Vec<BodyGaussian>,
    /// Index of its first Gaussian in the scene.
    pub first: usize,
}

/// A scene with its Gaussians: the floor first, then the moving bodies in order.
#[derive(Clone, Debug)]
pub struct BuiltScene {
    /// The scene's name.
    pub name: String,
    /// The generator's seed.
    pub seed: u64,
    /// The bodies, the floor first.
    pub bodies: Vec<BuiltBody>,
}

impl BuiltScene {
    /// Builds `spec` with Gaussians `spacing` apart; colours are jittered from `seed`.
    #[must_use]
    pub fn new(spec: &SceneSpec, spacing: Spacing, seed: u64) -> Self {
        let mut rng = SplitMix64::new(seed);
        let mut bodies = Vec::with_capacity(spec.bodies.len() + 1);
        let mut first = 0;
        for (k, b) in std::iter::once(floor())
            .chain(spec.bodies.iter().copied())
            .enumerate()
        {
            let step = if k == 0 { spacing.floor } else { spacing.body };
            let palette: Vec<[f64; 3]> = if k == 0 {
                PALETTE[..2].to_vec()
            } else {
                (0..4)
                    .map(|i| PALETTE[2 + (b.palette - 2 + i) % (PALETTE.len() - 2)])
                    .collect()
            };
            let c = Vec3::new(b.centre[0], b.centre[1], b.centre[2]);
            let gaussians = b.shape.gaussians(c, step, &palette, &mut rng);
            let n = gaussians.len();
            bodies.push(BuiltBody {
                spec: b,
                gaussians,
                first,
            });
            first += n;
        }
        Self {
            name: spec.name.to_string(),
            seed,
            bodies,
        }
    }

    /// Number of Gaussians.
    #[must_use]
    pub fn len(&self) -> usize {
        self.bodies.iter().map(|b| b.gaussians.len()).sum()
    }

    /// `true` without Gaussians.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The Gaussians at `t` (SH degree 0), of every body or of the moving bodies alone.
    #[must_use]
    pub fn splats_at(&self, t: f64, moving_only: bool) -> Splats<f64> {
        let mut s = Splats::new(0);
        let o = logit(OPACITY);
        for b in &self.bodies {
            if moving_only && !b.spec.law.is_moving() {
                continue;
            }
            let (r, _) = b.spec.law.world_from_body(t);
            let qr = quat_from_matrix(r);
            for g in &b.gaussians {
                let mean = b.spec.law.position(g.position, t);
                let q: Quat<f64> = qr.mul_quat(g.rotation);
                let log_scale = g.scale.map(f64::ln);
                let dc = g.color.map(|c| (c - SH_OFFSET) / SH_C0);
                s.push(mean, log_scale, q, o, &[dc]);
            }
        }
        s
    }

    /// The ground truth of the scene's motion (`motion.json`).
    #[must_use]
    pub fn ground_truth(&self) -> GroundTruth {
        #[allow(clippy::cast_possible_truncation, reason = "a small positive count")]
        let n = ((SAMPLE_RANGE[1] - SAMPLE_RANGE[0]) / SAMPLE_STEP).round() as usize + 1;
        let sample_times: Vec<f64> = (0..n)
            .map(|i| SAMPLE_RANGE[0] + i as f64 * SAMPLE_STEP)
            .collect();
        let bodies = self
            .bodies
            .iter()
            .map(|b| BodyTruth {
                name: b.spec.name.to_string(),
                moving: b.spec.law.is_moving(),
                law: b.spec.law,
                samples: sample_times
                    .iter()
                    .map(|&t| {
                        let (r, p) = b.spec.law.world_from_body(t);
                        RigidSample {
                            rotation: r.m,
                            translation: p.to_array(),
                        }
                    })
                    .collect(),
                gaussians: (b.first..b.first + b.gaussians.len()).collect(),
                body_points: b.gaussians.iter().map(|g| g.position.to_array()).collect(),
            })
            .collect();
        GroundTruth {
            format: FORMAT.to_string(),
            scene: self.name.clone(),
            seed: self.seed,
            sample_times,
            bodies,
        }
    }
}
