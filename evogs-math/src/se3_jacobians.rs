//! The Jacobians of the SE(3) exponential, their inverses, and the VJPs built on them
//! (derivation and conventions: `docs/se3.md`).
//!
//! Tangents are ξ = (ρ, φ) (translation part first, [`Vec6`] `head`/`tail`). With `Jl(φ)`
//! the SO(3) left Jacobian ([`so3_jacobians`](crate::so3_jacobians)) and Barfoot's block
//!
//! ```text
//! Q(ρ, φ) = ½ ρ̂ + B (φ̂ρ̂ + ρ̂φ̂ + φ̂ρ̂φ̂) + C (φ̂²ρ̂ + ρ̂φ̂² − 3 φ̂ρ̂φ̂) + E (φ̂ρ̂φ̂² + φ̂²ρ̂φ̂)
//! B = (θ − sin θ)/θ³,  C = (θ² + 2 cos θ − 2)/(2θ⁴),  E = (2θ − 3 sin θ + θ cos θ)/(2θ⁵)
//! ```
//!
//! (θ = |φ|; the coefficients, with their small-angle series, are
//! [`theta_minus_sin_over_cube`], [`q_coeff_c`] and [`q_coeff_e`]), the Jacobians are
//!
//! ```text
//! Exp(ξ + δ) ≈ Exp(Jl(ξ) δ)·Exp(ξ) ≈ Exp(ξ)·Exp(Jr(ξ) δ)
//! Jl(ξ) = [[Jl(φ), Q(ρ, φ)], [0, Jl(φ)]]         Jr(ξ) = Jl(−ξ)
//! Jl⁻¹(ξ) = [[Jl⁻¹(φ), −Jl⁻¹(φ) Q Jl⁻¹(φ)], [0, Jl⁻¹(φ)]]
//! Jl(ξ) = Ad(Exp(ξ))·Jr(ξ),   Q(ρ, φ)ᵀ = Q(−ρ, −φ)
//! ```
//!
//! `Jl(ξ) = Σ ad(ξ)ⁿ/(n+1)!` is the series the oracle's 50-digit reference sums. `Jl⁻¹` is
//! the closed-form `dexp⁻¹` of SE(3): with `T(t) = Exp(Ω(t))·Tₙ` and a world-frame twist ξ
//! (`Ṫ = ξ̂ T`), `Ω' = Jl⁻¹(Ω)·ξ` ([`jl_inv_mul`]), which the RKMK steppers of evogs-ode
//! integrate on SE(3) blocks.
//!
//! The `*_mul` functions apply a Jacobian without forming it; their VJPs
//! ([`jl_mul_vjp`], [`jl_inv_mul_vjp`]) chain the closed-form SO(3) VJPs with
//! [`q_mul_vjp`].

use crate::so3::hat;
use crate::so3_coeffs::{q_coeff_c, q_coeff_e, theta_minus_sin_over_cube};
use crate::so3_jacobians as so3j;
use crate::{Dual, Mat3, Mat6, Real, Vec3, Vec6};

/// Barfoot's `Q(ρ, φ)` block of the SE(3) left Jacobian (the module docs give the formula).
///
/// The coefficients switch to their series below θ = 1.5, so the block is accurate to
/// about 1e-16 relative at every angle, including θ = 1e-12 … 1e-2.
#[must_use]
pub fn q_matrix<T: Real>(rho: Vec3<T>, phi: Vec3<T>) -> Mat3<T> {
    let t2 = phi.norm_squared();
    let (p, r) = (hat(phi), hat(rho));
    let pr = p * r;
    let rp = r * p;
    let prp = pr * p;
    r.scale(T::HALF)
        + (pr + rp + prp).scale(theta_minus_sin_over_cube(t2))
        + (p * pr + rp * p - prp.scale(T::from_f64(3.0))).scale(q_coeff_c(t2))
        + (prp * p + p * prp).scale(q_coeff_e(t2))
}

/// `Q(ρ, φ)·v` without forming the matrix (`Q(ρ, φ)ᵀ·v` is `q_mul(−ρ, −φ, v)`).
#[inline]
#[must_use]
pub fn q_mul<T: Real>(rho: Vec3<T>, phi: Vec3<T>, v: Vec3<T>) -> Vec3<T> {
    let t2 = phi.norm_squared();
    let a = rho.cross(v); // ρ̂v
    let b = phi.cross(v); // φ̂v
    let pa = phi.cross(a); // φ̂ρ̂v
    let rb = rho.cross(b); // ρ̂φ̂v
    let prb = phi.cross(rb); // φ̂ρ̂φ̂v
    let ppa = phi.cross(pa); // φ̂²ρ̂v
    let rpb = rho.cross(phi.cross(b)); // ρ̂φ̂²v
    let prpb = phi.cross(rpb); // φ̂ρ̂φ̂²v
    let pprb = phi.cross(prb); // φ̂²ρ̂φ̂v
    a * T::HALF
        + (pa + rb + prb) * theta_minus_sin_over_cube(t2)
        + (ppa + rpb - prb * T::from_f64(3.0)) * q_coeff_c(t2)
        + (prpb + pprb) * q_coeff_e(t2)
}

