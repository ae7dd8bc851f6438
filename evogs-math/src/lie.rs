//! The Lie group contract that [`So3`] and [`Se3`] share, so that one suite of axioms
//! (`tests/suite/lie_axioms.rs`) checks both.
//!
//! Conventions, as everywhere in this crate: tangent vectors are the `vee` coordinates of the
//! Lie algebra, perturbations are on the left (`Exp(δ)·g`), and composition reads right to
//! left (`(a * b).act(p) = a.act(b.act(p))`). For SE(3) the tangent is `(ρ, φ)`, translation
//! part first.
//!
//! ```
//! use evogs_math::lie::LieGroup;
//! use evogs_math::{Se3, So3, Vec3, Vec6};
//!
//! /// `g·Exp(x)·g⁻¹ = Exp(Ad(g)·x)` for any group of this crate.
//! fn conjugation_error<G: LieGroup<f64>>(g: G, x: G::Tangent) -> f64 {
//!     let lhs = g * G::exp(x) * g.inverse();
//!     G::tangent_norm((lhs * G::exp(g.adjoint_mul(x)).inverse()).log())
//! }
//! let r = So3::exp(Vec3::new(0.3, -0.2, 1.1));
//! assert!(conjugation_error(r, Vec3::new(0.1, 0.2, -0.4)) < 1e-15);
//! let t = Se3::from_parts(r, Vec3::new(1.0, 2.0, -0.5));
//! let xi = Vec6::new(Vec3::new(0.5, 0.0, 0.1), Vec3::new(0.0, 0.3, 0.2));
//! assert!(conjugation_error(t, xi) < 1e-14);
//! ```

use core::ops::{Add, Mul, Neg, Sub};

use crate::{Real, Se3, So3, Vec3, Vec6};

/// A matrix Lie group acting on points of R³: the operations its axioms are stated in.
///
/// Implemented by [`So3`] (tangent [`Vec3`]) and [`Se3`] (tangent [`Vec6`]); each method
/// forwards to the type's inherent method of the same name.
pub trait LieGroup<T: Real>: Copy + Mul<Output = Self> {
    /// Degrees of freedom: the dimension of the tangent space.
    const DOF: usize;
    /// Tangent coordinates (the `vee` of a Lie algebra element).
    type Tangent: Copy
        + Add<Output = Self::Tangent>
        + Sub<Output = Self::Tangent>
        + Neg<Output = Self::Tangent>
        + Mul<T, Output = Self::Tangent>;
    /// The identity element.
    fn identity() -> Self;
    /// The exponential map `Exp(x)`.
    fn exp(x: Self::Tangent) -> Self;
    /// The logarithm (rotation angle in `[0, π]`).
    fn log(self) -> Self::Tangent;
    /// The inverse element.
    #[must_use]
    fn inverse(self) -> Self;
    /// The action on a point of R³.
    fn act(self, p: Vec3<T>) -> Vec3<T>;
    /// The adjoint action `Ad(g)·x`, defined by `g·Exp(x)·g⁻¹ = Exp(Ad(g)·x)`.
    fn adjoint_mul(self, x: Self::Tangent) -> Self::Tangent;
    /// The Euclidean norm of tangent coordinates.
    fn tangent_norm(x: Self::Tangent) -> T;
}

impl<T: Real> LieGroup<T> for So3<T> {
    const DOF: usize = 3;
    type Tangent = Vec3<T>;
    fn identity() -> Self {
        Self::identity()
    }
    fn exp(x: Vec3<T>) -> Self {
        Self::exp(x)
    }
    fn log(self) -> Vec3<T> {
        Self::log(self)
    }
    fn inverse(self) -> Self {
        Self::inverse(self)
    }
    fn act(self, p: Vec3<T>) -> Vec3<T> {
        Self::act(self, p)
    }
    /// For rotations the adjoint is the rotation itself: `Ad(R)·φ = R·φ`.
    fn adjoint_mul(self, x: Vec3<T>) -> Vec3<T> {
        Self::act(self, x)
    }
    fn tangent_norm(x: Vec3<T>) -> T {
        x.norm()
    }
}

impl<T: Real> LieGroup<T> for Se3<T> {
    const DOF: usize = 6;
    type Tangent = Vec6<T>;
    fn identity() -> Self {
        Self::identity()
    }
    fn exp(x: Vec6<T>) -> Self {
        Self::exp(x)
    }
    fn log(self) -> Vec6<T> {
        Self::log(self)
    }
    fn inverse(self) -> Self {
        Self::inverse(self)
    }
    fn act(self, p: Vec3<T>) -> Vec3<T> {
        Self::act(self, p)
    }
    fn adjoint_mul(self, x: Vec6<T>) -> Vec6<T> {
        Self::adjoint_mul(self, x)
    }
    fn tangent_norm(x: Vec6<T>) -> T {
        x.norm()
    }
}

#[cfg(test)]
mod tests {
    use super::LieGroup;
    use crate::{Se3, So3, Vec3, Vec6};

    #[test]
    fn tangent_norms_are_the_euclidean_norms_of_the_coordinates() {
        // The axioms suite measures errors with these norms, so a norm stuck at zero would
        // pass every axiom: pin it to exact Pythagorean quadruples.
        let so3 = <So3<f64> as LieGroup<f64>>::tangent_norm(Vec3::new(3.0, 4.0, 12.0));
        assert!((so3 - 13.0).abs() < 1e-12, "{so3}");
        let x = Vec6::from_array([0.0, 3.0, 0.0, 4.0, 0.0, 12.0]);
        let se3 = <Se3<f64> as LieGroup<f64>>::tangent_norm(x);
        assert!((se3 - 13.0).abs() < 1e-12, "{se3}");
    }
}
