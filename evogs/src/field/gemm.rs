//! [`Gemm`]: the scalar types with a real matrix-multiply kernel.
//!
//! The batched layers of the neural field multiply strided views of our own buffers. For
//! `f32`/`f64`, products whose operands each have one contiguous direction (every product
//! of the MLP) go to faer's `matmul` (sequential; its kernels are chosen at run time for
//! the CPU: AVX-512, AVX2/FMA, NEON or scalar). faer replaced matrixmultiply (through
//! nalgebra) here because it multiplies row-major operands without repacking them:
//! matrixmultiply packs the left operand by columns, which for the row-major activations is
//! a strided gather before every product (`docs/performance.md` has the measurements). This
//! keeps `unsafe` out of evogs (it lives in faer).
//!
//! That includes the thin products of the 3-wide output heads: faer's small-matrix kernels
//! took them 5–8 % of an iteration faster than the plain loops this file had for them.
//! An operand without a contiguous direction (which the field never passes) goes to a plain
//! loop here.
//!
//! The neural field is written once, generic over `T: Gemm`: f32 for training, f64 for the
//! gradient checks. Matrices are (slice, row stride, column stride), so a transposed operand is
//! just swapped strides.

use super::heads::{self, HeadsVjp};
use super::lanes::{LANES, coord_grad_f32x8, coord_grad_sums};
use evogs_math::Real;
use faer::{Accum, MatMut, MatRef as FaerRef, Par};

/// A strided matrix operand: `(data, rows, cols, row_stride, col_stride)`; entry (i, j) is
/// `data[i·row_stride + j·col_stride]`.
pub type MatRef<'a, T> = (&'a [T], usize, usize, usize, usize);

/// A scalar with a general matrix-multiply kernel, `C ← α·A·B + β·C`, and its choice of
/// the lane-parallel channel kernel of the HexPlane VJP (`field::lanes`).
pub trait Gemm: Real {
    /// The coordinate-gradient partial sums of one bilinear sample over whole blocks of
    /// `LANES` = 8 channels (`g.len()` a multiple of 8, each corner slice as long): what
    /// `lanes::coord_grad_sums` adds, in the same operations and order per lane, so the
    /// result is bitwise the same; a type may do it in vector registers.
    #[inline]
    fn coord_grad_lanes(
        g: &[Self],
        corners: [&[Self]; 4],
        fx: Self,
        fy: Self,
        acc: &mut ([Self; LANES], [Self; LANES]),
    ) {
        coord_grad_sums(g, corners, fx, fy, acc);
    }

    /// The heads' backward for columns `j0..j0 + LANES` of head `h` (`field::heads`): what
    /// `heads::block` computes, in the same operations and order per lane, so the result
    /// is bitwise the same; a type may do it in vector registers.
    #[inline]
    fn heads_vjp_lanes(v: &mut HeadsVjp<'_, Self>, h: usize, j0: usize) {
        heads::block::<Self, LANES>(v, h, j0);
    }

    /// `C ← alpha·A·B + beta·C` with `A` m×k, `B` k×n and `C` m×n given as strided views.
    ///
    /// # Panics
    /// If the shapes do not agree or a slice is too short for its shape and strides.
    fn gemm(
        alpha: Self,
        a: MatRef<'_, Self>,
        b: MatRef<'_, Self>,
        beta: Self,
        c: (&mut [Self], usize, usize, usize, usize),
    );
}

/// A faer view of a strided operand with one contiguous direction (`None` otherwise).
fn faer_view<T: faer::traits::ComplexField>(
    (d, m, n, rs, cs): MatRef<'_, T>,
) -> Option<FaerRef<'_, T>> {
    if cs == 1 {
        Some(FaerRef::from_row_major_slice_with_stride(d, m, n, rs))
    } else if rs == 1 {
        Some(FaerRef::from_column_major_slice_with_stride(d, m, n, cs))
    } else {
        None
    }
}

