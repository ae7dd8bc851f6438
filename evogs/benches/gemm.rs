//! The matrix products of the paper-size MLP (F = W = 64, a chunk of 256 rows) through
//! [`Gemm::gemm`], each in the layout `field::mlp` uses and, for the products whose large
//! operand is a row-major activation, with that operand column-major instead.
//!
//! matrixmultiply packs both operands into panels before its kernel runs. An `A` whose
//! columns are contiguous and a `B` whose rows are contiguous pack by contiguous copies; a
//! row-major activation as `A` packs by strided gathers, which on the development machine
//! takes as long as the multiply itself (`docs/performance.md`). The weight gradients
//! (`dW1`, `dW0`) read the activations transposed, which packs contiguously; the forward
//! and input-gradient products (`trunk`, `heads`, `d_trunk`, `d_features`) do not.
//!
//! ```sh
//! cargo bench -p evogs --bench gemm
//! ```

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use evogs::field::gemm::{Gemm, MatRef, row_major, transposed};
use std::hint::black_box;

/// Rows of a chunk, as in `field::chunk::CHUNK`.
const R: usize = 256;
/// Width and feature dimension of the paper-size MLP.
const W: usize = 64;

/// One product: its name, the shapes (m, k, n), and whether `A` is stored row-major
/// (`false`: column-major) and `B` row-major.
struct Case {
    name: &'static str,
    m: usize,
    k: usize,
    n: usize,
    a_rows: bool,
    b_rows: bool,
}

fn operand(data: &[f32], rows: usize, cols: usize, row_major_storage: bool) -> MatRef<'_, f32> {
    if row_major_storage {
        row_major(data, rows, cols)
    } else {
        transposed(data, cols, rows)
    }
}

fn bench(c: &mut Criterion) {
    let cases = [
        // As `Mlp::forward` and `Mlp::backward` call them (weights stored `[out][in]`).
        Case {
            name: "trunk/as used",
            m: R,
            k: W,
            n: W,
            a_rows: true,
            b_rows: false,
        },
        Case {
            name: "heads/as used",
            m: R,
            k: W,
            n: 3 * W,
            a_rows: true,
            b_rows: false,
        },
        Case {
            name: "dW1/as used",
            m: 3 * W,
            k: R,
            n: W,
            a_rows: false,
            b_rows: true,
        },
        Case {
            name: "d_trunk/as used",
            m: R,
            k: 3 * W,
            n: W,
            a_rows: true,
            b_rows: true,
        },
        Case {
            name: "dW0/as used",
            m: W,
            k: R,
            n: W,
            a_rows: false,
            b_rows: true,
        },
        Case {
            name: "d_features/as used",
            m: R,
            k: W,
            n: W,
            a_rows: true,
            b_rows: true,
        },
        // The same shapes with the activation column-major.
        Case {
            name: "trunk/A by columns",
            m: R,
            k: W,
            n: W,
            a_rows: false,
            b_rows: false,
        },
        Case {
            name: "heads/A by columns",
            m: R,
            k: W,
            n: 3 * W,
            a_rows: false,
            b_rows: false,
        },
        Case {
            name: "d_trunk/A by columns",
            m: R,
            k: 3 * W,
            n: W,
            a_rows: false,
            b_rows: true,
        },
        Case {
            name: "d_features/A by columns",
            m: R,
            k: W,
            n: W,
            a_rows: false,
            b_rows: true,
        },
    ];
    let mut g = c.benchmark_group("mlp_gemm");
    for case in &cases {
        let Case {
            name,
            m,
            k,
            n,
            a_rows,
            b_rows,
        } = *case;
        #[allow(clippy::cast_precision_loss, reason = "bench inputs")]
        let a: Vec<f32> = (0..m * k)
            .map(|i| ((i * 7919) % 1000) as f32 * 1e-3)
            .collect();
        #[allow(clippy::cast_precision_loss, reason = "bench inputs")]
        let b: Vec<f32> = (0..k * n)
            .map(|i| ((i * 104_729) % 1000) as f32 * 1e-3)
            .collect();
        let mut out = vec![0.0_f32; m * n];
        g.throughput(Throughput::Elements((2 * m * k * n) as u64));
        g.bench_function(name, |bencher| {
            bencher.iter(|| {
                f32::gemm(
                    1.0,
                    operand(black_box(&a), m, k, a_rows),
                    operand(black_box(&b), k, n, b_rows),
                    1.0,
                    (&mut out, m, n, n, 1),
                );
            });
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