fn lift<T: Real>(v: Vec3<T>) -> Vec3<Dual<T>> {
    Vec3::new(
        Dual::constant(v.x),
        Dual::constant(v.y),
        Dual::constant(v.z),
    )
}

/// VJP of [`q_mul`]: given the cotangent `g` of `Q(ρ, φ)·v`, returns
/// `(∂L/∂ρ, ∂L/∂φ, ∂L/∂v)`.
///
/// `∂L/∂v = Q(ρ, φ)ᵀ g = Q(−ρ, −φ) g`; the ρ and φ parts are six forward-mode
/// (dual-number) evaluations of `g·Q(ρ, φ)v`, exact to rounding in every branch of the
/// coefficients.
#[must_use]
pub fn q_mul_vjp<T: Real>(
    rho: Vec3<T>,
    phi: Vec3<T>,
    v: Vec3<T>,
    g: Vec3<T>,
) -> (Vec3<T>, Vec3<T>, Vec3<T>) {
    let (rd, pd, vd, gd) = (lift(rho), lift(phi), lift(v), lift(g));
    let mut d_rho = Vec3::zero();
    let mut d_phi = Vec3::zero();
    for j in 0..3 {
        let mut r = rd;
        r[j].eps = T::ONE;
        d_rho[j] = q_mul(r, pd, vd).dot(gd).eps;
        let mut p = pd;
        p[j].eps = T::ONE;
        d_phi[j] = q_mul(rd, p, vd).dot(gd).eps;
    }
    (d_rho, d_phi, q_mul(-rho, -phi, g))
}

/// The left Jacobian `Jl(ξ) = [[Jl(φ), Q(ρ, φ)], [0, Jl(φ)]]`.
///
/// ```
/// use evogs_math::{Se3, Vec3, Vec6, se3_jacobians::left_jacobian};
/// // Exp(ξ + δ)·Exp(ξ)⁻¹ ≈ Exp(Jl(ξ) δ) for a small δ.
/// let xi = Vec6::new(Vec3::new(0.5, -0.2, 1.0), Vec3::new(0.3, 0.8, -0.4));
/// let d = Vec6::new(Vec3::new(1.0, 2.0, -1.0), Vec3::new(0.5, -0.3, 0.2)) * 1e-7;
/// let lhs = (Se3::exp(xi + d) * Se3::exp(xi).inverse()).log();
/// assert!((lhs - left_jacobian(xi).mul_vec(d)).norm() < 1e-13);
/// ```
#[must_use]
pub fn left_jacobian<T: Real>(xi: Vec6<T>) -> Mat6<T> {
    let j = so3j::left_jacobian(xi.tail);
    Mat6::from_blocks(j, q_matrix(xi.head, xi.tail), Mat3::zero(), j)
}

/// The right Jacobian `Jr(ξ) = Jl(−ξ)`.
#[must_use]
pub fn right_jacobian<T: Real>(xi: Vec6<T>) -> Mat6<T> {
    left_jacobian(-xi)
}

/// The inverse left Jacobian `[[Jl⁻¹(φ), −Jl⁻¹(φ) Q Jl⁻¹(φ)], [0, Jl⁻¹(φ)]]` (finite for
/// θ < 2π).
#[must_use]
pub fn left_jacobian_inv<T: Real>(xi: Vec6<T>) -> Mat6<T> {
    let ji = so3j::left_jacobian_inv(xi.tail);
    let top_right = -(ji * q_matrix(xi.head, xi.tail) * ji);
    Mat6::from_blocks(ji, top_right, Mat3::zero(), ji)
}

/// The inverse right Jacobian `Jr⁻¹(ξ) = Jl⁻¹(−ξ)`.
#[must_use]
pub fn right_jacobian_inv<T: Real>(xi: Vec6<T>) -> Mat6<T> {
    left_jacobian_inv(-xi)
}

