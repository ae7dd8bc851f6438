//! One suite of Lie group axioms, run on every group of the crate ([`LieGroup`]: SO(3) and
//! SE(3)) over the public proptest strategies: identity, associativity, inverses, the
//! exponential and logarithm as inverse maps (below angle π), one-parameter subgroups, the
//! action as a homomorphism, and the adjoint as conjugation. What is particular to one group
//! (matrices, Jacobians, VJPs) stays in `properties.rs` and `se3_properties.rs`.

use evogs_math::lie::LieGroup;
use evogs_math::strategies::{se3, se3_tangent, so3_tangent, unit_quat, vec3};
use evogs_math::{Se3, So3, Vec3};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// Distance of two elements: `|Log(a·b⁻¹)|`.
fn dist<G: LieGroup<f64>>(a: G, b: G) -> f64 {
    G::tangent_norm((a * b.inverse()).log())
}

/// The group axioms for elements `a, b, c`, a tangent `x` of angle below π and a point `p`.
/// `tol` is the absolute tolerance of a distance between two elements built from these
/// inputs (it carries the size of the translations, for SE(3)).
fn axioms<G: LieGroup<f64> + core::fmt::Debug>(
    a: G,
    b: G,
    c: G,
    x: G::Tangent,
    p: Vec3<f64>,
    tol: f64,
) -> Result<(), TestCaseError> {
    let e = G::identity();
    // A group.
    prop_assert!(dist((a * b) * c, a * (b * c)) < tol, "associativity");
    prop_assert!(dist(a * e, a) < tol && dist(e * a, a) < tol, "identity");
    prop_assert!(dist(a * a.inverse(), e) < tol, "right inverse");
    prop_assert!(dist(a.inverse() * a, e) < tol, "left inverse");
    prop_assert!(
        dist(a.inverse().inverse(), a) < tol,
        "inverse of the inverse"
    );
    prop_assert!(
        dist((a * b).inverse(), b.inverse() * a.inverse()) < tol,
        "inverse of a product"
    );
    // Exp and Log.
    prop_assert!(dist(G::exp(a.log()), a) < tol, "Exp(Log(a)) = a");
    let xn = G::tangent_norm(x).max(1.0);
    prop_assert!(
        G::tangent_norm(G::exp(x).log() - x) < 1e-12 * xn,
        "Log(Exp(x)) = x below π"
    );
    prop_assert!(
        dist(G::exp(x) * G::exp(-x), e) < 1e-14 * xn,
        "Exp(-x) is the inverse of Exp(x)"
    );
    prop_assert!(
        dist(G::exp(x * 0.25) * G::exp(x * 0.75), G::exp(x)) < 1e-13 * xn,
        "Exp(sx)·Exp(tx) = Exp((s+t)x)"
    );
    prop_assert!(dist(G::exp(x * 0.0), e) == 0.0, "Exp(0) is the identity");
    // The action.
    let pn = 1.0 + p.norm();
    prop_assert!((e.act(p) - p).norm() == 0.0, "the identity acts trivially");
    prop_assert!(
        ((a * b).act(p) - a.act(b.act(p))).norm() < tol * pn,
        "the action is a homomorphism"
    );
    prop_assert!(
        (a.inverse().act(a.act(p)) - p).norm() < tol * pn,
        "the inverse undoes the action"
    );
    // The adjoint: a·Exp(x)·a⁻¹ = Exp(Ad(a)·x), and Ad(Exp x) fixes x.
    prop_assert!(
        dist(a * G::exp(x) * a.inverse(), G::exp(a.adjoint_mul(x))) < 1e2 * tol * xn,
        "the adjoint conjugates the exponential"
    );
    prop_assert!(
        G::tangent_norm(G::exp(x).adjoint_mul(x) - x) < 1e-13 * xn,
        "Ad(Exp x) fixes x"
    );
    prop_assert!(
        G::tangent_norm((a * b).adjoint_mul(x) - a.adjoint_mul(b.adjoint_mul(x))) < 1e2 * tol * xn,
        "the adjoint is a homomorphism"
    );
    Ok(())
}

proptest! {
    #[test]
    fn so3_satisfies_the_group_axioms(
        a in unit_quat(), b in unit_quat(), c in unit_quat(),
        x in so3_tangent(0.999 * core::f64::consts::PI), p in vec3(3.0),
    ) {
        let (a, b, c) = (So3::from_unit_quat(a), So3::from_unit_quat(b), So3::from_unit_quat(c));
        axioms(a, b, c, x, p, 1e-14)?;
        prop_assert_eq!(<So3<f64> as LieGroup<f64>>::DOF, 3);
    }

    #[test]
    fn se3_satisfies_the_group_axioms(
        a in se3(5.0), b in se3(5.0), c in se3(5.0),
        x in se3_tangent(0.999 * core::f64::consts::PI, 5.0), p in vec3(4.0),
    ) {
        // Distances are |Log(·)| of products, so they carry the rounding of the translations.
        let s = 1.0 + a.translation().norm() + b.translation().norm() + c.translation().norm();
        axioms(a, b, c, x, p, 1e-13 * s)?;
        prop_assert_eq!(<Se3<f64> as LieGroup<f64>>::DOF, 6);
    }
}

/// The suite can fail: a "group" whose inverse is off by a small rotation breaks it.
#[test]
fn the_suite_sees_a_broken_inverse() {
    #[derive(Clone, Copy, Debug)]
    struct Skewed(So3<f64>);
    impl core::ops::Mul for Skewed {
        type Output = Self;
        fn mul(self, o: Self) -> Self {
            Self(self.0 * o.0)
        }
    }
    impl LieGroup<f64> for Skewed {
        const DOF: usize = 3;
        type Tangent = Vec3<f64>;
        fn identity() -> Self {
            Self(So3::identity())
        }
        fn exp(x: Vec3<f64>) -> Self {
            Self(So3::exp(x))
        }
        fn log(self) -> Vec3<f64> {
            self.0.log()
        }
        fn inverse(self) -> Self {
            Self(So3::exp(Vec3::new(1e-9, 0.0, 0.0)) * self.0.inverse())
        }
        fn act(self, p: Vec3<f64>) -> Vec3<f64> {
            self.0.act(p)
        }
        fn adjoint_mul(self, x: Vec3<f64>) -> Vec3<f64> {
            self.0.act(x)
        }
        fn tangent_norm(x: Vec3<f64>) -> f64 {
            x.norm()
        }
    }
    let g = Skewed(So3::exp(Vec3::new(0.2, 0.4, -0.1)));
    let x = Vec3::new(0.3, 0.0, 0.2);
    let broken = axioms(g, g, g, x, Vec3::new(1.0, 2.0, 3.0), 1e-14);
    assert!(broken.is_err(), "a wrong inverse must fail the suite");
    let fine = axioms(
        So3::exp(Vec3::new(0.2, 0.4, -0.1)),
        So3::exp(Vec3::new(-1.0, 0.1, 0.7)),
        So3::exp(Vec3::new(0.0, 2.0, 0.3)),
        x,
        Vec3::new(1.0, 2.0, 3.0),
        1e-14,
    );
    assert!(fine.is_ok(), "{fine:?}");
}
