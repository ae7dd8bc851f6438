//! The trajectory error of a trained model against a scene's ground truth.
//!
//! Each model Gaussian is assigned to the body of the nearest ground-truth Gaussian at the
//! split time `τ` (the end of the training window). For a Gaussian assigned to a moving body
//! at `x(τ)`, the body's law carries that point on: `x*(t) = law.position(body_point(x(τ), τ), t)`.
//! The error at `t` is `|x(t) − x*(t)|`, reported as a mean over those Gaussians and relative
//! to the mean distance travelled since `τ`, `|x*(t) − x(τ)|`.

use super::ground_truth::GroundTruth;
use crate::field::Gemm;
use crate::model::Model;
use evogs_math::Vec3;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// Cell size of the nearest-neighbour grid (the scenes' Gaussians are ~0.05 to 0.1 apart).
const CELL: f64 = 0.1;
/// Grid rings searched before giving up on a neighbour.
const MAX_RING: i64 = 40;

/// The trajectory error at one time.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrajectoryError {
    /// The split time `τ`.
    pub split: f64,
    /// The time measured.
    pub time: f64,
    /// Model Gaussians assigned to a moving body.
    pub gaussians: usize,
    /// Mean distance to the ground truth.
    pub mean_error: f64,
    /// Mean distance the ground truth travelled since `τ`.
    pub mean_travel: f64,
    /// `mean_error / mean_travel`.
    pub relative: f64,
}

/// Ground-truth Gaussians at one time in a uniform grid.
struct Grid {
    cells: HashMap<[i64; 3], Vec<(usize, Vec3<f64>)>>,
}

fn cell_of(p: Vec3<f64>) -> [i64; 3] {
    #[allow(
        clippy::cast_possible_truncation,
        reason = "scene coordinates are small"
    )]
    let c = [p.x, p.y, p.z].map(|v| (v / CELL).floor() as i64);
    c
}

impl Grid {
    fn new(points: impl Iterator<Item = (usize, Vec3<f64>)>) -> Self {
        let mut cells: HashMap<[i64; 3], Vec<(usize, Vec3<f64>)>> = HashMap::new();
        for (tag, p) in points {
            cells.entry(cell_of(p)).or_default().push((tag, p));
        }
        Self { cells }
    }

    /// The tag of the nearest point within [`MAX_RING`] cells.
    fn nearest(&self, q: Vec3<f64>) -> Option<usize> {
        let c = cell_of(q);
        let mut best: Option<(f64, usize)> = None;
        for r in 0..=MAX_RING {
            for dx in -r..=r {
                for dy in -r..=r {
                    for dz in -r..=r {
                        if dx.abs().max(dy.abs()).max(dz.abs()) != r {
                            continue;
                        }
                        let Some(pts) = self.cells.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else {
                            continue;
                        };
                        for &(tag, p) in pts {
                            let d = (p - q).norm();
                            if best.is_none_or(|(bd, _)| d < bd) {
                                best = Some((d, tag));
                            }
                        }
                    }
                }
            }
            if let Some((d, tag)) = best
                && d <= r as f64 * CELL
            {
                return Some(tag);
            }
        }
        best.map(|(_, tag)| tag)
    }
}

/// The trajectory error at `t` of Gaussians that are at `at_split` at `split` and at `at_t`
/// at `t`; `None` when no Gaussian is assigned to a moving body.
///
/// # Panics
/// If `at_split` and `at_t` differ in length.
#[must_use]
pub fn trajectory_error(
    truth: &GroundTruth,
    at_split: &[Vec3<f64>],
    at_t: &[Vec3<f64>],
    split: f64,
    t: f64,
) -> Option<TrajectoryError> {
    assert_eq!(
        at_split.len(),
        at_t.len(),
        "one position per Gaussian at each time"
    );
    let grid = Grid::new(truth.bodies.iter().enumerate().flat_map(|(b, body)| {
        (0..body.gaussians.len()).map(move |k| (b, body.position(k, split)))
    }));
    let (mut err, mut travel, mut n) = (0.0, 0.0, 0_usize);
    for (x0, xt) in at_split.iter().zip(at_t) {
        let Some(b) = grid.nearest(*x0) else { continue };
        let body = &truth.bodies[b];
        if !body.moving {
            continue;
        }
        let want = body.law.position(body.law.body_point(*x0, split), t);
        err += (*xt - want).norm();
        travel += (want - *x0).norm();
        n += 1;
    }
    if n == 0 {
        return None;
    }
    let nf = n as f64;
    Some(TrajectoryError {
        split,
        time: t,
        gaussians: n,
        mean_error: err / nf,
        mean_travel: travel / nf,
        relative: err / travel.max(f64::MIN_POSITIVE),
    })
}

/// [`trajectory_error`] of a model's Gaussians (their positions at `split` and at `t`).
pub fn model_trajectory_error<T: Gemm>(
    model: &mut Model<T>,
    truth: &GroundTruth,
    split: f64,
    t: f64,
) -> Option<TrajectoryError> {
    let mut at = |time: f64| -> Vec<Vec3<f64>> {
        let mut s = evogs_splat::Splats::default();
        let mut stepper = None;
        let _tape = model.splats_at(time, &mut stepper, &mut s);
        s.means.iter().map(|m| m.cast::<f64>()).collect()
    };
    let (a, b) = (at(split), at(t));
    trajectory_error(truth, &a, &b, split, t)
}
