//! Reference problems with exact solutions (`docs/integrators.md` §7), for order verification,
//! tests, benches and the command line's `check-order`.
//!
//! Every problem is a [`VectorField`] (generic over the scalar, so it also runs in dual
//! numbers) with an initial state, an end time and an exact solution ([`ExactProblem`]).
//! Errors are measured with [`state_distance`]: the Euclidean norm on Euclidean blocks, the
//! rotation angle `|Log(R_exactᵀR)|` on SO(3) blocks (sign-agnostic: `q` and `−q` are the
//! same rotation), and that angle together with the translation distance on SE(3) blocks.
//!
//! | problem | layout | why |
//! |---|---|---|
//! | [`RotatingDecay`] `x' = [[α, β], [−β, α]]x` | ℝ² | linear, closed form, exact discrete gradient |
//! | [`Logistic`] `y' = r y(1 − y)` | ℝ | nonlinear: sees every order condition |
//! | [`CosGrowth`] `y' = k cos(t) y` | ℝ | non-autonomous: sees the nodes `c` |
//! | [`HarmonicOscillator`] `x'' = −ω²x` | ℝ² | energy behaviour |
//! | [`ConstantRate`] `R' = ω̂R` | SO(3) | Lie methods must be exact |
//! | [`ProblemK`] `R = Rz(a(t))Rx(b(t))` | SO(3) | non-commuting rates: separates orders |
//! | [`SymmetricTop`] | SO(3) × ℝ³ | attitude and rates coupled, closed form |
//! | [`AsymmetricTop`] | SO(3) × ℝ³ | invariants only (energy, \|L\|², spatial L) |
//! | [`ConstantTwist`] `Ṫ = ξ̂T` | SE(3) | Lie methods must be exact |
//! | [`ScrewPair`] `T = T₀Exp(a(t)ξ₁)Exp(b(t)ξ₂)` | SE(3) | state-dependent, time-varying twist: separates orders |
//! | [`PropelledTop`] | SE(3) × ℝ³ | symmetric top moving along its axis, closed form |
//! | [`DissipativePair`] | ℝ² | stiff decay: breaks the backsolve continuous adjoint |
//!
//! Without closed forms, for adaptive solvers and the adaptive reference file ([`by_name`]):
//!
//! | problem | layout | why |
//! |---|---|---|
//! | [`VanDerPol`] | ℝ² | relaxation oscillation; stiff for large μ (rejections) |
//! | [`Kepler`] | ℝ⁴ | eccentric orbits: step sizes vary by orders of magnitude |
//! | [`Lorenz`] | ℝ³ | chaotic: sensitivities grow fast |
//! | [`EulerRates`] | ℝ³ | Euler's equations of the free rigid body (rates only) |
//! | [`ForcedOscillator`] | ℝ² | non-autonomous, modulated stiffness |
//!
//! Methods of an order p show slope p on each of them (see [`crate::order`]); a linear
//! problem alone cannot tell a fake RK4 from a real one (`docs/integrators.md` §2).

mod classic;
mod linear;
mod oscillator;
mod rotation;
mod scalar;
mod se3;
mod stiff;
mod top;

pub use classic::{EulerRates, ForcedOscillator, Kepler, Lorenz, ProblemError, VanDerPol, by_name};
pub use linear::RotatingDecay;
pub use oscillator::HarmonicOscillator;
pub use rotation::{ConstantRate, ProblemK};
pub use scalar::{CosGrowth, Logistic};
pub use se3::{ConstantTwist, PropelledTop, ScrewPair};
pub use stiff::DissipativePair;
pub use top::{AsymmetricTop, RigidBody, SymmetricTop};

use crate::{Block, StateLayout, VectorField};
use evogs_math::so3::log_quat;
use evogs_math::{Quat, Real};

/// A vector field with a known initial state and exact solution.
pub trait ExactProblem<T: Real>: VectorField<T> {
    /// A short name for reports.
    fn name(&self) -> &'static str;

    /// Start time (0 unless stated).
    fn t0(&self) -> T {
        T::ZERO
    }

    /// The end time of the reference interval.
    fn t_end(&self) -> T;

    /// Writes the initial state `y(t0)` (ambient).
    fn initial_state(&self, y0: &mut [T]);

    /// Writes the exact solution `y(t)` (ambient).
    fn exact(&self, t: T, out: &mut [T]);

    /// The error of `y` against the exact state `exact`: [`state_distance`] by default.
    fn error(&self, y: &[T], exact: &[T]) -> T {
        state_distance(&self.layout(), y, exact)
    }
}