/// The one implementation behind both scalar types.
fn gemm_impl<T: Real + faer::traits::ComplexField>(
    alpha: T,
    a: MatRef<'_, T>,
    b: MatRef<'_, T>,
    beta: T,
    c: (&mut [T], usize, usize, usize, usize),
) {
    let (ad, am, ak, ars, acs) = a;
    let (bd, bk, bn, brs, bcs) = b;
    let (cd, cm, cn, crs, ccs) = c;
    assert!(
        am == cm && bn == cn && ak == bk,
        "gemm: shapes {am}x{ak} · {bk}x{bn} -> {cm}x{cn}"
    );
    if cm == 0 || cn == 0 {
        return;
    }
    let c_contiguous = ccs == 1 || crs == 1;
    if let (true, Some(av), Some(bv)) = (c_contiguous, faer_view(a), faer_view(b)) {
        // faer adds into C (or replaces it) but does not scale it: β·C first.
        let accum = if beta == <T as Real>::ZERO {
            Accum::Replace
        } else {
            if beta != <T as Real>::ONE {
                scale(beta, (&mut *cd, cm, cn, crs, ccs));
            }
            Accum::Add
        };
        let cv = if ccs == 1 {
            // The transpose of a column-major view, as faer's `MatRef` builds row-major
            // views: faer 0.23.2's `MatMut::from_row_major_slice_with_stride_mut` swaps the
            // two strides (it builds a column-major view), which the strided-product test
            // below caught.
            MatMut::from_column_major_slice_with_stride_mut(cd, cn, cm, crs).transpose_mut()
        } else {
            MatMut::from_column_major_slice_with_stride_mut(cd, cm, cn, ccs)
        };
        faer::linalg::matmul::matmul(cv, accum, av, bv, alpha, Par::Seq);
        return;
    }
    strided_gemm(
        alpha,
        (ad, ars, acs),
        (bd, brs, bcs),
        beta,
        (cd, crs, ccs),
        (cm, ak, cn),
    );
}

/// `C ← β·C` on a strided view.
fn scale<T: Real>(beta: T, (cd, cm, cn, crs, ccs): (&mut [T], usize, usize, usize, usize)) {
    for i in 0..cm {
        for j in 0..cn {
            cd[i * crs + j * ccs] *= beta;
        }
    }
}

/// `C ← α·A·B + β·C` for operands without a contiguous direction, with the loop order
/// chosen for contiguous inner loops (which the compiler vectorises): row-axpy when the rows of B and C are contiguous, dot
/// products (lane-parallel, [`super::lanes::dot`]) when the rows of A and the columns of B
/// are, a plain triple loop otherwise.
fn strided_gemm<T: Real>(
    alpha: T,
    a: (&[T], usize, usize),
    b: (&[T], usize, usize),
    beta: T,
    c: (&mut [T], usize, usize),
    (m, k, n): (usize, usize, usize),
) {
    let (ad, ars, acs) = a;
    let (bd, brs, bcs) = b;
    let (cd, crs, ccs) = c;
    let zero = <T as Real>::ZERO;
    if ccs == 1 && bcs == 1 {
        for i in 0..m {
            let row = &mut cd[i * crs..i * crs + n];
            if beta == zero {
                row.fill(zero);
            } else if beta != <T as Real>::ONE {
                for v in row.iter_mut() {
                    *v *= beta;
                }
            }
            for l in 0..k {
                let s = alpha * ad[i * ars + l * acs];
                let br = &bd[l * brs..l * brs + n];
                for (v, &bv) in row.iter_mut().zip(br) {
                    *v += s * bv;
                }
            }
        }
        return;
    }
    for i in 0..m {
        for j in 0..n {
            let s = if acs == 1 && brs == 1 {
                let ar = &ad[i * ars..i * ars + k];
                let bc = &bd[j * bcs..j * bcs + k];
                super::lanes::dot(ar, bc)
            } else {
                let mut s = zero;
                for l in 0..k {
                    s += ad[i * ars + l * acs] * bd[l * brs + j * bcs];
                }
                s
            };
            let c = &mut cd[i * crs + j * ccs];
            *c = if beta == zero {
                alpha * s
            } else {
                alpha * s + beta * *c
            };
        }
    }
}

impl Gemm for f32 {
    /// Explicit 8-lane vectors (`lanes::coord_grad_f32x8`).
    #[inline]
    fn coord_grad_lanes(
        g: &[Self],
        corners: [&[Self]; 4],
        fx: Self,
        fy: Self,
        acc: &mut ([Self; LANES], [Self; LANES]),
    ) {
        coord_grad_f32x8(g, corners, fx, fy, acc);
    }

    /// Explicit 8-lane vectors (`heads::block_f32x8`).
    #[inline]
    fn heads_vjp_lanes(v: &mut HeadsVjp<'_, Self>, h: usize, j0: usize) {
        heads::block_f32x8(v, h, j0);
    }

    fn gemm(
        alpha: Self,
        a: MatRef<'_, Self>,
        b: MatRef<'_, Self>,
        beta: Self,
        c: (&mut [Self], usize, usize, usize, usize),
    ) {
        gemm_impl(alpha, a, b, beta, c);
    }
}

impl Gemm for f64 {
    fn gemm(
        alpha: Self,
        a: MatRef<'_, Self>,
        b: MatRef<'_, Self>,
        beta: Self,
        c: (&mut [Self], usize, usize, usize, usize),
    ) {
        gemm_impl(alpha, a, b, beta, c);
    }
}