/// `Jl(ξ)·v = (Jl(φ) v_ρ + Q(ρ, φ) v_φ, Jl(φ) v_φ)`, without forming the matrix.
#[inline]
#[must_use]
pub fn jl_mul<T: Real>(xi: Vec6<T>, v: Vec6<T>) -> Vec6<T> {
    let (rho, phi) = (xi.head, xi.tail);
    Vec6::new(
        so3j::jl_mul(phi, v.head) + q_mul(rho, phi, v.tail),
        so3j::jl_mul(phi, v.tail),
    )
}

/// `Jl(ξ)ᵀ·v = (Jl(φ)ᵀ v_ρ, Q(ρ, φ)ᵀ v_ρ + Jl(φ)ᵀ v_φ)`, using `Jl(φ)ᵀ = Jl(−φ)` and
/// `Q(ρ, φ)ᵀ = Q(−ρ, −φ)`. (On SE(3), unlike SO(3), `Jl(ξ)ᵀ ≠ Jr(ξ)`.)
#[inline]
#[must_use]
pub fn jl_tr_mul<T: Real>(xi: Vec6<T>, v: Vec6<T>) -> Vec6<T> {
    let (rho, phi) = (xi.head, xi.tail);
    Vec6::new(
        so3j::jl_mul(-phi, v.head),
        q_mul(-rho, -phi, v.head) + so3j::jl_mul(-phi, v.tail),
    )
}

/// `Jl⁻¹(ξ)·v`: with `u = Jl⁻¹(φ) v_φ`, `(Jl⁻¹(φ)(v_ρ − Q(ρ, φ) u), u)`.
///
/// ```
/// use evogs_math::{Vec3, Vec6, se3_jacobians::{jl_inv_mul, jl_mul}};
/// let xi = Vec6::new(Vec3::new(0.5, -0.2, 1.0), Vec3::new(0.3, 2.8, -0.4));
/// let v = Vec6::new(Vec3::new(1.0, 2.0, -1.0), Vec3::new(0.5, -0.3, 0.2));
/// assert!((jl_mul(xi, jl_inv_mul(xi, v)) - v).norm() < 1e-14);
/// ```
#[inline]
#[must_use]
pub fn jl_inv_mul<T: Real>(xi: Vec6<T>, v: Vec6<T>) -> Vec6<T> {
    let (rho, phi) = (xi.head, xi.tail);
    let u = so3j::jl_inv_mul(phi, v.tail);
    Vec6::new(so3j::jl_inv_mul(phi, v.head - q_mul(rho, phi, u)), u)
}

/// `Jl⁻¹(ξ)ᵀ·v`: with `a = Jl⁻¹(φ)ᵀ v_ρ`, `(a, Jl⁻¹(φ)ᵀ(v_φ − Q(ρ, φ)ᵀ a))`.
#[inline]
#[must_use]
pub fn jl_inv_tr_mul<T: Real>(xi: Vec6<T>, v: Vec6<T>) -> Vec6<T> {
    let (rho, phi) = (xi.head, xi.tail);
    let a = so3j::jl_inv_mul(-phi, v.head);
    Vec6::new(a, so3j::jl_inv_mul(-phi, v.tail - q_mul(-rho, -phi, a)))
}

/// VJP of [`jl_mul`]: given the cotangent `g` of `Jl(ξ)·v`, returns `(∂L/∂ξ, ∂L/∂v)`.
///
/// `∂L/∂v = Jl(ξ)ᵀ g`; `∂L/∂ξ` chains [`so3_jacobians::jl_mul_vjp`](so3j::jl_mul_vjp) for
/// the two SO(3) blocks with [`q_mul_vjp`] for the `Q` block.
///
/// ```
/// use evogs_math::{Vec3, Vec6, se3_jacobians::{jl_mul, jl_mul_vjp}};
/// use evogs_math::diff::{central_gradient, GradCheck};
/// let xi = Vec6::new(Vec3::new(0.5, -0.2, 1.0), Vec3::new(0.3, 0.8, -0.4));
/// let v = Vec6::new(Vec3::new(1.0, 2.0, -1.0), Vec3::new(0.5, -0.3, 0.2));
/// let g = Vec6::new(Vec3::new(0.2, 0.1, -0.7), Vec3::new(-0.4, 0.9, 0.3));
/// let (d_xi, _) = jl_mul_vjp(xi, v, g);
/// let mut x = xi.to_array();
/// let mut num = [0.0; 6];
/// central_gradient(|p: &[f64]| jl_mul(Vec6::from_slice(p), v).dot(g), &mut x, &mut num);
/// assert!(GradCheck::new(1e-10, 1e-8).check(&d_xi.to_array(), &num).passed());
/// ```
#[must_use]
pub fn jl_mul_vjp<T: Real>(xi: Vec6<T>, v: Vec6<T>, g: Vec6<T>) -> (Vec6<T>, Vec6<T>) {
    let (rho, phi) = (xi.head, xi.tail);
    let (d_phi_a, d_vr) = so3j::jl_mul_vjp(phi, v.head, g.head);
    let (d_rho, d_phi_q, d_vp_q) = q_mul_vjp(rho, phi, v.tail, g.head);
    let (d_phi_b, d_vp) = so3j::jl_mul_vjp(phi, v.tail, g.tail);
    (
        Vec6::new(d_rho, d_phi_a + d_phi_q + d_phi_b),
        Vec6::new(d_vr, d_vp + d_vp_q),
    )
}

