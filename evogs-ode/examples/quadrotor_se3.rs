//! A quadrotor-like rigid body flown on SE(3) × ℝ⁶ by the adaptive Dormand–Prince 5(4)
//! pair, and the gradient of a final-pose loss with respect to the initial twist by the
//! exact discrete adjoint, compared with central finite differences.
//!
//! `cargo run --release -p evogs-ode --example quadrotor_se3`
//!
//! The body (mass 1, asymmetric inertia `I = diag(0.8, 1.0, 1.6)`) has the state
//! `[T, v, ω]`: its pose `T = (R, c)` (world from body, c the centre of mass) and its body
//! twist (linear velocity v and angular velocity ω, both in body coordinates). It is driven
//! by a given law: a thrust `f(t) = 9.81 + 2 sin 3t` along the body's z axis, a torque
//! `τ(t) = (0.2 cos 2t, −0.1 sin t, 0.05)`, gravity `g = (0, 0, −9.81)` and linear drag:
//!
//! ```text
//! Ṫ = T·ν̂              world twist Ad(T)·ν, ν = (v, ω)
//! v̇ = v × ω + Rᵀg + f(t) e₃ − k_v v
//! ω̇ = I⁻¹((Iω) × ω + τ(t) − k_ω ω)
//! ```
//!
//! The loss `L = ½|c(t₁) − c*|² + ½|R(t₁) e₃ − b|²` asks for a final position and a
//! final direction of the thrust axis. Its gradient with respect to the initial twist
//! `ν(0)` comes from [`AdaptiveSolver::adjoint`]; the finite differences re-run the solve
//! with its accepted steps held fixed ([`AdaptiveSolver::replay`]), which is the function
//! the discrete adjoint differentiates exactly, and, for comparison, re-solve adaptively
//! (whose steps move with the input, so they agree only to about the tolerance).

use evogs_math::se3::adjoint_mul_vjp;
use evogs_math::{Real, Se3, Vec3, Vec6};
use evogs_ode::adaptive::{AdaptiveOptions, AdaptiveSolver, Pair, Stats};
use evogs_ode::{Block, StateLayout, VectorField};

/// The driven rigid body: the field of the module docs.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Quadrotor {
    /// Principal moments of inertia (body axes).
    pub(crate) inertia: [f64; 3],
    /// Linear drag coefficient `k_v`.
    pub(crate) drag_v: f64,
    /// Angular drag coefficient `k_ω`.
    pub(crate) drag_w: f64,
}

impl Default for Quadrotor {
    fn default() -> Self {
        Self {
            inertia: [0.8, 1.0, 1.6],
            drag_v: 0.3,
            drag_w: 0.1,
        }
    }
}

const GRAVITY: f64 = -9.81;

fn div_elem<T: Real>(a: Vec3<T>, b: Vec3<T>) -> Vec3<T> {
    Vec3::new(a.x / b.x, a.y / b.y, a.z / b.z)
}

impl Quadrotor {
    fn thrust<T: Real>(t: T) -> T {
        T::from_f64(9.81) + T::from_f64(2.0) * (T::from_f64(3.0) * t).sin()
    }
    fn torque<T: Real>(t: T) -> Vec3<T> {
        Vec3::new(
            T::from_f64(0.2) * (T::from_f64(2.0) * t).cos(),
            T::from_f64(-0.1) * t.sin(),
            T::from_f64(0.05),
        )
    }
    fn inertia<T: Real>(&self) -> Vec3<T> {
        Vec3::new(
            T::from_f64(self.inertia[0]),
            T::from_f64(self.inertia[1]),
            T::from_f64(self.inertia[2]),
        )
    }
    fn parts<T: Real>(y: &[T]) -> (Se3<T>, Vec3<T>, Vec3<T>) {
        (
            Se3::from_slice(y),
            Vec3::from_slice(&y[7..]),
            Vec3::from_slice(&y[10..]),
        )
    }
}

