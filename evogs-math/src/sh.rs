//! Real spherical harmonics of degree 0 to 3 (the 3DGS colour basis), with VJPs.
//!
//! Coefficients are stored `coeffs[k][channel]`, `k < (degree + 1)²`, DC first, in the
//! order used by gsplat, 3DGS and the `.ply` files. The basis (x, y, z = the unit view
//! direction d̂, `docs/splatting.md` §10):
//!
//! ```text
//! Y0 = C0
//! Y1 = −C1 y    Y2 = C1 z    Y3 = −C1 x
//! Y4 = C2₀ xy   Y5 = C2₁ yz  Y6 = C2₂ (2z² − x² − y²)  Y7 = C2₃ xz  Y8 = C2₄ (x² − y²)
//! Y9 = C3₀ y(3x² − y²)  Y10 = C3₁ xyz  Y11 = C3₂ y(4z² − x² − y²)
//! Y12 = C3₃ z(2z² − 3x² − 3y²)  Y13 = C3₄ x(4z² − x² − y²)  Y14 = C3₅ z(x² − y²)
//! Y15 = C3₆ x(x² − 3y²)
//! ```
//!
//! [`sh_eval`] returns `Σ_k Y_k(d̂) coeffs[k]` (no offset, no clamp: the renderer adds
//! +0.5 and clamps at 0). Directions need not be unit: they are normalised inside, and
//! [`sh_eval_vjp`] differentiates through the normalisation, `d(dir) = (I − d̂d̂ᵀ) dd̂/|dir|`.

use crate::activation::{normalize_vec3, normalize_vec3_vjp};
use crate::{Real, Vec3};

/// C0 = 1/(2√π).
pub const SH_C0: f64 = 0.28209479177387814;
/// C1 = √3/(2√π).
pub const SH_C1: f64 = 0.4886025119029199;
/// Degree-2 constants.
pub const SH_C2: [f64; 5] = [
    1.0925484305920792,
    -1.0925484305920792,
    0.31539156525252005,
    -1.0925484305920792,
    0.5462742152960396,
];
/// Degree-3 constants.
pub const SH_C3: [f64; 7] = [
    -0.5900435899266435,
    2.890611442640554,
    -0.4570457994644658,
    0.3731763325901154,
    -0.4570457994644658,
    1.445305721320277,
    -0.5900435899266435,
];

/// The largest supported degree.
pub const MAX_SH_DEGREE: usize = 3;
/// The number of coefficients at the largest degree.
pub const MAX_SH_COEFFS: usize = 16;

/// Number of coefficients per channel for a degree: `(degree + 1)²`.
#[inline]
#[must_use]
pub const fn sh_coeff_count(degree: usize) -> usize {
    (degree + 1) * (degree + 1)
}

/// The basis values `Y_k(d)` for `k < (degree + 1)²` at a **unit** direction `d`, written
/// into `out[..(degree + 1)²]`.
///
/// # Panics
/// If `degree > 3`.
pub fn sh_basis<T: Real>(degree: usize, d: Vec3<T>, out: &mut [T; MAX_SH_COEFFS]) {
    assert!(degree <= MAX_SH_DEGREE, "SH degree {degree} > 3");
    let c = |v: f64| T::from_f64(v);
    let (x, y, z) = (d.x, d.y, d.z);
    out[0] = c(SH_C0);
    if degree == 0 {
        return;
    }
    out[1] = -c(SH_C1) * y;
    out[2] = c(SH_C1) * z;
    out[3] = -c(SH_C1) * x;
    if degree == 1 {
        return;
    }
    let (xx, yy, zz) = (x * x, y * y, z * z);
    out[4] = c(SH_C2[0]) * x * y;
    out[5] = c(SH_C2[1]) * y * z;
    out[6] = c(SH_C2[2]) * (T::TWO * zz - xx - yy);
    out[7] = c(SH_C2[3]) * x * z;
    out[8] = c(SH_C2[4]) * (xx - yy);
    if degree == 2 {
        return;
    }
    let three = c(3.0);
    let four = c(4.0);
    out[9] = c(SH_C3[0]) * y * (three * xx - yy);
    out[10] = c(SH_C3[1]) * x * y * z;
    out[11] = c(SH_C3[2]) * y * (four * zz - xx - yy);
    out[12] = c(SH_C3[3]) * z * (T::TWO * zz - three * xx - three * yy);
    out[13] = c(SH_C3[4]) * x * (four * zz - xx - yy);
    out[14] = c(SH_C3[5]) * z * (xx - yy);
    out[15] = c(SH_C3[6]) * x * (xx - three * yy);
}

