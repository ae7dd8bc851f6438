//! [`FieldRecord`]: what one batched evaluation of [`NeuralField`] keeps for its VJP, and
//! the memory budget of the records a caller keeps.

use super::{NeuralField, gaussian_layout};
use crate::field::chunk::{CHUNK, ChunkRecord, ChunkWork};
use crate::field::gemm::Gemm;
use crate::field::hexplane::HexPlane;
use crate::field::mlp::Mlp;
use evogs_ode::StageTape;
use std::sync::Mutex;

/// The default budget of the records kept for the VJPs: 512 MiB (every stage of a
/// `paper`-size RK4 frame of 16 evaluations at 20 000 Gaussians fits in it).
pub const EVAL_BUDGET_BYTES: usize = 512 << 20;

/// The forward pass of one batched evaluation, chunk by chunk (features and MLP
/// activations), for the VJP at the same input: written by
/// [`NeuralField::eval_batch`] (or [`VectorField::eval_recorded`](evogs_ode::VectorField))
/// and read by [`NeuralField::vjp_batch`]. It remembers the time, the batch size and the
/// parameter generation it was written at; the VJP refuses it otherwise. Its buffers are
/// reused when it is written again.
#[derive(Debug)]
pub struct FieldRecord<T> {
    chunks: Vec<ChunkRecord<T>>,
    /// `(t, n, parameter generation)` of the evaluation that wrote it; `None` when empty.
    written: Option<(T, usize, u64)>,
}

impl<T> Default for FieldRecord<T> {
    fn default() -> Self {
        Self {
            chunks: Vec::new(),
            written: None,
        }
    }
}

impl<T: Gemm> FieldRecord<T> {
    /// Sizes the record for `n` rows and marks it as written at `(t, n, generation)`.
    pub(super) fn prepare(&mut self, hex: &HexPlane, mlp: &Mlp, t: T, n: usize, generation: u64) {
        let n_chunks = n.div_ceil(CHUNK);
        while self.chunks.len() < n_chunks {
            self.chunks.push(ChunkRecord::new(hex, mlp));
        }
        self.written = Some((t, n, generation));
    }

    /// The first `n_chunks` chunk records, to write.
    pub(super) fn chunks_mut(&mut self, n_chunks: usize) -> &mut [ChunkRecord<T>] {
        &mut self.chunks[..n_chunks]
    }

    /// The first `n_chunks` chunk records.
    pub(super) fn chunks(&self, n_chunks: usize) -> &[ChunkRecord<T>] {
        &self.chunks[..n_chunks]
    }

    /// Panics unless the record was written by an evaluation of `n` positions at `t` with
    /// the parameters of `generation`.
    pub(super) fn check(&self, t: T, n: usize, generation: u64) {
        assert!(
            self.written == Some((t, n, generation)),
            "the field record was not written by this evaluation (or the parameters changed \
             since)"
        );
    }
}

impl<T: Gemm> NeuralField<T> {
    /// The bytes that the records kept for later VJPs may take together (a
    /// [`StageTape`] keeps the records of the last ODE steps that fit,
    /// [`records_within_budget`](Self::records_within_budget), and the adjoint evaluates
    /// the earlier steps again). Each costs [`evaluation_bytes`](Self::evaluation_bytes):
    /// at the `paper` size (F = W = 64) and N = 20 000, 30 MB in f32.
    pub fn set_eval_budget(&mut self, bytes: usize) {
        self.eval_budget = bytes;
    }

    /// How many evaluations of `n` Gaussians fit the budget
    /// ([`set_eval_budget`](Self::set_eval_budget)).
    #[must_use]
    pub fn records_within_budget(&self, n: usize) -> usize {
        self.eval_budget / self.evaluation_bytes(n).max(1)
    }

    /// The bytes one kept evaluation of `n` Gaussians takes: its record,
    /// `N·(F + 4W + 9)` scalars for F features and MLP width W (rounded up to whole chunks),
    /// and what the stage tape keeps beside it ([`StageTape::scalars_per_stage`] of the
    /// Gaussian layout: the stage's value, slope and increment, 9 each, and its state, 10).
    #[must_use]
    pub fn evaluation_bytes(&self, n: usize) -> usize {
        let record = ChunkRecord::<T>::scalars_per_row(&self.hex, &self.mlp);
        let tape = StageTape::<T, FieldRecord<T>>::scalars_per_stage(&gaussian_layout(n));
        (n.div_ceil(CHUNK) * CHUNK * record + tape) * core::mem::size_of::<T>()
    }

    /// Grows the VJP's scratch to one per thread of `threads`.
    pub(super) fn ensure_work(&mut self, threads: usize) {
        while self.work.len() < threads {
            self.work
                .push(Mutex::new(ChunkWork::new(&self.hex, &self.mlp)));
        }
    }
}