/// A row-major `rows × cols` operand.
#[must_use]
pub const fn row_major<T>(data: &[T], rows: usize, cols: usize) -> MatRef<'_, T> {
    (data, rows, cols, cols, 1)
}

/// The transpose of a row-major `rows × cols` matrix, as a `cols × rows` operand.
#[must_use]
pub const fn transposed<T>(data: &[T], rows: usize, cols: usize) -> MatRef<'_, T> {
    (data, cols, rows, 1, cols)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strided_products_match_naive_loops() {
        // Every operand contiguous in one direction: faer's path.
        let (m, k, n) = (9, 7, 8);
        let a: Vec<f64> = (0..m * k)
            .map(|i| f64::from(u32::try_from(i).expect("small")) * 0.1 - 2.0)
            .collect();
        let b: Vec<f64> = (0..k * n)
            .map(|i| (f64::from(u32::try_from(i).expect("small")) * 0.37).sin())
            .collect();
        let mut c = vec![1.0; m * n];
        f64::gemm(
            2.0,
            row_major(&a, m, k),
            row_major(&b, k, n),
            0.5,
            (&mut c, m, n, n, 1),
        );
        for i in 0..m {
            for j in 0..n {
                let s: f64 = (0..k).map(|l| a[i * k + l] * b[l * n + j]).sum();
                assert!(
                    (c[i * n + j] - (2.0 * s + 0.5)).abs() < 1e-12,
                    "entry ({i}, {j})"
                );
            }
        }
        // Aᵀ·A through swapped strides, and a thin (3-column) product.
        let mut g = vec![0.0; k * k];
        f64::gemm(
            1.0,
            transposed(&a, m, k),
            row_major(&a, m, k),
            0.0,
            (&mut g, k, k, k, 1),
        );
        let s: f64 = (0..m).map(|l| a[l * k + 2] * a[l * k + 5]).sum();
        assert!((g[2 * k + 5] - s).abs() < 1e-12, "AᵀA entry");
        let mut t = vec![0.0; m * 3];
        f64::gemm(
            1.0,
            row_major(&a, m, k),
            (&b, k, 3, n, 1),
            0.0,
            (&mut t, m, 3, 3, 1),
        );
        let s: f64 = (0..k).map(|l| a[4 * k + l] * b[l * n + 1]).sum();
        assert!((t[4 * 3 + 1] - s).abs() < 1e-12, "thin product");
    }

    /// The output view in every layout the field could hand over: row-major with padded rows
    /// (a stride above the column count), column-major with padded columns, and a view with no
    /// contiguous direction (the loop fallback); entries outside the view stay untouched.
    #[test]
    fn padded_and_column_major_outputs_match_naive_loops() {
        let (m, k, n) = (9, 7, 8);
        let a: Vec<f64> = (0..m * k)
            .map(|i| (f64::from(u32::try_from(i).expect("small")) * 0.29).cos())
            .collect();
        let b: Vec<f64> = (0..k * n)
            .map(|i| (f64::from(u32::try_from(i).expect("small")) * 0.37).sin())
            .collect();
        let want = |i: usize, j: usize| -> f64 {
            let s: f64 = (0..k).map(|l| a[i * k + l] * b[l * n + j]).sum();
            1.5 * s - 0.25 * f64::from(u32::try_from(i * 100 + j).expect("small"))
        };
        // (row stride, column stride, buffer length) of C.
        for (crs, ccs, len) in [
            (n + 3, 1, m * (n + 3)),
            (1, m + 2, n * (m + 2)),
            (2 * n, 2, 2 * m * n),
        ] {
            let mut c = vec![7.0; len];
            for i in 0..m {
                for j in 0..n {
                    c[i * crs + j * ccs] = f64::from(u32::try_from(i * 100 + j).expect("small"));
                }
            }
            f64::gemm(
                1.5,
                row_major(&a, m, k),
                row_major(&b, k, n),
                -0.25,
                (&mut c, m, n, crs, ccs),
            );
            let mut inside = vec![false; len];
            for i in 0..m {
                for j in 0..n {
                    let got = c[i * crs + j * ccs];
                    assert!(
                        (got - want(i, j)).abs() < 1e-12,
                        "strides ({crs}, {ccs}) entry ({i}, {j}): {got}"
                    );
                    inside[i * crs + j * ccs] = true;
                }
            }
            for (v, _) in c.iter().zip(&inside).filter(|(_, inside)| !**inside) {
                assert!(
                    v.to_bits() == 7.0f64.to_bits(),
                    "strides ({crs}, {ccs}): padding written"
                );
            }
        }
    }
}
