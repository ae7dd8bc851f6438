//! Refitting a body on its orbit: its canonical Gaussians and its own spin fitted together to
//! the views, so that spins are compared by how well the body *can* fit the views turning that
//! way, not by how a canonical fitted to one or two views happens to look turned.
//!
//! At the orbit search's time (just after the static warm-up) a small fast body has been
//! fitted to the one or two views of the warm-up's window, so its depth is hardly fixed, and
//! turning it shows little of how it looks from elsewhere (README, "The torus"). A refit is
//! the small bundle adjustment that fixes it: with the orbit's centroid path held, the
//! members' canonical parameters, the body's spin and its orbit (centre and angular velocity)
//! are fitted by Adam to the views up to a horizon, one view per step; the spin that fits best
//! after its refit wins.
//!
//! Conventions: quaternions `(w, x, y, z)` turn body to world; the spin `s` is world-frame
//! (radians per unit time). A member with canonical position `p` and raw quaternion `q` is,
//! at elapsed time `τ = t − t₀`,
//!
//! ```text
//! x(τ) = c(τ) + U (p − c₀),   q(τ) = U ⊗ q,   U = exp(τ s)
//! ```
//!
//! with `c(τ) = o + exp(τ Ω)(c₀ − o)` the orbit's circle (centre `o`, angular velocity `Ω`)
//! through the body's centroid `c₀`. The rotations' gradients go through left perturbations
//! `U ← exp(δ) U`: `∂L/∂δ = (U r) × ∂L/∂x + ½ vec(∂L/∂q ⊗ (U q)*)` per member (`r = p − c₀`),
//! and `∂L/∂s = τ Jₗ(τ s)ᵀ ∂L/∂δ` ([`member_pose_vjp`]); the same for `Ω` with the sum of the
//! members' position cotangents ([`circle_point_vjp`]).
//!
//! A spin search's body moves along its learnt centroid samples instead, or, refitted as a
//! thrown body, along a flight with bounces ([`super::ballistic`]): its start, velocity,
//! gravity's magnitude (the direction is held), floor depth and restitution are fitted the
//! same way ([`super::ballistic::Ballistic::refit_params`]).

use super::ballistic::REFIT_PARAMS;
use super::bodies::{Body, CentrePath, Paths, circle_point_vjp};
use super::orbit::{Group, Orbit};
use super::spin::SearchContext;
use super::window_loss::WindowLoss;
use crate::model::Model;
use crate::train::adam::{Adam, AdamState};
use crate::train::step::ViewData;
use evogs_math::rng::SplitMix64;
use evogs_math::so3::exp_quat;
use evogs_math::so3_jacobians::left_jacobian;
use evogs_math::{Par, Quat, Real, Vec3};
use evogs_ode::Stepper;
use evogs_splat::{CameraGrad, DensifyStats, RasterInputGrad, RenderGrad, RenderOptions, Splats};

/// Adam rates of a refit (per step, before the decay), in the blocks of
/// [`Splats::write_flat`]: positions (scene units), log-scales, raw quaternions, opacity
/// logits, SH coefficients.
const RATES: [f64; 5] = [1e-3, 5e-3, 2e-3, 0.05, 2.5e-3];
/// Adam rates of the centroid path's points (an orbit's centre, a learnt path's samples;
/// scene units), an orbit's angular velocity and the body's spin (radians per unit time).
const PATH_RATES: [f64; 3] = [1e-3, 0.02, 0.05];
/// The rates fall exponentially to this fraction of themselves over a refit.
const FINAL_RATE: f64 = 0.1;
/// Seed of the views' order.
const ORDER_SEED: u64 = 23;

/// A body's members' canonical parameters (in the order of its members), its own spin and
/// its centroid's path.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct BodyParams {
    /// The members' canonical Gaussians.
    pub splats: Splats<f32>,
    /// World-frame spin (radians per unit time).
    pub spin: Vec3<f64>,
    /// The centroid's path: an orbit's circle or a learnt body's samples.
    pub path: CentrePath,
}

/// What a refit moves: a body's members, its canonical centroid and the time range (start,
/// length) its path runs over.
#[derive(Clone, Copy, Debug)]
pub(super) struct Subject<'a> {
    /// The members.
    pub members: &'a [usize],
    /// Their centroid at the range's start.
    pub c0: Vec3<f64>,
    /// Start and length of the time range.
    pub range: (f64, f64),
}