impl<T: Real> VectorField<T> for Quadrotor {
    type Record = ();
    fn dim(&self) -> usize {
        12
    }
    fn layout(&self) -> StateLayout {
        StateLayout::particles(&[Block::Se3, Block::Euclidean(6)], 1)
    }
    fn n_params(&self) -> usize {
        0
    }
    fn eval(&mut self, t: T, y: &[T], dydt: &mut [T]) {
        let (x, v, w) = Self::parts(y);
        let inertia = self.inertia::<T>();
        let g_body = x
            .rotation()
            .inverse()
            .act(Vec3::new(T::ZERO, T::ZERO, T::from_f64(GRAVITY)));
        x.adjoint_mul(Vec6::new(v, w)).write_to(dydt);
        let dv = v.cross(w) + g_body + Vec3::new(T::ZERO, T::ZERO, Self::thrust(t))
            - v * T::from_f64(self.drag_v);
        let rhs = inertia.mul_elem(w).cross(w) + Self::torque(t) - w * T::from_f64(self.drag_w);
        dv.write_to(&mut dydt[6..]);
        div_elem(rhs, inertia).write_to(&mut dydt[9..]);
    }
    /// `d_y += (∂f/∂y)ᵀ·w` with the pose's cotangent for the left perturbation `Exp(δ)·T`:
    /// the world twist through [`adjoint_mul_vjp`], gravity in body axes
    /// (`δ(Rᵀg) = Rᵀ ĝ φ` ⇒ `φ̄ += (R w_v) × g`), and the products of the Newton–Euler
    /// equations by hand.
    fn vjp(&mut self, _t: T, y: &[T], w: &[T], d_y: &mut [T], _d_params: &mut [T]) {
        let (x, v, om) = Self::parts(y);
        let inertia = self.inertia::<T>();
        let (d_x, d_nu) = adjoint_mul_vjp(x, Vec6::new(v, om), Vec6::from_slice(w));
        let w_v = Vec3::from_slice(&w[6..]);
        let u = div_elem(Vec3::from_slice(&w[9..]), inertia);
        let gravity = Vec3::new(T::ZERO, T::ZERO, T::from_f64(GRAVITY));
        let d_pose = d_x + Vec6::new(Vec3::zero(), x.rotation().act(w_v).cross(gravity));
        let d_v = d_nu.head + om.cross(w_v) - w_v * T::from_f64(self.drag_v);
        let d_om = d_nu.tail
            + w_v.cross(v)
            + inertia.mul_elem(om.cross(u))
            + u.cross(inertia.mul_elem(om))
            - u * T::from_f64(self.drag_w);
        d_pose.add_to(d_y);
        d_v.add_to(&mut d_y[6..]);
        d_om.add_to(&mut d_y[9..]);
    }
}

/// The final-pose loss `½|c − c*|² + ½|R e₃ − b|²` and its left cotangent
/// `(c − c*, c × (c − c*) + (R e₃) × (R e₃ − b))` (the twist entries get 0).
fn loss(y: &[f64]) -> (f64, [f64; 12]) {
    let x = Se3::from_slice(y);
    let (target, b) = (Vec3::new(1.0, -0.5, 2.0), Vec3::new(0.0, 0.6, 0.8));
    let (c, axis) = (x.translation(), x.rotation().act(Vec3::new(0.0, 0.0, 1.0)));
    let (dc, da) = (c - target, axis - b);
    let mut g = [0.0; 12];
    Vec6::new(dc, c.cross(dc) + axis.cross(da)).write_to(&mut g);
    (0.5 * (dc.norm_squared() + da.norm_squared()), g)
}

/// What the example measures.
#[derive(Clone, Debug)]
pub(crate) struct Report {
    /// Solver statistics of the forward solve.
    pub(crate) stats: Stats,
    /// The loss at the final pose.
    pub(crate) loss: f64,
    /// `∂L/∂ν(0)` by the discrete adjoint.
    pub(crate) adjoint: [f64; 6],
    /// By central differences of the replayed solve (steps held fixed).
    pub(crate) fd_fixed: [f64; 6],
    /// By central differences of fresh adaptive solves.
    pub(crate) fd_resolved: [f64; 6],
}

