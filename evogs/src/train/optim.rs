//! The optimiser of a [`Model`]: one Adam state per parameter group, with the learning rates
//! and schedules of `docs/method.md` §7.3.
//!
//! | group | rate |
//! |---|---|
//! | positions (canonical and anchors) | `position_lr(i)·extent`, exponential decay |
//! | log-scales | `scaling_lr` |
//! | quaternions | `rotation_lr` |
//! | opacity logits | `opacity_lr` |
//! | SH DC / higher coefficients | `feature_lr` / `feature_lr/20` |
//! | HexPlane ("grid") | `grid_lr(i − warm-up)·extent`, exponential decay |
//! | MLP ("deformation") | `deformation_lr(i − warm-up)·extent`, exponential decay |

use super::adam::{Adam, AdamState, ExpSchedule};
use crate::config::OptimConfig;
use crate::model::{Model, ModelGrad};
use evogs_math::{Quat, Vec3};

/// Adam states of the parameter groups of one anchor (positions, log-scales, quaternions).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StateGroups {
    /// Positions.
    pub means: AdamState,
    /// Log-scales.
    pub log_scales: AdamState,
    /// Quaternions.
    pub quats: AdamState,
}

impl StateGroups {
    /// Zero moments for `n` Gaussians.
    #[must_use]
    pub fn new(n: usize) -> Self {
        Self {
            means: AdamState::new(3 * n),
            log_scales: AdamState::new(3 * n),
            quats: AdamState::new(4 * n),
        }
    }
}

/// All Adam states of a model.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Optimizer {
    /// Hyper-parameters.
    pub adam: Adam,
    /// Canonical positions, log-scales, quaternions.
    pub canonical: StateGroups,
    /// Opacity logits.
    pub opacity: AdamState,
    /// SH DC coefficients (3 per Gaussian).
    pub sh_dc: AdamState,
    /// Higher SH coefficients (3·(K − 1) per Gaussian).
    pub sh_rest: AdamState,
    /// Anchors `1..K`.
    pub anchors: Vec<StateGroups>,
    /// HexPlane parameters.
    pub grid: AdamState,
    /// MLP parameters and output scales.
    pub mlp: AdamState,
}

/// The learning rates of one iteration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LearningRates {
    /// Positions.
    pub position: f64,
    /// Log-scales.
    pub scaling: f64,
    /// Quaternions.
    pub rotation: f64,
    /// Opacity logits.
    pub opacity: f64,
    /// SH DC.
    pub feature: f64,
    /// HexPlane.
    pub grid: f64,
    /// MLP.
    pub deformation: f64,
}

impl LearningRates {
    /// The rates at `iteration` (1-based); the field schedules start at `dynamics_start`.
    #[must_use]
    pub fn at(cfg: &OptimConfig, extent: f64, iteration: u64, dynamics_start: u64) -> Self {
        let sched = |init: f64, fin: f64| ExpSchedule {
            init,
            final_: fin,
            max_steps: cfg.lr_max_steps,
        };
        let field_step = iteration.saturating_sub(dynamics_start);
        Self {
            position: sched(cfg.position_lr_init, cfg.position_lr_final).at(iteration) * extent,
            scaling: cfg.scaling_lr,
            rotation: cfg.rotation_lr,
            opacity: cfg.opacity_lr,
            feature: cfg.feature_lr,
            grid: sched(cfg.grid_lr_init, cfg.grid_lr_final).at(field_step) * extent,
            deformation: sched(cfg.deformation_lr_init, cfg.deformation_lr_final).at(field_step)
                * extent,
        }
    }
}

fn vec3_pairs<'a>(
    x: &'a mut [Vec3<f32>],
    g: &'a [Vec3<f32>],
) -> impl Iterator<Item = (&'a mut f32, f32)> {
    x.iter_mut()
        .zip(g)
        .flat_map(|(v, d)| [(&mut v.x, d.x), (&mut v.y, d.y), (&mut v.z, d.z)])
}

fn quat_pairs<'a>(
    x: &'a mut [Quat<f32>],
    g: &'a [Quat<f32>],
) -> impl Iterator<Item = (&'a mut f32, f32)> {
    x.iter_mut().zip(g).flat_map(|(q, d)| {
        [
            (&mut q.w, d.w),
            (&mut q.x, d.x),
            (&mut q.y, d.y),
            (&mut q.z, d.z),
        ]
    })
}