impl<'a> Subject<'a> {
    /// An orbit search's `group` over `range`.
    pub(super) fn group(group: &'a Group, range: (f64, f64)) -> Self {
        Self {
            members: &group.members,
            c0: group.centroid,
            range,
        }
    }

    /// A spin search's `body`.
    pub(super) fn body(body: &'a Body) -> Self {
        Self {
            members: &body.members,
            c0: body.c0,
            range: body.range,
        }
    }
}

impl BodyParams {
    /// The `members` of `canonical`, spinning at `spin` along `path`.
    pub(super) fn gather(
        canonical: &Splats<f32>,
        members: &[usize],
        spin: Vec3<f64>,
        path: CentrePath,
    ) -> Self {
        let mut splats = Splats::new(canonical.sh_degree);
        for &i in members {
            splats.push(
                canonical.means[i],
                canonical.log_scales[i],
                canonical.quats[i],
                canonical.opacity_logits[i],
                canonical.sh_coeffs(i),
            );
        }
        Self { splats, spin, path }
    }

    /// `orbit`'s circle and spin for the `members` of `canonical`.
    pub(super) fn orbit(canonical: &Splats<f32>, members: &[usize], orbit: &Orbit) -> Self {
        let path = CentrePath::Circle {
            centre: orbit.centre,
            omega: orbit.omega,
        };
        Self::gather(canonical, members, orbit.spin, path)
    }

    /// The orbit of a circling body (`None` for a sampled path).
    pub(super) fn as_orbit(&self) -> Option<Orbit> {
        match self.path {
            CentrePath::Circle { centre, omega } => Some(Orbit {
                centre,
                omega,
                spin: self.spin,
            }),
            CentrePath::Sampled(_) | CentrePath::Ballistic(_) => None,
        }
    }

    /// The path's parameters, flat (an orbit's centre and angular velocity, a learnt path's
    /// samples, or a flight's [`super::ballistic::Ballistic::refit_params`]), and the blocks
    /// `(start, end, rate)` of their Adam rates.
    fn path_flat(&self) -> (Vec<f32>, Vec<(usize, usize, f64)>) {
        #[allow(clippy::cast_possible_truncation, reason = "Adam runs in f32")]
        let flat = |v: &[Vec3<f64>]| -> Vec<f32> {
            v.iter()
                .flat_map(|p| p.to_array().map(|x| x as f32))
                .collect()
        };
        match &self.path {
            CentrePath::Circle { centre, omega } => (
                flat(&[*centre, *omega]),
                vec![(0, 3, PATH_RATES[0]), (3, 6, PATH_RATES[1])],
            ),
            CentrePath::Sampled(c) => (flat(c), vec![(0, 3 * c.len(), PATH_RATES[0])]),
            CentrePath::Ballistic(b) => {
                #[allow(clippy::cast_possible_truncation, reason = "Adam runs in f32")]
                let p = b.refit_params().map(|x| x as f32).to_vec();
                (p, b.refit_rates(PATH_RATES[0]).to_vec())
            }
        }
    }

    /// Sets the path's parameters from the layout of [`Self::path_flat`].
    fn set_path_flat(&mut self, flat: &[f32]) {
        let at = |k: usize| Vec3::from_slice(&flat[3 * k..]).cast::<f64>();
        match &mut self.path {
            CentrePath::Circle { centre, omega } => (*centre, *omega) = (at(0), at(1)),
            CentrePath::Sampled(c) => {
                for (k, p) in c.iter_mut().enumerate() {
                    *p = at(k);
                }
            }
            CentrePath::Ballistic(b) => {
                let mut p = [0.0; REFIT_PARAMS];
                for (d, &x) in p.iter_mut().zip(flat) {
                    *d = f64::from(x);
                }
                b.set_refit_params(&p);
            }
        }
    }