/// `Σ_k w_k ∇Y_k(d)`: the gradient of a weighted basis sum with respect to the (unit)
/// direction's components, using the analytic derivatives of the table in `docs/splatting.md`
/// §10.
pub fn sh_basis_grad<T: Real>(degree: usize, d: Vec3<T>, w: &[T; MAX_SH_COEFFS]) -> Vec3<T> {
    let c = |v: f64| T::from_f64(v);
    let (x, y, z) = (d.x, d.y, d.z);
    let mut g = Vec3::zero();
    if degree == 0 {
        return g;
    }
    g.y -= c(SH_C1) * w[1];
    g.z += c(SH_C1) * w[2];
    g.x -= c(SH_C1) * w[3];
    if degree == 1 {
        return g;
    }
    let two = T::TWO;
    g += Vec3::new(y, x, T::ZERO) * (c(SH_C2[0]) * w[4]);
    g += Vec3::new(T::ZERO, z, y) * (c(SH_C2[1]) * w[5]);
    g += Vec3::new(-two * x, -two * y, c(4.0) * z) * (c(SH_C2[2]) * w[6]);
    g += Vec3::new(z, T::ZERO, x) * (c(SH_C2[3]) * w[7]);
    g += Vec3::new(two * x, -two * y, T::ZERO) * (c(SH_C2[4]) * w[8]);
    if degree == 2 {
        return g;
    }
    let (xx, yy, zz) = (x * x, y * y, z * z);
    let (three, four, six, eight) = (c(3.0), c(4.0), c(6.0), c(8.0));
    g += Vec3::new(six * x * y, three * (xx - yy), T::ZERO) * (c(SH_C3[0]) * w[9]);
    g += Vec3::new(y * z, x * z, x * y) * (c(SH_C3[1]) * w[10]);
    g +=
        Vec3::new(-two * x * y, four * zz - xx - three * yy, eight * y * z) * (c(SH_C3[2]) * w[11]);
    g +=
        Vec3::new(-six * x * z, -six * y * z, three * (two * zz - xx - yy)) * (c(SH_C3[3]) * w[12]);
    g +=
        Vec3::new(four * zz - three * xx - yy, -two * x * y, eight * x * z) * (c(SH_C3[4]) * w[13]);
    g += Vec3::new(two * x * z, -two * y * z, xx - yy) * (c(SH_C3[5]) * w[14]);
    g += Vec3::new(three * (xx - yy), -six * x * y, T::ZERO) * (c(SH_C3[6]) * w[15]);
    g
}

/// `Σ_k Y_k(dir/|dir|)·coeffs[k]` per channel (no +0.5 offset, no clamp).
///
/// # Panics
/// If `coeffs` has fewer than `(degree + 1)²` entries or `degree > 3`.
///
/// ```
/// use evogs_math::{Vec3, sh::{sh_eval, SH_C0}};
/// let dc = [[1.0, 2.0, 3.0]];
/// let c = sh_eval(0, &dc, Vec3::new(0.0, 0.0, 5.0));
/// assert!((c[1] - 2.0 * SH_C0).abs() < 1e-16);
/// ```
#[must_use]
pub fn sh_eval<T: Real>(degree: usize, coeffs: &[[T; 3]], dir: Vec3<T>) -> [T; 3] {
    let k = sh_coeff_count(degree);
    assert!(
        coeffs.len() >= k,
        "need {k} SH coefficients, got {}",
        coeffs.len()
    );
    let mut basis = [T::ZERO; MAX_SH_COEFFS];
    let d = if degree == 0 {
        dir
    } else {
        normalize_vec3(dir)
    };
    sh_basis(degree, d, &mut basis);
    let mut out = [T::ZERO; 3];
    for (b, c) in basis.iter().zip(coeffs).take(k) {
        for ch in 0..3 {
            out[ch] += *b * c[ch];
        }
    }
    out
}

