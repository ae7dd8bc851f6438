//! The matrix exponential and its Fréchet derivative in f64, for the exact solutions of the
//! linear-ODE reference files (which used `scipy.linalg.expm` and `expm_frechet`).
//!
//! ```text
//! expm(X):  choose s with ‖X‖₁/2ˢ ≤ 1/4, Taylor polynomial of degree 20 of X/2ˢ
//!           (remainder < 4⁻²¹/21! ≈ 5e-33 relative), then square s times
//! L(X, E):  Van Loan's block identity  expm([[X, E], [0, X]]) = [[e^X, L(X, E)], [0, e^X]]
//! ```
//!
//! Matrices are `n × n`, row-major, in flat slices.

/// `a·b` for `n × n` matrices.
fn mul(n: usize, a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut c = vec![0.0; n * n];
    for i in 0..n {
        for k in 0..n {
            let aik = a[i * n + k];
            for j in 0..n {
                c[i * n + j] += aik * b[k * n + j];
            }
        }
    }
    c
}

/// The 1-norm (largest absolute column sum).
fn norm1(n: usize, a: &[f64]) -> f64 {
    (0..n)
        .map(|j| (0..n).map(|i| a[i * n + j].abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

const DEGREE: u32 = 20;

/// `e^X` of an `n × n` matrix.
///
/// # Panics
/// If `x.len() != n²` or `X` is not finite.
#[must_use]
pub fn expm(n: usize, x: &[f64]) -> Vec<f64> {
    assert_eq!(x.len(), n * n, "expm needs an n×n matrix");
    assert!(
        x.iter().all(|v| v.is_finite()),
        "expm of a non-finite matrix"
    );
    let nrm = norm1(n, x);
    let mut s = 0_i32;
    while nrm * 0.5_f64.powi(s) > 0.25 {
        s += 1;
    }
    let scale = 0.5_f64.powi(s);
    let y: Vec<f64> = x.iter().map(|v| v * scale).collect();
    // Horner: I + Y(I + Y/2(I + Y/3(… (I + Y/20)))).
    let mut p = vec![0.0; n * n];
    for i in 0..n {
        p[i * n + i] = 1.0;
    }
    for k in (1..=DEGREE).rev() {
        let mut q = mul(n, &y, &p);
        for v in &mut q {
            *v /= f64::from(k);
        }
        for i in 0..n {
            q[i * n + i] += 1.0;
        }
        p = q;
    }
    for _ in 0..s {
        p = mul(n, &p, &p);
    }
    p
}

/// The Fréchet derivative `L(X, E) = d/dε e^{X + εE}` at ε = 0.
///
/// # Panics
/// If the lengths are not `n²`.
#[must_use]
pub fn expm_frechet(n: usize, x: &[f64], e: &[f64]) -> Vec<f64> {
    assert!(
        x.len() == n * n && e.len() == n * n,
        "expm_frechet needs n×n matrices"
    );
    let m = 2 * n;
    let mut big = vec![0.0; m * m];
    for i in 0..n {
        for j in 0..n {
            big[i * m + j] = x[i * n + j];
            big[(i + n) * m + j + n] = x[i * n + j];
            big[i * m + j + n] = e[i * n + j];
        }
    }
    let eb = expm(m, &big);
    let mut l = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            l[i * n + j] = eb[i * m + j + n];
        }
    }
    l
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_generator_exponentiates_to_a_rotation() {
        let th = 2.3_f64;
        let e = expm(2, &[0.0, -th, th, 0.0]);
        let want = [th.cos(), -th.sin(), th.sin(), th.cos()];
        for (a, b) in e.iter().zip(want) {
            assert!((a - b).abs() < 1e-14, "expm of a rotation generator: {e:?}");
        }
    }

    #[test]
    fn frechet_derivative_matches_central_differences() {
        let x = [0.3, -1.2, 0.5, 0.7, 0.1, -0.4, -0.6, 0.9, 0.2];
        let e = [0.5, 0.1, -0.3, 0.2, -0.7, 0.4, 0.0, 0.6, -0.1];
        let l = expm_frechet(3, &x, &e);
        let h = 1e-5;
        let shifted = |s: f64| -> Vec<f64> {
            let xs: Vec<f64> = x.iter().zip(&e).map(|(a, b)| a + s * b).collect();
            expm(3, &xs)
        };
        let (p, m) = (shifted(h), shifted(-h));
        for k in 0..9 {
            let num = (p[k] - m[k]) / (2.0 * h);
            assert!((num - l[k]).abs() < 1e-9, "entry {k}: {num} vs {}", l[k]);
        }
    }
}