    /// Writes the members back into `canonical` and the search's canonical poses.
    pub(super) fn scatter(
        &self,
        members: &[usize],
        canonical: &mut Splats<f32>,
        ctx: &mut SearchContext,
    ) {
        for (j, &i) in members.iter().enumerate() {
            let s = &self.splats;
            canonical.means[i] = s.means[j];
            canonical.log_scales[i] = s.log_scales[j];
            canonical.quats[i] = s.quats[j];
            canonical.opacity_logits[i] = s.opacity_logits[j];
            canonical.sh_coeffs_mut(i).copy_from_slice(s.sh_coeffs(j));
            ctx.p0[i] = s.means[j].cast();
            ctx.q0[i] = s.quats[j].normalize().cast();
            ctx.log_scales[i] = s.log_scales[j];
        }
    }
}

/// The views a refit sees, each with the model's own state at its time (which the body's
/// members overwrite), and those of them a refit uses now (all, or those to a horizon).
pub(super) struct Frames<'v> {
    views: Vec<&'v ViewData<f32>>,
    states: Vec<Splats<f32>>,
    active: Vec<usize>,
}

impl<'v> Frames<'v> {
    /// The views of `ctx` up to `horizon` (fraction of `range`, start and length), all
    /// active.
    pub(super) fn new(
        model: &mut Model<f32>,
        ctx: &SearchContext<'v>,
        (range, horizon): ((f64, f64), f64),
        stepper: &mut Option<Stepper<f32>>,
    ) -> Self {
        let views: Vec<&ViewData<f32>> = ctx.views_to((range, horizon)).collect();
        let states = views
            .iter()
            .map(|v| {
                let mut st = Splats::default();
                model.splats_at(v.time, stepper, &mut st);
                st
            })
            .collect();
        let active = (0..views.len()).collect();
        Self {
            views,
            states,
            active,
        }
    }

    /// Makes the views up to time `t_end` the active ones.
    pub(super) fn set_horizon(&mut self, t_end: f64) {
        self.active = (0..self.views.len())
            .filter(|&i| self.views[i].time <= t_end)
            .collect();
    }

    /// Applies `f` to each view's time and state (to place other bodies in them).
    pub(super) fn for_each_state(&mut self, mut f: impl FnMut(f64, &mut Splats<f32>)) {
        for (v, st) in self.views.iter().zip(&mut self.states) {
            f(v.time, st);
        }
    }

    /// Number of active views.
    pub(super) fn len(&self) -> usize {
        self.active.len()
    }

    /// Active view `k` and its state.
    fn get(&self, k: usize) -> (&'v ViewData<f32>, &Splats<f32>) {
        let i = self.active[k];
        (self.views[i], &self.states[i])
    }
}

/// A member's position and raw quaternion at elapsed time `tau` (module doc): centroid `c`
/// on its path, canonical centroid `c0`, canonical position `p` and raw quaternion `q`.
pub(super) fn member_pose<T: Real>(
    (c, c0): (Vec3<T>, Vec3<T>),
    spin: Vec3<T>,
    tau: T,
    p: Vec3<T>,
    q: Quat<T>,
) -> (Vec3<T>, Quat<T>) {
    let u = exp_quat(spin * tau);
    (c + u.rotate(p - c0), u.mul_quat(q))
}

/// The VJP of [`member_pose`] with respect to `p`, `q` and `spin`, given the cotangents of
/// the position `gx` and of the quaternion `gq`.
pub(super) fn member_pose_vjp<T: Real>(
    c0: Vec3<T>,
    spin: Vec3<T>,
    tau: T,
    (p, q): (Vec3<T>, Quat<T>),
    (gx, gq): (Vec3<T>, Quat<T>),
) -> (Vec3<T>, Quat<T>, Vec3<T>) {
    let u = exp_quat(spin * tau);
    let (a, uq) = (u.rotate(p - c0), u.mul_quat(q));
    // Left multiplication by `u` and the rotation by it are orthogonal maps.
    let gp = u.rotate_inv(gx);
    let gq_raw = u.conj().mul_quat(gq);
    let h = gq.mul_quat(uq.conj());
    let g_delta = a.cross(gx) + Vec3::new(h.x, h.y, h.z) * T::HALF;
    let g_spin = left_jacobian(spin * tau).transpose().mul_vec(g_delta) * tau;
    (gp, gq_raw, g_spin)
}

