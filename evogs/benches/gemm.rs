//! The matrix products of one chunk of the paper-size MLP (F = W = 64, [`CHUNK`] rows)
//! through [`Gemm::gemm`], each with the shapes, strides and β that `field::mlp` passes:
//! the two forward products and the heads' three thin ones (only the first is timed: the
//! other two are the same shape), then the backward's weight and input gradients (the
//! backward of the heads' thin output layers is not a matrix product there: a fused kernel
//! does it with the rectifiers, `field/heads.rs`). The
//! rate of each product against the machine's FMA peak (`tools/fma-peak`) is what
//! `docs/performance.md` reports for the field's GEMMs.
//!
//! ```sh
//! cargo bench -p evogs --bench gemm
//! ```

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use evogs::field::CHUNK;
use evogs::field::gemm::{Gemm, MatRef, row_major, transposed};
use std::hint::black_box;

/// Rows of a chunk.
const R: usize = CHUNK;
/// Width and feature dimension of the paper-size MLP.
const W: usize = 64;
/// The MLP's outputs per row (three heads of three).
const OUT: usize = 9;

/// An operand: `rows × cols` with the given row and column strides over a buffer.
#[derive(Clone, Copy)]
struct Layout {
    rows: usize,
    cols: usize,
    rs: usize,
    cs: usize,
}

impl Layout {
    const fn rows(rows: usize, cols: usize) -> Self {
        Self {
            rows,
            cols,
            rs: cols,
            cs: 1,
        }
    }

    /// The buffer length the layout reads.
    const fn span(self) -> usize {
        (self.rows - 1) * self.rs + (self.cols - 1) * self.cs + 1
    }

    fn of(self, data: &[f32]) -> MatRef<'_, f32> {
        (data, self.rows, self.cols, self.rs, self.cs)
    }
}

/// One product `C ← A·B + β·C` as `field::mlp` calls it.
struct Case {
    name: &'static str,
    a: Layout,
    b: Layout,
    c: Layout,
    beta: f32,
}

/// `transposed(data, rows, cols)`: the transpose of a row-major `rows × cols` matrix.
const fn transposed_of(rows: usize, cols: usize) -> Layout {
    Layout {
        rows: cols,
        cols: rows,
        rs: 1,
        cs: cols,
    }
}

fn cases() -> [Case; 7] {
    let row = Layout::rows;
    [
        Case {
            name: "forward trunk, R x F . F x W",
            a: row(R, W),
            b: transposed_of(W, W),
            c: row(R, W),
            beta: 0.0,
        },
        Case {
            name: "forward heads, R x W . W x 3W",
            a: row(R, W),
            b: transposed_of(3 * W, W),
            c: row(R, 3 * W),
            beta: 0.0,
        },
        Case {
            name: "forward head out (thin), R x W . W x 3",
            a: Layout {
                rows: R,
                cols: W,
                rs: 3 * W,
                cs: 1,
            },
            b: transposed_of(3, W),
            c: Layout {
                rows: R,
                cols: 3,
                rs: OUT,
                cs: 1,
            },
            beta: 1.0,
        },
        Case {
            name: "backward dW1, 3W x R . R x W",
            a: transposed_of(R, 3 * W),
            b: row(R, W),
            c: row(3 * W, W),
            beta: 1.0,
        },
        Case {
            name: "backward d_trunk, R x 3W . 3W x W",
            a: row(R, 3 * W),
            b: row(3 * W, W),
            c: row(R, W),
            beta: 0.0,
        },
        Case {
            name: "backward dW0, W x R . R x F",
            a: transposed_of(R, W),
            b: row(R, W),
            c: row(W, W),
            beta: 1.0,
        },
        Case {
            name: "backward d_features, R x W . W x F",
            a: row(R, W),
            b: row(W, W),
            c: row(R, W),
            beta: 0.0,
        },
    ]
}

fn bench(c: &mut Criterion) {
    // The layouts above are the ones `field::mlp` builds with these helpers.
    let shape = |m: MatRef<'_, f32>| (m.1, m.2, m.3, m.4);
    let buf = [0.0_f32; 3 * W];
    let t = transposed_of(3, W);
    assert_eq!(
        shape(transposed(&buf, 3, W)),
        (t.rows, t.cols, t.rs, t.cs),
        "transposed"
    );
    let r = Layout::rows(3, W);
    assert_eq!(
        shape(row_major(&buf, 3, W)),
        (r.rows, r.cols, r.rs, r.cs),
        "row-major"
    );
    let mut g = c.benchmark_group("mlp_gemm");
    for case in &cases() {
        let Case {
            name,
            a,
            b,
            c: out,
            beta,
        } = *case;
        assert!(
            a.cols == b.rows && a.rows == out.rows && b.cols == out.cols,
            "{name}"
        );
        #[allow(clippy::cast_precision_loss, reason = "bench inputs")]
        let fill = |n: usize, p: usize| -> Vec<f32> {
            (0..n).map(|i| ((i * p) % 1000) as f32 * 1e-3).collect()
        };
        let (da, db) = (fill(a.span(), 7919), fill(b.span(), 104_729));
        let mut dc = vec![0.0_f32; out.span()];
        g.throughput(Throughput::Elements((2 * a.rows * a.cols * b.cols) as u64));
        g.bench_function(name, |bencher| {
            bencher.iter(|| {
                f32::gemm(
                    1.0,
                    a.of(black_box(&da)),
                    b.of(black_box(&db)),
                    beta,
                    (&mut dc, out.rows, out.cols, out.rs, out.cs),
                );
            });
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