/// The distance of two states: `sqrt(Σ |Δx|² + Σ angle² + Σ (angle² + |Δt|²))` over the
/// Euclidean entries, the SO(3) blocks and the SE(3) blocks, with
/// `angle = |Log(q_bᵀ·q_a)|` (quaternions of any non-zero norm; `q` and `−q` are the same
/// rotation) and `Δt` the difference of the translations.
///
/// ```
/// use evogs_ode::{Block, StateLayout, problems::state_distance};
/// let l = StateLayout::particles(&[Block::Euclidean(1), Block::So3], 1);
/// let h = 0.1_f64;
/// let a = [3.0, 1.0, 0.0, 0.0, 0.0];
/// let b = [3.0, (h / 2.0).cos(), 0.0, 0.0, (h / 2.0).sin()]; // rotated by h about z
/// assert!((state_distance(&l, &a, &b) - h).abs() < 1e-15);
/// ```
#[must_use]
pub fn state_distance<T: Real>(layout: &StateLayout, a: &[T], b: &[T]) -> T {
    let pa = layout.particle_ambient_len();
    let mut acc = T::ZERO;
    for p in 0..layout.count() {
        for sp in layout.spans() {
            let o = p * pa + sp.ambient;
            match sp.block {
                Block::Euclidean(m) => {
                    for e in o..o + m {
                        acc += (a[e] - b[e]).sq();
                    }
                }
                Block::So3 | Block::Se3 => {
                    let qa = Quat::from_slice(&a[o..]);
                    let qb = Quat::from_slice(&b[o..]);
                    acc += log_quat(qb.conj().mul_quat(qa)).norm_squared();
                    if sp.block == Block::Se3 {
                        for e in o + 4..o + 7 {
                            acc += (a[e] - b[e]).sq();
                        }
                    }
                }
            }
        }
    }
    acc.sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The name and the reference interval's length of a problem.
    fn report<P: ExactProblem<f64>>(p: &P) -> (&'static str, f64) {
        (p.name(), p.t_end() - p.t0())
    }

    #[test]
    fn every_problem_reports_the_name_its_tables_use() {
        let reports = [
            report(&Logistic::default()),
            report(&CosGrowth::default()),
            report(&HarmonicOscillator::default()),
            report(&RotatingDecay::default()),
            report(&ConstantRate::default()),
            report(&ProblemK),
            report(&ConstantTwist::default()),
            report(&ScrewPair::default()),
            report(&PropelledTop::default()),
            report(&SymmetricTop::default()),
        ];
        for (name, length) in reports {
            assert!(length >= 1.0, "{name}: a reference interval of {length}");
        }
        let names = reports.map(|r| r.0);
        assert_eq!(
            names,
            [
                "logistic",
                "cos-growth",
                "harmonic-oscillator",
                "rotating-decay",
                "so3-constant-rate",
                "problem-k",
                "se3-constant-twist",
                "se3-screw-pair",
                "se3-propelled-top",
                "symmetric-top",
            ]
        );
    }

    #[test]
    fn the_state_distance_sums_every_block_of_every_particle() {
        // [Euclidean(1), So3, Se3] × 2: 1 + 4 + 7 ambient entries a particle.
        let layout = StateLayout::particles(&[Block::Euclidean(1), Block::So3, Block::Se3], 2);
        let id = [1.0, 0.0, 0.0, 0.0];
        let about_z = |angle: f64| [(angle / 2.0).cos(), 0.0, 0.0, (angle / 2.0).sin()];
        let particle = |x: f64, q: [f64; 4], g: [f64; 4], t: [f64; 3]| {
            let mut v = alloc::vec![x];
            v.extend(q);
            v.extend(g);
            v.extend(t);
            v
        };
        let a = [
            particle(0.5, id, id, [0.0; 3]),
            particle(1.0, id, id, [1.0, 1.0, 1.0]),
        ]
        .concat();
        let b = [
            particle(0.5, about_z(0.2), id, [0.0; 3]),
            particle(4.0, id, about_z(-0.1), [2.0, 3.0, 3.0]),
        ]
        .concat();
        // 0.2² (particle 0's rotation) + 3² + 0.1² + |(1, 2, 2)|² (particle 1).
        let expected = (0.04_f64 + 9.0 + 0.01 + 9.0).sqrt();
        let d = state_distance(&layout, &a, &b);
        assert!((d - expected).abs() < 1e-14, "{d} against {expected}");
    }
}
