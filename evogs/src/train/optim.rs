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

use super::adam::{Adam, AdamState, AdamStep, ExpSchedule};
use crate::config::OptimConfig;
use crate::model::{Model, ModelGrad};
use evogs_math::{Par, Quat, Vec3};

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
    /// The waypoint field's HexPlane and MLP (continuous waypoints only).
    pub waypoint: Option<(AdamState, AdamState)>,
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

/// The message of a waypoint group asked of a model without a waypoint field.
const NO_WAYPOINT: &str = "a waypoint group needs a waypoint field";

/// One parameter group of a model, with its own Adam state: the list of groups exists once,
/// in [`Optimizer::for_each_group`] (Adam steps, checkpoints and densification all walk it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Group {
    /// Canonical positions.
    Means,
    /// Canonical log-scales.
    LogScales,
    /// Canonical quaternions.
    Quats,
    /// Opacity logits.
    Opacity,
    /// SH DC coefficients.
    ShDc,
    /// Higher SH coefficients.
    ShRest,
    /// Positions of anchor `k + 1`.
    AnchorMeans(usize),
    /// Log-scales of anchor `k + 1`.
    AnchorLogScales(usize),
    /// Quaternions of anchor `k + 1`.
    AnchorQuats(usize),
    /// HexPlane parameters.
    Grid,
    /// MLP parameters and output scales.
    Mlp,
    /// The waypoint field's HexPlane parameters (continuous waypoints).
    WaypointGrid,
    /// The waypoint field's MLP parameters and output scales (continuous waypoints).
    WaypointMlp,
}

impl Group {
    /// The group's name in checkpoints (`canonical.means`, `anchor0.quats`, `grid`, ...).
    #[must_use]
    pub fn name(self) -> String {
        match self {
            Self::Means => "canonical.means".into(),
            Self::LogScales => "canonical.log_scales".into(),
            Self::Quats => "canonical.quats".into(),
            Self::Opacity => "opacity".into(),
            Self::ShDc => "sh_dc".into(),
            Self::ShRest => "sh_rest".into(),
            Self::AnchorMeans(k) => format!("anchor{k}.means"),
            Self::AnchorLogScales(k) => format!("anchor{k}.log_scales"),
            Self::AnchorQuats(k) => format!("anchor{k}.quats"),
            Self::Grid => "grid".into(),
            Self::Mlp => "mlp".into(),
            Self::WaypointGrid => "waypoint_grid".into(),
            Self::WaypointMlp => "waypoint_mlp".into(),
        }
    }

    /// Values per Gaussian (`sh_coeffs` SH coefficients per Gaussian), or `None` for the
    /// field's groups, which do not grow with the Gaussians.
    #[must_use]
    pub const fn per_gaussian(self, sh_coeffs: usize) -> Option<usize> {
        match self {
            Self::Means
            | Self::LogScales
            | Self::AnchorMeans(_)
            | Self::AnchorLogScales(_)
            | Self::ShDc => Some(3),
            Self::Quats | Self::AnchorQuats(_) => Some(4),
            Self::Opacity => Some(1),
            Self::ShRest => Some(3 * (sh_coeffs - 1)),
            Self::Grid | Self::Mlp | Self::WaypointGrid | Self::WaypointMlp => None,
        }
    }

    /// Whether Adam steps the group only while the dynamics are active (their gradients are
    /// zero before).
    #[must_use]
    pub const fn dynamic(self) -> bool {
        matches!(
            self,
            Self::AnchorMeans(_)
                | Self::AnchorLogScales(_)
                | Self::AnchorQuats(_)
                | Self::Grid
                | Self::Mlp
                | Self::WaypointGrid
                | Self::WaypointMlp
        )
    }