impl Report {
    /// `max |a − b| / max(1, max |a|)` of the adjoint against a finite-difference vector.
    #[must_use]
    pub(crate) fn rel_diff(&self, fd: &[f64; 6]) -> f64 {
        let scale = self.adjoint.iter().fold(1.0_f64, |m, a| m.max(a.abs()));
        self.adjoint
            .iter()
            .zip(fd)
            .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()))
            / scale
    }
}

/// Flies the body for 3 s from a tilted hover with tolerance `tol` and differentiates.
///
/// # Panics
/// If the adaptive solve fails (it does not for these settings).
#[must_use]
pub(crate) fn run(tol: f64) -> Report {
    let mut body = Quadrotor::default();
    let (t0, t1) = (0.0, 3.0);
    let pose = Se3::exp(Vec6::new(
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.3, -0.2, 0.1),
    ));
    let mut y0 = [0.0; 13];
    pose.write_to(&mut y0);
    y0[7..].copy_from_slice(&[0.4, -0.3, 0.2, 0.5, -0.8, 1.2]);
    let opts = AdaptiveOptions::with_tolerances(tol, tol);
    let mut solver = AdaptiveSolver::new(Pair::Dopri5, VectorField::<f64>::layout(&body), opts);
    let sol = solver.solve(&mut body, t0, t1, &y0, &[t1]).expect("solve");
    let (l, g) = loss(sol.output(0));
    let (mut d_y0, mut d_t) = ([0.0; 12], [0.0]);
    solver
        .adjoint(&mut body, &sol, &g, &mut d_y0, &mut [], &mut d_t)
        .expect("adjoint");
    let steps = sol.steps().clone();
    let eps = 1e-6;
    let (mut fd_fixed, mut fd_resolved) = ([0.0; 6], [0.0; 6]);
    for i in 0..6 {
        let mut at = |s: f64, fixed: bool| {
            let mut y = y0;
            y[7 + i] += s * eps;
            let mut out = [0.0; 13];
            if fixed {
                solver
                    .replay(&mut body, &steps, &y, &[t1], &mut out)
                    .expect("replay");
            } else {
                out.copy_from_slice(
                    solver
                        .solve(&mut body, t0, t1, &y, &[t1])
                        .expect("solve")
                        .output(0),
                );
            }
            loss(&out).0
        };
        fd_fixed[i] = (at(1.0, true) - at(-1.0, true)) / (2.0 * eps);
        fd_resolved[i] = (at(1.0, false) - at(-1.0, false)) / (2.0 * eps);
    }
    let mut adjoint = [0.0; 6];
    adjoint.copy_from_slice(&d_y0[6..]);
    Report {
        stats: sol.stats(),
        loss: l,
        adjoint,
        fd_fixed,
        fd_resolved,
    }
}

fn main() {
    println!("Quadrotor on SE(3) × R^6, Dormand–Prince 5(4), t in [0, 3], L = final-pose loss\n");
    println!(
        "| rtol = atol | accepted | rejected | field evals | L | adjoint vs FD (steps fixed) | vs FD (re-solved) |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|");
    for tol in [1e-4, 1e-6, 1e-8, 1e-10] {
        let r = run(tol);
        println!(
            "| {tol:.0e} | {} | {} | {} | {:.6} | {:.1e} | {:.1e} |",
            r.stats.accepted,
            r.stats.rejected,
            r.stats.field_evals,
            r.loss,
            r.rel_diff(&r.fd_fixed),
            r.rel_diff(&r.fd_resolved)
        );
    }
    let r = run(1e-8);
    println!("\n∂L/∂ν(0) at tol 1e-8 (v then ω, body axes):\n");
    println!("| entry | adjoint | FD, steps fixed | FD, re-solved |\n|---|---:|---:|---:|");
    let names = ["v_x", "v_y", "v_z", "ω_x", "ω_y", "ω_z"];
    for i in 0..6 {
        println!(
            "| {} | {:+.9e} | {:+.9e} | {:+.9e} |",
            names[i], r.adjoint[i], r.fd_fixed[i], r.fd_resolved[i]
        );
    }
}