/// VJP of [`sh_eval`]: **adds** `∂L/∂coeffs` into `d_coeffs` and returns `∂L/∂dir` (through
/// the normalisation; zero for degree 0).
///
/// # Panics
/// If `coeffs` or `d_coeffs` has fewer than `(degree + 1)²` entries.
///
/// ```
/// use evogs_math::{Vec3, sh::{sh_eval, sh_eval_vjp}};
/// use evogs_math::diff::{central_gradient, GradCheck};
/// let coeffs: Vec<[f64; 3]> = (0..16).map(|k| [0.1 * k as f64, -0.05, 0.3]).collect();
/// let (dir, g) = (Vec3::new(0.3, -1.2, 2.0), [0.5, -1.0, 0.25]);
/// let mut dc = vec![[0.0; 3]; 16];
/// let d_dir = sh_eval_vjp(3, &coeffs, dir, g, &mut dc);
/// let f = |v: &[f64]| { let c = sh_eval(3, &coeffs, Vec3::from_slice(v)); c[0] * g[0] + c[1] * g[1] + c[2] * g[2] };
/// let (mut x, mut num) = (dir.to_array(), [0.0; 3]);
/// central_gradient(f, &mut x, &mut num);
/// assert!(GradCheck::new(1e-10, 1e-7).check(&d_dir.to_array(), &num).passed());
/// ```
pub fn sh_eval_vjp<T: Real>(
    degree: usize,
    coeffs: &[[T; 3]],
    dir: Vec3<T>,
    d_out: [T; 3],
    d_coeffs: &mut [[T; 3]],
) -> Vec3<T> {
    let k = sh_coeff_count(degree);
    assert!(
        coeffs.len() >= k && d_coeffs.len() >= k,
        "need {k} SH coefficients"
    );
    let mut basis = [T::ZERO; MAX_SH_COEFFS];
    let d = if degree == 0 {
        dir
    } else {
        normalize_vec3(dir)
    };
    sh_basis(degree, d, &mut basis);
    let mut w = [T::ZERO; MAX_SH_COEFFS];
    for j in 0..k {
        for ch in 0..3 {
            d_coeffs[j][ch] += basis[j] * d_out[ch];
        }
        w[j] = coeffs[j][0] * d_out[0] + coeffs[j][1] * d_out[1] + coeffs[j][2] * d_out[2];
    }
    if degree == 0 {
        return Vec3::zero();
    }
    normalize_vec3_vjp(dir, sh_basis_grad(degree, d, &w))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Dual;
    use crate::diff::{GradCheck, central_gradient, dual_jvp, vjp_dot_test};
    use alloc::vec;
    use alloc::vec::Vec;

    fn coeffs(n: usize) -> Vec<[f64; 3]> {
        let mut r = crate::rng::SplitMix64::new(4);
        (0..n)
            .map(|_| {
                [
                    r.uniform(-1.0, 1.0),
                    r.uniform(-1.0, 1.0),
                    r.uniform(-1.0, 1.0),
                ]
            })
            .collect()
    }

    #[test]
    fn vjps_match_fd_and_dual_for_each_degree() {
        let g = [0.5, -1.0, 0.25];
        for degree in 0..=3 {
            let k = sh_coeff_count(degree);
            let c = coeffs(k);
            for dir in [
                Vec3::new(0.3, -1.2, 2.0),
                Vec3::new(-4.0, 0.1, -0.2),
                Vec3::new(0.0, 0.0, 1.0),
            ] {
                let mut dc = vec![[0.0; 3]; k];
                let d_dir = sh_eval_vjp(degree, &c, dir, g, &mut dc);
                let f = |v: &[f64]| {
                    let o = sh_eval(degree, &c, Vec3::from_slice(v));
                    o[0] * g[0] + o[1] * g[1] + o[2] * g[2]
                };
                let (mut x, mut num) = (dir.to_array(), [0.0; 3]);
                central_gradient(f, &mut x, &mut num);
                GradCheck::new(1e-10, 1e-7)
                    .check(&d_dir.to_array(), &num)
                    .assert_passed("SH direction");
                // Coefficient gradient: exact, the basis times the cotangent.
                let mut flat: Vec<f64> = c.iter().flatten().copied().collect();
                let mut num = vec![0.0; 3 * k];
                let fc = |v: &[f64]| {
                    let cc: Vec<[f64; 3]> = v.chunks(3).map(|s| [s[0], s[1], s[2]]).collect();
                    let o = sh_eval(degree, &cc, dir);
                    o[0] * g[0] + o[1] * g[1] + o[2] * g[2]
                };
                central_gradient(fc, &mut flat, &mut num);
                let a: Vec<f64> = dc.iter().flatten().copied().collect();
                GradCheck::new(1e-10, 1e-8)
                    .check(&a, &num)
                    .assert_passed("SH coefficients");
                // Forward mode through the whole evaluation (direction and coefficients).
                let mut x0 = dir.to_array().to_vec();
                x0.extend(c.iter().flatten());
                let n_in = x0.len();
                let r = vjp_dot_test(
                    |v: &[f64], out: &mut [f64]| {
                        dual_jvp(
                            |x: &[Dual<f64>], y: &mut [Dual<f64>]| {
                                let cc: Vec<[Dual<f64>; 3]> =
                                    x[3..].chunks(3).map(|s| [s[0], s[1], s[2]]).collect();
                                y.copy_from_slice(&sh_eval(degree, &cc, Vec3::from_slice(x)));
                            },
                            &x0,
                            v,
                            out,
                        );
                    },
                    |w: &[f64], out: &mut [f64]| {
                        let mut dc = vec![[0.0; 3]; k];
                        let dd = sh_eval_vjp(degree, &c, dir, [w[0], w[1], w[2]], &mut dc);
                        dd.write_to(out);
                        for (o, v) in out[3..].iter_mut().zip(dc.iter().flatten()) {
                            *o = *v;
                        }
                    },
                    n_in,
                    3,
                    13,
                );
                assert!(r < 1e-13, "degree {degree} dot test {r}");
            }
        }
    }

    #[test]
    fn coefficient_counts_are_the_squares() {
        let counts: Vec<usize> = (0..=3).map(sh_coeff_count).collect();
        assert_eq!(counts, [1, 4, 9, 16]);
    }

    #[test]
    fn basis_has_the_signs_and_norms_of_the_closed_forms() {
        // The real spherical harmonics of 3D Gaussian splatting (Condon–Shortley phase
        // included), each written from its closed form, not from the constant tables: the
        // orthonormality test below cannot see a flipped sign.
        use core::f64::consts::PI;
        let closed = |d: Vec3<f64>| -> [f64; 16] {
            let (x, y, z) = (d.x, d.y, d.z);
            let c1 = (3.0 / (4.0 * PI)).sqrt();
            let (a, b) = ((15.0 / PI).sqrt(), (5.0 / PI).sqrt());
            let (e, f, g) = (
                (35.0 / (2.0 * PI)).sqrt(),
                (105.0 / PI).sqrt(),
                (21.0 / (2.0 * PI)).sqrt(),
            );
            let h = (7.0 / PI).sqrt();
            let (xx, yy, zz) = (x * x, y * y, z * z);
            [
                0.5 / PI.sqrt(),
                -c1 * y,
                c1 * z,
                -c1 * x,
                0.5 * a * x * y,
                -0.5 * a * y * z,
                0.25 * b * (2.0 * zz - xx - yy),
                -0.5 * a * x * z,
                0.25 * a * (xx - yy),
                -0.25 * e * y * (3.0 * xx - yy),
                0.5 * f * x * y * z,
                -0.25 * g * y * (4.0 * zz - xx - yy),
                0.25 * h * z * (2.0 * zz - 3.0 * xx - 3.0 * yy),
                -0.25 * g * x * (4.0 * zz - xx - yy),
                0.25 * f * z * (xx - yy),
                -0.25 * e * x * (xx - 3.0 * yy),
            ]
        };
        for raw in [
            [0.48, 0.6, 0.64],
            [-0.36, 0.48, -0.8],
            [0.6, -0.64, 0.48],
            [0.0, -0.6, 0.8],
        ] {
            let d = Vec3::new(raw[0], raw[1], raw[2]);
            let mut got = [0.0; MAX_SH_COEFFS];
            sh_basis(3, d, &mut got);
            for (k, (g, w)) in got.iter().zip(closed(d)).enumerate() {
                assert!(
                    (g - w).abs() <= 1e-14,
                    "Y_{k}({raw:?}) = {g}, closed form {w}"
                );
            }
        }
    }

    #[test]
    fn basis_is_orthonormal_on_the_sphere() {
        // Monte Carlo-free check: quadrature on a Fibonacci sphere of 20000 points.
        let n = 20_000;
        let mut gram = [[0.0; 16]; 16];
        let golden = core::f64::consts::PI * (3.0 - num_traits::Float::sqrt(5.0_f64));
        for i in 0..n {
            let z = 1.0 - 2.0 * (f64::from(i) + 0.5) / f64::from(n);
            let r = num_traits::Float::sqrt(1.0 - z * z);
            let (s, c) = num_traits::Float::sin_cos(golden * f64::from(i));
            let mut b = [0.0; 16];
            sh_basis(3, Vec3::new(r * c, r * s, z), &mut b);
            for a in 0..16 {
                for bb in 0..16 {
                    gram[a][bb] += b[a] * b[bb] * 4.0 * core::f64::consts::PI / f64::from(n);
                }
            }
        }
        for a in 0..16 {
            for bb in 0..16 {
                let want = if a == bb { 1.0 } else { 0.0 };
                assert!(
                    (gram[a][bb] - want).abs() < 2e-3,
                    "⟨Y{a}, Y{bb}⟩ = {}",
                    gram[a][bb]
                );
            }
        }
    }
}