impl Optimizer {
    /// Zero moments for a model.
    #[must_use]
    pub fn new(model: &Model<f32>) -> Self {
        let n = model.len();
        let k = model.canonical.coeffs_per_gaussian();
        Self {
            adam: Adam::default(),
            canonical: StateGroups::new(n),
            opacity: AdamState::new(n),
            sh_dc: AdamState::new(3 * n),
            sh_rest: AdamState::new(3 * n * (k - 1)),
            anchors: model.anchors.iter().map(|_| StateGroups::new(n)).collect(),
            grid: AdamState::new(model.field.grid_range().len()),
            mlp: AdamState::new(model.field.mlp_range().len()),
        }
    }

    /// One Adam step of every trainable group. The anchors and the field are stepped only
    /// while the dynamics are active (their gradients are zero before).
    pub fn step(&mut self, model: &mut Model<f32>, grad: &ModelGrad<f32>, lr: &LearningRates) {
        let adam = self.adam;
        let c = &mut model.canonical;
        let g = &grad.canonical;
        step_state(
            &adam,
            &mut self.canonical,
            lr,
            &mut c.means,
            &mut c.log_scales,
            &mut c.quats,
            &g.means,
            &g.log_scales,
            &g.quats,
        );
        self.opacity
            .step(&adam, lr.opacity, &mut c.opacity_logits, &g.opacity_logits);
        let k = c.coeffs_per_gaussian();
        let dc =
            c.sh.iter_mut()
                .zip(&g.sh)
                .step_by(k)
                .flat_map(|(v, d)| v.iter_mut().zip(d.iter().copied()));
        self.sh_dc.step_iter(&adam, lr.feature, dc);
        if k > 1 {
            let rest =
                c.sh.iter_mut()
                    .zip(&g.sh)
                    .enumerate()
                    .filter(|(i, _)| i % k != 0)
                    .flat_map(|(_, (v, d))| v.iter_mut().zip(d.iter().copied()));
            self.sh_rest.step_iter(&adam, lr.feature / 20.0, rest);
        }
        if model.dynamics_active {
            for ((a, ga), st) in model
                .anchors
                .iter_mut()
                .zip(&grad.anchors)
                .zip(&mut self.anchors)
            {
                step_state(
                    &adam,
                    st,
                    lr,
                    &mut a.means,
                    &mut a.log_scales,
                    &mut a.quats,
                    &ga.means,
                    &ga.log_scales,
                    &ga.quats,
                );
            }
            let (gr, mr) = (model.field.grid_range(), model.field.mlp_range());
            let p = model.field.params_mut();
            self.grid
                .step(&adam, lr.grid, &mut p[gr.clone()], &grad.field[gr]);
            self.mlp
                .step(&adam, lr.deformation, &mut p[mr.clone()], &grad.field[mr]);
        }
    }

    /// Every per-Gaussian Adam state with its values per Gaussian (positions, log-scales and
    /// quaternions of the canonical state and of every anchor, opacity, SH DC, higher SH).
    fn for_each_gaussian_state(
        &mut self,
        sh_coeffs: usize,
        mut f: impl FnMut(&mut AdamState, usize),
    ) {
        for st in std::iter::once(&mut self.canonical).chain(self.anchors.iter_mut()) {
            f(&mut st.means, 3);
            f(&mut st.log_scales, 3);
            f(&mut st.quats, 4);
        }
        f(&mut self.opacity, 1);
        f(&mut self.sh_dc, 3);
        f(&mut self.sh_rest, 3 * (sh_coeffs - 1));
    }

    /// Keeps the Adam entries of the Gaussians flagged in `keep`, then appends zero moments
    /// for `added` new Gaussians (densification).
    pub fn resize_gaussians(&mut self, keep: &[bool], added: usize, sh_coeffs: usize) {
        self.for_each_gaussian_state(sh_coeffs, |st, stride| {
            st.retain(keep, stride);
            st.grow(added, stride);
        });
    }

    /// Reorders the Adam entries of the Gaussians as [`Model::permute_gaussians`] reorders
    /// the Gaussians.
    pub fn permute_gaussians(&mut self, order: &[usize], sh_coeffs: usize) {
        self.for_each_gaussian_state(sh_coeffs, |st, stride| st.permute(order, stride));
    }
}

fn step_state(
    adam: &Adam,
    st: &mut StateGroups,
    lr: &LearningRates,
    means: &mut [Vec3<f32>],
    log_scales: &mut [Vec3<f32>],
    quats: &mut [Quat<f32>],
    gm: &[Vec3<f32>],
    gs: &[Vec3<f32>],
    gq: &[Quat<f32>],
) {
    st.means.step_iter(adam, lr.position, vec3_pairs(means, gm));
    st.log_scales
        .step_iter(adam, lr.scaling, vec3_pairs(log_scales, gs));
    st.quats.step_iter(adam, lr.rotation, quat_pairs(quats, gq));
}