/// The VJP of the centroid's position on `path` at `t` (for `sub`), `g` its cotangent,
/// added into `g_path` (the layout of [`BodyParams::path_flat`]).
fn path_vjp(path: &CentrePath, sub: Subject<'_>, t: f64, g: Vec3<f64>, g_path: &mut [f64]) {
    let (t0, span) = sub.range;
    let mut add = |k: usize, v: Vec3<f64>| {
        for (d, x) in g_path[3 * k..3 * k + 3].iter_mut().zip(v.to_array()) {
            *d += x;
        }
    };
    match path {
        CentrePath::Circle { centre, omega } => {
            let (gc, gw) = circle_point_vjp(*centre, *omega, sub.c0, t - t0, g);
            add(0, gc);
            add(1, gw);
        }
        CentrePath::Sampled(_) => {
            let (k, f) = Paths::locate(t0, span, t);
            add(k, g * (1.0 - f));
            add(k + 1, g * f);
        }
        CentrePath::Ballistic(b) => {
            for (d, x) in g_path.iter_mut().zip(b.refit_vjp(t - t0, g)) {
                *d += x;
            }
        }
    }
}

/// Writes `params` posed at time `t` into the members of `st`.
fn place_params(st: &mut Splats<f32>, sub: Subject<'_>, params: &BodyParams, t: f64) {
    let tau = t - sub.range.0;
    let (c, _) = params.path.at(sub.c0, sub.range, t);
    let s = &params.splats;
    for (j, &i) in sub.members.iter().enumerate() {
        let (x, q) = member_pose(
            (c, sub.c0),
            params.spin,
            tau,
            s.means[j].cast(),
            s.quats[j].cast(),
        );
        st.means[i] = x.cast();
        st.quats[i] = q.cast();
        st.log_scales[i] = s.log_scales[j];
        st.opacity_logits[i] = s.opacity_logits[j];
        st.sh_coeffs_mut(i).copy_from_slice(s.sh_coeffs(j));
    }
}

/// Buffers of one refit, kept across its steps (the rasterizer sizes them to each view).
struct Workspace {
    probe: Splats<f32>,
    grad: RenderGrad<f32>,
    window: WindowLoss,
}

impl Workspace {
    fn new(opts: RenderOptions<f32>, lambda: f32) -> Self {
        Self {
            probe: Splats::default(),
            grad: RenderGrad {
                splats: Splats::default(),
                camera: CameraGrad::zero(),
                raster: RasterInputGrad::default(),
                background: [0.0; 3],
                densify: DensifyStats::default(),
            },
            window: WindowLoss::new(opts, lambda),
        }
    }

    /// The loss of view `v`, rendered whole from `st` with the body posed from `params`.
    fn full_loss(
        &mut self,
        (st, v): (&Splats<f32>, &ViewData<f32>),
        sub: Subject<'_>,
        params: &BodyParams,
    ) -> f64 {
        self.probe.clone_from(st);
        place_params(&mut self.probe, sub, params, v.time);
        self.window.full_loss(v, &self.probe)
    }
}

/// Mean photometric loss per view of `frames` with the body posed from `params`.
fn mean_loss(
    frames: &Frames<'_>,
    body: Subject<'_>,
    params: &BodyParams,
    ws: &mut Workspace,
) -> f64 {
    let mut total = 0.0;
    for k in 0..frames.len() {
        let (v, st) = frames.get(k);
        total += ws.full_loss((st, v), body, params);
    }
    #[allow(clippy::cast_precision_loss, reason = "a count")]
    let n = frames.len().max(1) as f64;
    total / n
}

/// One Adam step of a vector in f64 (the moments in f32).
fn adam_vec3(st: &mut AdamState, lr: f64, x: &mut Vec3<f64>, g: Vec3<f64>) {
    #[allow(clippy::cast_possible_truncation, reason = "Adam runs in f32")]
    let (mut x32, g32) = (
        x.to_array().map(|v| v as f32),
        g.to_array().map(|v| v as f32),
    );
    st.step(&Adam::default(), lr, &mut x32, &g32);
    *x = Vec3::new(x32[0], x32[1], x32[2]).cast();
}