/// VJP of [`jl_inv_mul`]: given the cotangent `g` of `Jl⁻¹(ξ)·v`, returns
/// `(∂L/∂ξ, ∂L/∂v)` (`∂L/∂v = Jl⁻¹(ξ)ᵀ g`), by reversing the three steps of
/// [`jl_inv_mul`] with [`so3_jacobians::jl_inv_mul_vjp`](so3j::jl_inv_mul_vjp) and
/// [`q_mul_vjp`].
#[must_use]
pub fn jl_inv_mul_vjp<T: Real>(xi: Vec6<T>, v: Vec6<T>, g: Vec6<T>) -> (Vec6<T>, Vec6<T>) {
    let (rho, phi) = (xi.head, xi.tail);
    let u = so3j::jl_inv_mul(phi, v.tail);
    let w = v.head - q_mul(rho, phi, u);
    // top = Jl⁻¹(φ) w
    let (d_phi_a, d_w) = so3j::jl_inv_mul_vjp(phi, w, g.head);
    // w = v_ρ − Q(ρ, φ) u
    let (d_rho, d_phi_q, d_u_q) = q_mul_vjp(rho, phi, u, d_w);
    // u = Jl⁻¹(φ) v_φ (also the bottom output)
    let (d_phi_b, d_vp) = so3j::jl_inv_mul_vjp(phi, v.tail, g.tail - d_u_q);
    (
        Vec6::new(-d_rho, d_phi_a - d_phi_q + d_phi_b),
        Vec6::new(d_w, d_vp),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diff::{GradCheck, central_gradient, dual_jvp, vjp_dot_test};
    use crate::se3::{Se3, ad};

    /// Tangents with rotation angles from 0 through 1e-12 … 1e-2 to near π (and one beyond).
    fn samples() -> Vec<Vec6<f64>> {
        let rho = Vec3::new(0.7, -1.3, 0.4);
        let axis = Vec3::new(0.48, -0.6, 0.64); // unit
        let mut out = vec![Vec6::new(rho, Vec3::zero())];
        for angle in [
            1e-12, 1e-9, 1e-6, 1e-4, 1e-3, 1e-2, 0.3, 1.49, 1.51, 2.5, 3.1, 4.0,
        ] {
            out.push(Vec6::new(rho, axis * angle));
        }
        out.push(Vec6::new(Vec3::zero(), axis * 0.8));
        out
    }

    /// `Σ_{n≤N} ad(ξ)ⁿ/(n+1)!`, the defining series of `Jl` (converged for these |ξ|).
    fn jl_series(xi: Vec6<f64>) -> Mat6<f64> {
        let a = ad(xi);
        let mut term = Mat6::identity();
        let mut sum = Mat6::identity();
        for n in 1..60 {
            term = (term * a).scale(1.0 / (f64::from(n) + 1.0));
            sum = sum + term;
        }
        sum
    }

    #[test]
    fn closed_form_matches_the_series_and_the_inverse() {
        for xi in samples() {
            let jl = left_jacobian(xi);
            if xi.tail.norm() < 3.2 {
                let d = (jl - jl_series(xi)).max_abs();
                assert!(d < 1e-14, "Jl closed form vs series at {xi:?}: {d:e}");
            }
            let i = jl * left_jacobian_inv(xi) - Mat6::identity();
            assert!(i.max_abs() < 1e-13, "Jl Jl⁻¹ = I at {xi:?}");
            let ad_jr = Se3::exp(xi).adjoint() * right_jacobian(xi);
            assert!(
                (jl - ad_jr).max_abs() < 1e-14,
                "Jl = Ad(Exp ξ) Jr at {xi:?}"
            );
        }
    }

    #[test]
    fn small_angle_q_block_is_accurate() {
        // The block of the defining series, summed in f64, is exact to rounding at small
        // angles (ad(ξ)ⁿ shrinks like θⁿ⁻¹); the closed form's series branch must match it.
        let rho = Vec3::new(0.7, -1.3, 0.4);
        for angle in [1e-12, 1e-10, 1e-8, 1e-6, 1e-4, 1e-3, 1e-2] {
            let phi = Vec3::new(0.48, -0.6, 0.64) * angle;
            let want = jl_series(Vec6::new(rho, phi)).block(0, 1);
            let err = (q_matrix(rho, phi) - want).max_abs();
            assert!(err < 1e-15, "Q at θ = {angle:e}: error {err:e}");
        }
    }

    #[test]
    fn products_match_the_matrices() {
        let v = Vec6::from_array([0.3, -0.2, 0.9, 1.1, -0.4, 0.25]);
        for xi in samples() {
            let (jl, ji) = (left_jacobian(xi), left_jacobian_inv(xi));
            let q = q_matrix(xi.head, xi.tail);
            assert!(
                (q_mul(xi.head, xi.tail, v.head) - q.mul_vec(v.head)).norm() < 1e-15,
                "Q v"
            );
            assert!(
                (q.transpose() - q_matrix(-xi.head, -xi.tail)).max_abs() < 1e-15,
                "Qᵀ = Q(−ρ, −φ)"
            );
            let pairs = [
                ("Jl v", jl_mul(xi, v), jl.mul_vec(v)),
                ("Jlᵀ v", jl_tr_mul(xi, v), jl.tr_mul_vec(v)),
                ("Jl⁻¹ v", jl_inv_mul(xi, v), ji.mul_vec(v)),
                ("Jl⁻ᵀ v", jl_inv_tr_mul(xi, v), ji.tr_mul_vec(v)),
            ];
            for (what, a, b) in pairs {
                assert!((a - b).norm() < 1e-14, "{what} at {xi:?}");
            }
        }
    }

    type Vjp = fn(Vec6<f64>, Vec6<f64>, Vec6<f64>) -> (Vec6<f64>, Vec6<f64>);
    type DualMap = fn(Vec6<Dual<f64>>, Vec6<Dual<f64>>) -> Vec6<Dual<f64>>;

    /// A VJP against central differences (both arguments) and against the dual-number JVP
    /// of the same generic function (dot-product test).
    fn check_vjp(what: &str, f: fn(Vec6<f64>, Vec6<f64>) -> Vec6<f64>, fd: DualMap, vjp: Vjp) {
        let v = Vec6::from_array([0.3, -0.2, 0.9, 1.1, -0.4, 0.25]);
        let g = Vec6::from_array([-0.6, 0.5, 0.1, 0.35, 0.8, -0.9]);
        for xi in samples() {
            let (d_xi, d_v) = vjp(xi, v, g);
            let mut x = [xi.to_array(), v.to_array()].concat();
            let mut num = [0.0; 12];
            central_gradient(
                |p: &[f64]| f(Vec6::from_slice(p), Vec6::from_slice(&p[6..])).dot(g),
                &mut x,
                &mut num,
            );
            let analytic = [d_xi.to_array(), d_v.to_array()].concat();
            GradCheck::new(1e-9, 1e-7)
                .check(&analytic, &num)
                .assert_passed(&format!("{what} at {xi:?}"));
            let x0 = [xi.to_array(), v.to_array()].concat();
            let r = vjp_dot_test(
                |dir: &[f64], out: &mut [f64]| {
                    dual_jvp(
                        |p: &[Dual<f64>], y: &mut [Dual<f64>]| {
                            fd(Vec6::from_slice(p), Vec6::from_slice(&p[6..])).write_to(y);
                        },
                        &x0,
                        dir,
                        out,
                    );
                },
                |gg: &[f64], out: &mut [f64]| {
                    let (a, b) = vjp(xi, v, Vec6::from_slice(gg));
                    a.write_to(out);
                    b.write_to(&mut out[6..]);
                },
                12,
                6,
                7,
            );
            assert!(r < 1e-13, "{what}: dot-product residual {r:e} at {xi:?}");
        }
    }

    #[test]
    fn jl_mul_vjp_matches_fd_and_dual_numbers() {
        check_vjp("jl_mul_vjp", jl_mul, jl_mul, jl_mul_vjp);
    }

    #[test]
    fn jl_inv_mul_vjp_matches_fd_and_dual_numbers() {
        check_vjp("jl_inv_mul_vjp", jl_inv_mul, jl_inv_mul, jl_inv_mul_vjp);
    }
}