    /// The group's learning rate.
    #[must_use]
    pub fn rate(self, lr: &LearningRates) -> f64 {
        match self {
            Self::Means | Self::AnchorMeans(_) => lr.position,
            Self::LogScales | Self::AnchorLogScales(_) => lr.scaling,
            Self::Quats | Self::AnchorQuats(_) => lr.rotation,
            Self::Opacity => lr.opacity,
            Self::ShDc => lr.feature,
            Self::ShRest => lr.feature / 20.0,
            Self::Grid | Self::WaypointGrid => lr.grid,
            Self::Mlp | Self::WaypointMlp => lr.deformation,
        }
    }
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
            waypoint: model.waypoint_field.as_ref().map(|f| {
                (
                    AdamState::new(f.grid_range().len()),
                    AdamState::new(f.mlp_range().len()),
                )
            }),
        }
    }

    /// Every parameter group, in the checkpoints' order: canonical positions, log-scales,
    /// quaternions, opacity, SH DC, higher SH, each anchor's positions, log-scales and
    /// quaternions, HexPlane, MLP, and the waypoint field's HexPlane and MLP when there is
    /// one. The one list of the groups.
    pub fn groups(&self) -> impl Iterator<Item = Group> + use<> {
        let canonical = [
            Group::Means,
            Group::LogScales,
            Group::Quats,
            Group::Opacity,
            Group::ShDc,
            Group::ShRest,
        ];
        let anchors = (0..self.anchors.len()).flat_map(|k| {
            [
                Group::AnchorMeans(k),
                Group::AnchorLogScales(k),
                Group::AnchorQuats(k),
            ]
        });
        let waypoint = self
            .waypoint
            .is_some()
            .then_some([Group::WaypointGrid, Group::WaypointMlp])
            .into_iter()
            .flatten();
        canonical
            .into_iter()
            .chain(anchors)
            .chain([Group::Grid, Group::Mlp])
            .chain(waypoint)
    }

    /// Calls `f` with every parameter group ([`groups`](Self::groups)) and its Adam state.
    pub fn for_each_group(&mut self, mut f: impl FnMut(Group, &mut AdamState)) {
        for g in self.groups() {
            f(g, self.state_mut(g));
        }
    }

    /// The Adam state of a group.
    ///
    /// # Panics
    /// An anchor group of an anchor the optimiser does not have, or a waypoint group
    /// without a waypoint field.
    #[must_use]
    pub fn state(&self, g: Group) -> &AdamState {
        match g {
            Group::Means => &self.canonical.means,
            Group::LogScales => &self.canonical.log_scales,
            Group::Quats => &self.canonical.quats,
            Group::Opacity => &self.opacity,
            Group::ShDc => &self.sh_dc,
            Group::ShRest => &self.sh_rest,
            Group::AnchorMeans(k) => &self.anchors[k].means,
            Group::AnchorLogScales(k) => &self.anchors[k].log_scales,
            Group::AnchorQuats(k) => &self.anchors[k].quats,
            Group::Grid => &self.grid,
            Group::Mlp => &self.mlp,
            Group::WaypointGrid => &self.waypoint.as_ref().expect(NO_WAYPOINT).0,
            Group::WaypointMlp => &self.waypoint.as_ref().expect(NO_WAYPOINT).1,
        }
    }

    /// The Adam state of a group, to change.
    ///
    /// # Panics
    /// An anchor group of an anchor the optimiser does not have, or a waypoint group
    /// without a waypoint field.
    pub fn state_mut(&mut self, g: Group) -> &mut AdamState {
        match g {
            Group::Means => &mut self.canonical.means,
            Group::LogScales => &mut self.canonical.log_scales,
            Group::Quats => &mut self.canonical.quats,
            Group::Opacity => &mut self.opacity,
            Group::ShDc => &mut self.sh_dc,
            Group::ShRest => &mut self.sh_rest,
            Group::AnchorMeans(k) => &mut self.anchors[k].means,
            Group::AnchorLogScales(k) => &mut self.anchors[k].log_scales,
            Group::AnchorQuats(k) => &mut self.anchors[k].quats,
            Group::Grid => &mut self.grid,
            Group::Mlp => &mut self.mlp,
            Group::WaypointGrid => &mut self.waypoint.as_mut().expect(NO_WAYPOINT).0,
            Group::WaypointMlp => &mut self.waypoint.as_mut().expect(NO_WAYPOINT).1,
        }
    }

    /// One Adam step of every trainable group. The anchors and the field are stepped only
    /// while the dynamics are active (their gradients are zero before); the higher SH
    /// coefficients only when there are any. `par` steps each group in fixed runs of
    /// units, bitwise the same on any thread count.
    pub fn step(
        &mut self,
        model: &mut Model<f32>,
        grad: &ModelGrad<f32>,
        lr: &LearningRates,
        par: Par,
    ) {
        let adam = self.adam;
        let k = model.canonical.coeffs_per_gaussian();
        let (gr, mr) = (model.field.grid_range(), model.field.mlp_range());
        let vec3s =
            |s: AdamStep, x: &mut [Vec3<f32>], g: &[Vec3<f32>], m: &mut [f32], v: &mut [f32]| {
                s.apply(vec3_pairs(x, g), m, v);
            };
        let quats =
            |s: AdamStep, x: &mut [Quat<f32>], g: &[Quat<f32>], m: &mut [f32], v: &mut [f32]| {
                s.apply(quat_pairs(x, g), m, v);
            };
        self.for_each_group(|group, st| {
            if (group.dynamic() && !model.dynamics_active) || (group == Group::ShRest && k == 1) {
                return;
            }
            let rate = group.rate(lr);
            let c = &mut model.canonical;
            let g = &grad.canonical;
            match group {
                Group::Means => {
                    st.step_units(&adam, rate, par, &mut c.means, &g.means, [1, 3], vec3s);
                }
                Group::LogScales => {
                    st.step_units(
                        &adam,
                        rate,
                        par,
                        &mut c.log_scales,
                        &g.log_scales,
                        [1, 3],
                        vec3s,
                    );
                }
                Group::Quats => {
                    st.step_units(&adam, rate, par, &mut c.quats, &g.quats, [1, 4], quats);
                }
                Group::Opacity => {
                    st.step(&adam, rate, par, &mut c.opacity_logits, &g.opacity_logits);
                }
                // The SH coefficients of a Gaussian are k items of 3 values: the first is the
                // DC group's, the other k − 1 the rest's.
                Group::ShDc => st.step_units(
                    &adam,
                    rate,
                    par,
                    &mut c.sh,
                    &g.sh,
                    [k, 3],
                    |s, x, g, m, v| {
                        let dc = x.iter_mut().zip(g).step_by(k);
                        s.apply(
                            dc.flat_map(|(a, d)| a.iter_mut().zip(d.iter().copied())),
                            m,
                            v,
                        );
                    },
                ),
                Group::ShRest => {
                    st.step_units(
                        &adam,
                        rate,
                        par,
                        &mut c.sh,
                        &g.sh,
                        [k, 3 * (k - 1)],
                        |s, x, g, m, v| step_sh_rest(s, k, x, g, m, v),
                    );
                }
                Group::AnchorMeans(a) => {
                    let (x, g) = (&mut model.anchors[a].means, &grad.anchors[a].means);
                    st.step_units(&adam, rate, par, x, g, [1, 3], vec3s);
                }
                Group::AnchorLogScales(a) => {
                    let (x, g) = (
                        &mut model.anchors[a].log_scales,
                        &grad.anchors[a].log_scales,
                    );
                    st.step_units(&adam, rate, par, x, g, [1, 3], vec3s);
                }
                Group::AnchorQuats(a) => {
                    let (x, g) = (&mut model.anchors[a].quats, &grad.anchors[a].quats);
                    st.step_units(&adam, rate, par, x, g, [1, 4], quats);
                }
                Group::Grid => {
                    let (x, g) = (
                        &mut model.field.params_mut()[gr.clone()],
                        &grad.field[gr.clone()],
                    );
                    st.step(&adam, rate, par, x, g);
                }
                Group::Mlp => {
                    let (x, g) = (
                        &mut model.field.params_mut()[mr.clone()],
                        &grad.field[mr.clone()],
                    );
                    st.step(&adam, rate, par, x, g);
                }
                Group::WaypointGrid | Group::WaypointMlp => {
                    let f = model.waypoint_field.as_mut().expect(NO_WAYPOINT);
                    let r = if group == Group::WaypointGrid {
                        f.grid_range()
                    } else {
                        f.mlp_range()
                    };
                    let (x, g) = (&mut f.params_mut()[r.clone()], &grad.waypoint_field[r]);
                    st.step(&adam, rate, par, x, g);
                }
            }
        });
    }

    /// Keeps the Adam entries of the Gaussians flagged in `keep`, then appends zero moments
    /// for `added` new Gaussians (densification).
    pub fn resize_gaussians(&mut self, keep: &[bool], added: usize, sh_coeffs: usize) {
        self.for_each_group(|g, st| {
            if let Some(stride) = g.per_gaussian(sh_coeffs) {
                st.retain(keep, stride);
                st.grow(added, stride);
            }
        });
    }

    /// Reorders the Adam entries of the Gaussians as [`Model::permute_gaussians`] reorders
    /// the Gaussians.
    pub fn permute_gaussians(&mut self, order: &[usize], sh_coeffs: usize) {
        self.for_each_group(|g, st| {
            if let Some(stride) = g.per_gaussian(sh_coeffs) {
                st.permute(order, stride);
            }
        });
    }
}