/// One refit of `sub`: `iters` Adam steps on `start` (its members' canonical Gaussians, its
/// spin and its path), one view of `frames` per step in a shuffled order. Returns the fitted
/// parameters and their mean loss per view over `frames`.
pub(super) fn refit_body(
    ctx: &SearchContext<'_>,
    frames: &Frames<'_>,
    sub: Subject<'_>,
    start: &BodyParams,
    iters: usize,
    par: Par,
) -> (BodyParams, f64) {
    let opts = RenderOptions { par, ..ctx.opts };
    let (members, c0, t0) = (sub.members, sub.c0, sub.range.0);
    let mut ws = Workspace::new(opts, ctx.lambda);
    let mut params = start.clone();
    let n = params.splats.len();
    let mut flat = Vec::new();
    params.splats.write_flat(&mut flat);
    // The flat layout's blocks: means, log-scales, quaternions, opacity logits, SH.
    let bounds = [0, 3 * n, 6 * n, 10 * n, 11 * n, flat.len()];
    let mut adam: Vec<AdamState> = bounds
        .windows(2)
        .map(|w| AdamState::new(w[1] - w[0]))
        .collect();
    let (mut path_flat, path_blocks) = params.path_flat();
    let mut path_adam: Vec<AdamState> = path_blocks
        .iter()
        .map(|&(lo, hi, _)| AdamState::new(hi - lo))
        .collect();
    let mut g_path = vec![0.0f64; path_flat.len()];
    let mut spin_adam = AdamState::new(3);
    let hyper = Adam::default();
    let mut grad_members = params.splats.zeros_like();
    let mut gflat = Vec::new();
    let mut order: Vec<usize> = (0..frames.len()).collect();
    let mut rng = SplitMix64::new(ORDER_SEED);
    let mut g32 = Vec::new();
    for k in 0..iters {
        if frames.len() == 0 {
            break;
        }
        let e = k % frames.len();
        if e == 0 {
            for i in (1..order.len()).rev() {
                order.swap(i, rng.below(i + 1));
            }
        }
        let (v, st) = frames.get(order[e]);
        ws.probe.clone_from(st);
        place_params(&mut ws.probe, sub, &params, v.time);
        // The members' exact gradient from a window around them (`window_loss`); zero if
        // no member is in sight.
        ws.window.grad_into(v, &ws.probe, members, &mut ws.grad);
        let g = &ws.grad.splats;
        // Back to the canonical members, the spin and the path.
        let tau = v.time - t0;
        let (mut g_spin, mut g_c) = (Vec3::<f64>::zero(), Vec3::<f64>::zero());
        for (j, &i) in members.iter().enumerate() {
            let s = &params.splats;
            let gx: Vec3<f64> = g.means[i].cast();
            let (gp, gq, gs) = member_pose_vjp(
                c0,
                params.spin,
                tau,
                (s.means[j].cast(), s.quats[j].cast()),
                (gx, g.quats[i].cast()),
            );
            grad_members.means[j] = gp.cast();
            grad_members.quats[j] = gq.cast();
            grad_members.log_scales[j] = g.log_scales[i];
            grad_members.opacity_logits[j] = g.opacity_logits[i];
            grad_members
                .sh_coeffs_mut(j)
                .copy_from_slice(g.sh_coeffs(i));
            g_spin += gs;
            g_c += gx;
        }
        g_path.fill(0.0);
        path_vjp(&params.path, sub, v.time, g_c, &mut g_path);
        #[allow(clippy::cast_precision_loss, reason = "step counts")]
        let decay = FINAL_RATE.powf(k as f64 / iters.max(1) as f64);
        grad_members.write_flat(&mut gflat);
        for (b, st) in adam.iter_mut().enumerate() {
            let (lo, hi) = (bounds[b], bounds[b + 1]);
            st.step(&hyper, RATES[b] * decay, &mut flat[lo..hi], &gflat[lo..hi]);
        }
        params.splats.read_flat(&flat);
        for (st, &(lo, hi, rate)) in path_adam.iter_mut().zip(&path_blocks) {
            g32.clear();
            #[allow(clippy::cast_possible_truncation, reason = "Adam runs in f32")]
            g32.extend(g_path[lo..hi].iter().map(|&x| x as f32));
            st.step(&hyper, rate * decay, &mut path_flat[lo..hi], &g32);
        }
        params.set_path_flat(&path_flat);
        adam_vec3(
            &mut spin_adam,
            PATH_RATES[2] * decay,
            &mut params.spin,
            g_spin,
        );
    }
    let loss = mean_loss(frames, sub, &params, &mut ws);
    (params, loss)
}

#[cfg(test)]
#[path = "body_fit_tests.rs"]
mod tests;
