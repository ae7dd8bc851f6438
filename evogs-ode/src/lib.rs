//! # evogs-ode
//!
//! ODE integration on vector spaces, SO(3) and SE(3), on fixed grids and adaptively (embedded
//! Runge–Kutta pairs with dense output), with **exact** discrete adjoints, continuous
//! adjoints for comparison, vector-field algebra, reference problems with exact solutions and
//! empirical order verification. `no_std` + `alloc`.
//!
//! | piece | items |
//! |---|---|
//! | right-hand sides | [`VectorField`] (`eval` + accumulating `vjp`), [`StateLayout`], [`fields`] |
//! | methods | [`Method`] (Euler, midpoint, Heun, RK4, RK4 3/8), [`Tableau`] (exact rationals) |
//! | stepping | [`Stepper`] (one RK core; RKMK on SO(3) and SE(3) blocks), [`TimeGrid`], [`integrate`] |
//! | trajectories | [`integrate_trajectory`], [`Trajectory`], [`Checkpointing`] (store-all, every-k) |
//! | gradients | [`discrete_adjoint`] (exact), [`Stepper::step_vjp`], [`continuous_adjoint`] |
//! | adaptive | [`adaptive`]: [`AdaptiveSolver`](adaptive::AdaptiveSolver) with Dormand–Prince 5(4) and Bogacki–Shampine 3(2) ([`Pair`](adaptive::Pair)), PI control, dense output, exact adjoint w.r.t. `y0`, θ and output times (docs/adaptive.md) |
//! | motion editing | [`algebra`]: `Sum`, `Scaled`, `Mix` with masks, `RigidRotation`, `Translation` |
//! | verification | [`problems`] (exact solutions; classic problems by name), [`order`] (`estimate_order`, `convergence_study`) |
//! | property tests | `strategies` (feature `proptest`): methods, pairs, linear systems, states, times |
//!
//! ## States, tangents and rotations
//!
//! A state is a flat slice laid out by a [`StateLayout`]: a per-particle pattern of blocks
//! repeated `count` times, so one field carries every particle (all Gaussians of a scene).
//! A `Euclidean(n)` block is n numbers. An `So3` block stores a **unit quaternion
//! (w, x, y, z)** (4 ambient numbers) but has **3 tangent numbers**:
//!
//! - a field returns a **world-frame angular velocity** ω there (`R' = ω̂R`);
//! - cotangents (gradients) are 3-vectors with respect to the **left** perturbation
//!   `R ↦ Exp(δ)·R`, e.g. for `L = aᵀRb` the cotangent is `(Rb) × a`.
//!
//! An `Se3` block stores a rigid transform as the **unit quaternion then the translation**
//! (7 ambient numbers) and has **6 tangent numbers (ρ, φ)**, translation part first: a
//! field returns a **world-frame twist** there (`Ṫ = ξ̂T`), and cotangents are taken with
//! respect to `T ↦ Exp(δ)·T` (conventions: [`evogs_math::se3`], `docs/se3.md`).
//!
//! States are ambient; derivatives, cotangents and adjoints are tangent.
//!
//! ## The step: explicit Runge–Kutta, and RKMK on SO(3)
//!
//! One core driven by tableau constants handles every block. For a step from `(tₙ, yₙ)`:
//!
//! ```text
//! Ωᵢ = h Σ_{j<i} a_ij Kⱼ
//! Euclidean:  Xᵢ = yₙ + Ωᵢ,          Kᵢ = f(tₙ + cᵢh, Xᵢ)
//! SO(3):      Rᵢ = Exp(Ωᵢ)·Rₙ,       Kᵢ = Jl⁻¹(Ωᵢ)·ωᵢ,   ωᵢ = f(tₙ + cᵢh, Xᵢ)
//! update:     y_{n+1} = yₙ + h Σ bᵢKᵢ,   R_{n+1} = Exp(h Σ bᵢKᵢ)·Rₙ
//! ```
//!
//! On SO(3) this is the Runge–Kutta–Munthe-Kaas method: with `R(t) = Exp(Ω(t))·Rₙ`, the
//! increment obeys `Ω' = Jl⁻¹(Ω)·ω`, a vector-space ODE, and `Jl⁻¹` (the closed-form
//! `dexp⁻¹` of SO(3)) keeps the tableau's order. The Euler tableau gives Lie–Euler
//! `R ← Exp(hω)R`, classical RK4 gives RKMK4; both are exact for a constant rate, and the
//! measured orders on Problem K (a time-varying rotation with an exact solution) are
//! 1, 2, 2, 4, 4. SE(3) blocks run the same rule with the SE(3) exponential and its
//! closed-form `Jl⁻¹` (Barfoot's `Q` block), measured at the same orders on
//! [`problems::ScrewPair`] (SE(3)) and [`problems::PropelledTop`] (SE(3) × ℝ³); the discrete
//! adjoint transports cotangents with `Ad(Exp(Ω))ᵀ` instead of `Exp(Ω)ᵀ`. Integrating the
//! quaternion as a vector and renormalising would also keep
//! the order, but exp-based steps stay on the group and their adjoints live in the 3-D
//! tangent space.
//!
//! ## Discrete adjoint (exact) vs continuous adjoint (approximate)
//!
//! The **discrete adjoint** ([`discrete_adjoint`], built on [`Stepper::step_vjp`])
//! transposes the computed steps, stage by stage in reverse: it is the exact gradient of the
//! numbers the forward pass produced, to rounding, for any step size. It needs the forward
//! states: all of them, or every k-th with recomputation ([`Checkpointing`]; both give
//! bitwise identical gradients).
//!
//! The **continuous adjoint** (Chen et al. 2018; [`continuous_adjoint`]) first derives
//! the adjoint ODE `a' = −(∂f/∂x)ᵀa`, then solves it numerically backward. That is the
//! gradient of the exact flow, approximated by a second solve: it differs from the
//! gradient of the computed solution by `O(hᵖ)`. Its memory-free "reintegrate" variant
//! also solves x backward, which is ill-conditioned on dissipative dynamics: a mode that
//! decays like `e^{−50t}` forward grows like `e^{50t}` backward, so the reconstruction of
//! `x(t0)` and every gradient built on it can be off by many orders of magnitude.
//! [`ContinuousAdjoint::reconstruction_error`] reports it:
//!
//! ```
//! use evogs_ode::{ContinuousVariant, Method, TimeGrid, continuous_adjoint};
//! use evogs_ode::problems::DissipativePair; // x₁' = −50x₁ + …, ode-lie.md §4.10
//! let mut f = DissipativePair::default();
//! let (x0, c) = (DissipativePair::initial_state(), DissipativePair::loss_weights());
//! let grid = TimeGrid::uniform(0.0, 1.0, 40);
//! let back = continuous_adjoint(&mut f, Method::Rk4, &grid, &x0, &c, ContinuousVariant::Reintegrate)
//!     .unwrap();
//! assert!(back.reconstruction_error.unwrap() > 1e10); // x(0) is lost: gradients are garbage
//! ```
//!
//! ## Example: turn oriented particles and differentiate through the solve
//!
//! ```
//! use evogs_math::{Vec3, so3::exp_quat};
//! use evogs_ode::algebra::{ParticleFrame, RigidRotation};
//! use evogs_ode::{Checkpointing, Method, Stepper, TimeGrid, VectorField};
//! use evogs_ode::{discrete_adjoint, integrate_trajectory};
//!
//! // Two particles [position (3), orientation (quaternion)], rotating about the z axis.
//! let frame = ParticleFrame::oriented_points(2);
//! let mut field = RigidRotation::new(frame, Vec3::new(0.0, 0.0, 1.5), Vec3::zero());
//! let y0: [f64; 14] = [1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, /**/ 0.0, 2.0, 0.5, 1.0, 0.0, 0.0, 0.0];
//! let mut stepper = Stepper::new(Method::Rk4, field.layout()); // RKMK4 on the rotations
//! let grid = TimeGrid::with_max_step(0.0, 1.0, 0.1);
//! let traj = integrate_trajectory(&mut field, &mut stepper, &grid, &y0, Checkpointing::StoreAll);
//!
//! // Orientations follow Exp(ωt)·R₀ exactly.
//! let y1 = traj.final_state();
//! let want = exp_quat(Vec3::new(0.0, 0.0, 1.5));
//! assert!((y1[3] - want.w).abs() < 1e-14 && (y1[6] - want.z).abs() < 1e-14);
//!
//! // Gradient of L = x-coordinate of particle 0 w.r.t. the initial state and θ = [ω, c].
//! let mut d_final = vec![0.0; field.dim()];
//! d_final[0] = 1.0;
//! let mut d_y0 = vec![0.0; field.dim()];
//! let mut d_theta = vec![0.0; field.n_params()];
//! discrete_adjoint(&mut field, &mut stepper, &traj, &d_final, &mut d_y0, &mut d_theta);
//! // Exactly, x(1) = cos(1.5)·x₀ − sin(1.5)·y₀, so ∂x/∂x₀ ≈ cos 1.5 up to the RK4 error.
//! assert!((d_y0[0] - 1.5_f64.cos()).abs() < 1e-5); // RK4 error ≈ 6e-6 at ωh = 0.15
//! ```
//!
//! ## Example: an adaptive solve with dense output, and its adjoint
//!
//! Dormand–Prince on the Van der Pol oscillator (θ = (μ)), reported at times that are not
//! steps; then the gradient of `L = x₀(2.5) + x₁(4)` with respect to the initial state, μ and
//! the two output times, exact for the computed solution (steps held fixed).
//!
//! ```
//! use evogs_ode::VectorField;
//! use evogs_ode::adaptive::{AdaptiveOptions, AdaptiveSolver, Pair};
//! use evogs_ode::problems::VanDerPol;
//!
//! let mut f = VanDerPol { mu: 1.0_f64 };
//! let opts = AdaptiveOptions::with_tolerances(1e-9, 1e-9);
//! let mut solver = AdaptiveSolver::new(Pair::Dopri5, f.layout(), opts);
//! let times = [2.5, 4.0];
//! let sol = solver.solve(&mut f, 0.0, 4.0, &[2.0, 0.0], &times).unwrap();
//! let st = sol.stats();
//! assert!(st.accepted > 10 && st.field_evals == 2 + 6 * (st.accepted + st.rejected));
//!
//! // Dense output at 2.5 agrees with a solve that ends there.
//! let end = solver.solve(&mut f, 0.0, 2.5, &[2.0, 0.0], &[]).unwrap();
//! assert!((sol.output(0)[0] - end.final_state()[0]).abs() < 1e-7);
//!
//! // ∂L/∂y0, ∂L/∂μ and ∂L/∂τ for L = x₀(2.5) + x₁(4).
//! let d_out = [1.0, 0.0, /* τ = 4: */ 0.0, 1.0];
//! let (mut d_y0, mut d_mu, mut d_t) = ([0.0_f64; 2], [0.0_f64], [0.0_f64; 2]);
//! solver.adjoint(&mut f, &sol, &d_out, &mut d_y0, &mut d_mu, &mut d_t).unwrap();
//! // dL/dτ₀ is x₀'(2.5) = x₁(2.5), the field at the output.
//! assert!((d_t[0] - sol.output(0)[1]).abs() < 1e-6);
//! // The μ-gradient matches a central difference of two solves.
//! let mut solve_mu = |mu: f64| {
//!     let mut g = VanDerPol { mu };
//!     let s = solver.solve(&mut g, 0.0, 4.0, &[2.0, 0.0], &times).unwrap();
//!     s.output(0)[0] + s.output(1)[1]
//! };
//! let fd: f64 = (solve_mu(1.0 + 1e-5) - solve_mu(1.0 - 1e-5)) / 2e-5;
//! assert!((d_mu[0] - fd).abs() < 1e-4 * fd.abs().max(1.0));
//! ```
//!
//! ## Features
//!
//! `std` (default) or `libm` for the float functions (`no_std` builds use
//! `--no-default-features --features libm`); `rayon` adds
//! [`Par::Rayon`](evogs_math::Par) for the per-particle block updates of
//! [`Stepper::with_par`] (bitwise identical to sequential).
#![cfg_attr(not(feature = "std"), no_std)]

#[cfg(not(any(feature = "std", feature = "libm")))]
compile_error!("evogs-ode needs a float backend: enable the `std` (default) or the `libm` feature");

extern crate alloc;

pub mod adaptive;
mod adjoint;
pub mod algebra;
mod chunks;
mod continuous;
mod field;
pub mod fields;
mod grid;
mod integrate;
mod layout;
mod method;
pub mod order;
pub mod problems;
mod rational;
mod stepper;
#[cfg(feature = "proptest")]
pub mod strategies;
mod tableau;

pub use adjoint::{discrete_adjoint, discrete_adjoint_observed};
pub use continuous::{AdjointError, ContinuousAdjoint, ContinuousVariant, continuous_adjoint};
pub use field::VectorField;
pub use grid::TimeGrid;
pub use integrate::{Checkpointing, Trajectory, integrate, integrate_steps, integrate_trajectory};
pub use layout::{Block, BlockSpan, MAX_BLOCKS, StateLayout};
pub use method::{Method, ParseMethodError};
pub use rational::Rational;
pub use stepper::Stepper;
pub use tableau::{MAX_STAGES, OrderCondition, Tableau};