/// The Adam step of the SH coefficients but the DC term, over whole Gaussians of `k`
/// coefficients (`x`, `g`) and their `3·(k − 1)` moments each, in coefficient order: a
/// Gaussian's higher coefficients are contiguous, so each is one vectorised slice step.
fn step_sh_rest(
    s: AdamStep,
    k: usize,
    x: &mut [[f32; 3]],
    g: &[[f32; 3]],
    m: &mut [f32],
    v: &mut [f32],
) {
    let rest = 3 * (k - 1);
    let units = x.chunks_exact_mut(k).zip(g.chunks_exact(k));
    let moments = m.chunks_exact_mut(rest).zip(v.chunks_exact_mut(rest));
    for ((x, g), (m, v)) in units.zip(moments) {
        s.apply_slices(x[1..].as_flattened_mut(), g[1..].as_flattened(), m, v);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Moments and parameters that move in a few steps: values from a fixed sequence.
    fn values(n: usize, phase: f32) -> Vec<f32> {
        (0..n)
            .map(|i| (i as f32 * 0.37 + phase).sin() * 0.5)
            .collect()
    }

    #[test]
    fn the_sh_rest_step_is_the_per_value_step_of_every_coefficient_but_the_dc() {
        // The rule stated before the step was vectorised: the values of every coefficient
        // but the first of each Gaussian, in order, paired with the moments in order.
        let reference = |s: AdamStep,
                         k: usize,
                         x: &mut [[f32; 3]],
                         g: &[[f32; 3]],
                         m: &mut [f32],
                         v: &mut [f32]| {
            let rest = x.iter_mut().zip(g).enumerate().filter(|(i, _)| i % k != 0);
            s.apply(
                rest.flat_map(|(_, (a, d))| a.iter_mut().zip(d.iter().copied())),
                m,
                v,
            );
        };
        for k in [2, 4, 9, 16] {
            let gaussians = 7;
            let to_triples = |v: Vec<f32>| -> Vec<[f32; 3]> {
                v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
            };
            let x0 = to_triples(values(3 * k * gaussians, 0.1));
            let g = to_triples(values(3 * k * gaussians, 1.3));
            let moments = 3 * (k - 1) * gaussians;
            let mut want = (
                x0.clone(),
                values(moments, 2.0),
                values(moments, 0.7)
                    .iter()
                    .map(|v| v * v)
                    .collect::<Vec<_>>(),
            );
            let mut got = want.clone();
            let mut st = AdamState::new(moments);
            let s = st.begin(&Adam::default(), 0.01);
            reference(s, k, &mut want.0, &g, &mut want.1, &mut want.2);
            step_sh_rest(s, k, &mut got.0, &g, &mut got.1, &mut got.2);
            let bits = |x: &[f32]| x.iter().map(|e| e.to_bits()).collect::<Vec<_>>();
            assert_eq!(
                bits(got.0.as_flattened()),
                bits(want.0.as_flattened()),
                "k = {k}: parameters"
            );
            assert_eq!(bits(&got.1), bits(&want.1), "k = {k}: first moments");
            assert_eq!(bits(&got.2), bits(&want.2), "k = {k}: second moments");
            let dc_moved = got
                .0
                .iter()
                .step_by(k)
                .zip(x0.iter().step_by(k))
                .any(|(a, b)| a.map(f32::to_bits) != b.map(f32::to_bits));
            assert!(
                !dc_moved,
                "k = {k}: the DC coefficients are not this group's"
            );
            assert_ne!(got.0, x0, "k = {k}: the rest moved");
        }
    }
}
