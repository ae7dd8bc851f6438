//! Spatial masks λ(x) ∈ [0, 1] for [`Mix`](super::Mix): spheres and boxes with hard or
//! soft edges, or explicit per-particle weights.
//!
//! Shapes are described by a signed distance `d(x)` (negative inside):
//!
//! ```text
//! sphere (c, r):       d = |x − c| − r,                         ∇d = (x − c)/|x − c|
//! box [min, max]:      q = |x − m| − e  (m centre, e half-extents, per axis)
//!                      d = |max(q, 0)| + min(maxᵢ qᵢ, 0)
//! hard edge:           λ = 1 if d ≤ 0 else 0                    ∂λ/∂x = 0
//! soft edge (width w): λ = σ(−d/w)  (σ the logistic sigmoid)     ∂λ/∂x = −λ(1 − λ)/w · ∇d
//! ```
//!
//! A soft edge is ½ on the surface, ≈ 0.73 one width inside and ≈ 0.27 one width outside;
//! it is smooth in x, so gradients flow through the mask. A hard edge is an indicator:
//! its gradient with respect to x is zero (almost everywhere).

use alloc::vec::Vec;
use evogs_math::activation::sigmoid;
use evogs_math::{Real, Vec3};

/// How a shape's boundary blends.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Edge<T> {
    /// Indicator: λ = 1 inside or on the surface, 0 outside.
    Hard,
    /// Sigmoid of the signed distance over `width` (> 0).
    Soft {
        /// The blend width (a distance).
        width: T,
    },
}

/// A mask λ(x) ∈ [0, 1] per particle.
#[derive(Clone, Debug, PartialEq)]
pub enum Mask<T> {
    /// A ball.
    Sphere {
        /// Centre.
        center: Vec3<T>,
        /// Radius.
        radius: T,
        /// Edge profile.
        edge: Edge<T>,
    },
    /// An axis-aligned box.
    Box {
        /// Lower corner.
        min: Vec3<T>,
        /// Upper corner.
        max: Vec3<T>,
        /// Edge profile.
        edge: Edge<T>,
    },
    /// Explicit weights, one per particle (independent of x).
    Weights(Vec<T>),
}

impl<T: Real> Mask<T> {
    /// Weights 1 for the listed particles and 0 for the others (`count` particles).
    ///
    /// # Panics
    /// If an index is `>= count`.
    #[must_use]
    pub fn from_indices(count: usize, indices: &[usize]) -> Self {
        let mut w = alloc::vec![T::ZERO; count];
        for &i in indices {
            w[i] = T::ONE;
        }
        Self::Weights(w)
    }

    /// The signed distance `d(x)` and its gradient (`None` for explicit weights). Where the
    /// gradient is not defined, one of its one-sided values is given (on a box's medial
    /// planes) or zero (at a sphere's centre), never NaN.
    #[must_use]
    pub fn signed_distance(&self, x: Vec3<T>) -> Option<(T, Vec3<T>)> {
        match self {
            Self::Sphere { center, radius, .. } => {
                let r = x - *center;
                let n = r.norm();
                let grad = if n > T::ZERO {
                    r * (T::ONE / n)
                } else {
                    Vec3::zero()
                };
                Some((n - *radius, grad))
            }
            Self::Box { min, max, .. } => {
                let m = (*min + *max) * T::HALF;
                let e = (*max - *min) * T::HALF;
                let r = x - m;
                let sign = r.map(|v| if v < T::ZERO { -T::ONE } else { T::ONE });
                let q = r.map(Real::abs) - e;
                let outside = q.map(|v| v.max(T::ZERO));
                let (mut k, mut qmax) = (0, q.x);
                for i in 1..3 {
                    if q[i] > qmax {
                        k = i;
                        qmax = q[i];
                    }
                }
                if qmax > T::ZERO {
                    let n = outside.norm();
                    Some((n, outside.mul_elem(sign) * (T::ONE / n)))
                } else {
                    let mut grad = Vec3::zero();
                    grad[k] = sign[k];
                    Some((qmax, grad))
                }
            }
            Self::Weights(_) => None,
        }
    }

    fn edge(&self) -> Edge<T> {
        match self {
            Self::Sphere { edge, .. } | Self::Box { edge, .. } => *edge,
            Self::Weights(_) => Edge::Hard,
        }
    }

    /// λ for particle `p` at position `x`.
    #[must_use]
    pub fn weight(&self, p: usize, x: Vec3<T>) -> T {
        self.weight_and_grad(p, x).0
    }

    /// λ and `∂λ/∂x` for particle `p` at position `x`.
    ///
    /// # Panics
    /// For explicit weights, if `p` is out of range.
    #[must_use]
    pub fn weight_and_grad(&self, p: usize, x: Vec3<T>) -> (T, Vec3<T>) {
        if let Self::Weights(w) = self {
            return (w[p], Vec3::zero());
        }
        let (d, grad) = self
            .signed_distance(x)
            .expect("shape masks have a distance");
        match self.edge() {
            Edge::Hard => {
                let inside = if d <= T::ZERO { T::ONE } else { T::ZERO };
                (inside, Vec3::zero())
            }
            Edge::Soft { width } => {
                let l = sigmoid(-d / width);
                (l, grad * (-l * (T::ONE - l) / width))
            }
        }
    }
}
