//! The evaluation cache of [`NeuralField`]: stored forward activations keyed by the exact
//! positions, time and parameter generation, reused by a VJP at the same input
//! (least-recently-used replacement), within a memory budget.

use super::NeuralField;
use crate::field::chunk::CHUNK;
use crate::field::chunk::{ChunkRecord, ChunkWork};
use crate::field::gemm::Gemm;

/// The default budget of the stored evaluations: 512 MiB (every stage of a `paper`-size RK4
/// frame of 16 evaluations at 20 000 Gaussians fits in it).
pub const EVAL_BUDGET_BYTES: usize = 512 << 20;

/// What a stored evaluation was computed for: exactly these positions, time and parameters.
#[derive(Debug, PartialEq)]
pub(super) struct EvalKey<T> {
    pub(super) t: T,
    pub(super) generation: u64,
    pub(super) positions: Vec<T>,
}

/// The activations of one batched evaluation, chunk by chunk, and its key.
#[derive(Debug)]
pub(super) struct Evaluation<T> {
    pub(super) chunks: Vec<ChunkRecord<T>>,
    pub(super) key: Option<EvalKey<T>>,
    pub(super) last_use: u64,
}

impl<T: Gemm> NeuralField<T> {
    /// How many evaluations to keep for later VJPs (at least 1). A VJP at exactly the
    /// positions, time and parameters of a stored evaluation reuses its activations instead
    /// of recomputing the forward pass; the discrete adjoint of an s-stage method over m
    /// steps evaluates its s·m stages and then takes their VJPs in reverse, so a capacity of
    /// s·m saves every recomputation. Fewer are kept when they would not fit the budget
    /// ([`set_eval_budget`](Self::set_eval_budget)).
    pub fn set_eval_capacity(&mut self, capacity: usize) {
        self.capacity = capacity.max(1);
        self.evals.truncate(self.capacity);
    }

    /// The bytes that the stored evaluations may take together (at least one evaluation is
    /// always kept). Each costs `N·(F + 4W + 9 + 3)` scalars for N Gaussians, F features and
    /// MLP width W: at the `paper` size (F = W = 64) and N = 20 000, 26 MB in f32.
    pub fn set_eval_budget(&mut self, bytes: usize) {
        self.eval_budget = bytes;
    }

    /// How many evaluations of `n` Gaussians are kept: the capacity, or fewer to fit the
    /// budget.
    pub(super) fn kept_evaluations(&self, n: usize) -> usize {
        self.capacity
            .min(self.eval_budget / self.evaluation_bytes(n).max(1))
            .max(1)
    }

    /// The bytes one stored evaluation of `n` Gaussians takes (its activations and key).
    #[must_use]
    pub fn evaluation_bytes(&self, n: usize) -> usize {
        let per_row = ChunkRecord::<T>::scalars_per_row(&self.hex, &self.mlp) + 3;
        n.div_ceil(CHUNK) * CHUNK * per_row * core::mem::size_of::<T>()
    }

    /// Grows the per-chunk scratch to `n_chunks` chunks.
    pub(super) fn ensure_work(&mut self, n_chunks: usize) {
        while self.work.len() < n_chunks {
            self.work.push(ChunkWork::new(&self.hex, &self.mlp));
        }
    }

    /// The index of a stored evaluation for exactly this input, if any.
    pub(super) fn find_eval(
        &self,
        t: T,
        positions: &[T],
        stride: usize,
        n: usize,
    ) -> Option<usize> {
        self.evals.iter().position(|e| {
            e.key.as_ref().is_some_and(|k| {
                k.generation == self.generation
                    && k.t == t
                    && k.positions.len() == 3 * n
                    && (0..n).all(|i| {
                        k.positions[3 * i..3 * i + 3] == positions[i * stride..i * stride + 3]
                    })
            })
        })
    }

    /// A slot for a new evaluation of `n` Gaussians (the least recently used one), sized and
    /// keyed for this input.
    pub(super) fn claim_eval(&mut self, t: T, positions: &[T], stride: usize, n: usize) -> usize {
        let kept = self.kept_evaluations(n);
        self.evals.truncate(kept);
        let slot = if self.evals.len() < kept {
            self.evals.push(Evaluation {
                chunks: Vec::new(),
                key: None,
                last_use: 0,
            });
            self.evals.len() - 1
        } else {
            (0..self.evals.len())
                .min_by_key(|&i| self.evals[i].last_use)
                .unwrap_or(0)
        };
        let n_chunks = n.div_ceil(CHUNK);
        let e = &mut self.evals[slot];
        while e.chunks.len() < n_chunks {
            e.chunks.push(ChunkRecord::new(&self.hex, &self.mlp));
        }
        let mut key = e.key.take().unwrap_or(EvalKey {
            t,
            generation: 0,
            positions: Vec::new(),
        });
        key.t = t;
        key.generation = self.generation;
        key.positions.clear();
        key.positions
            .extend((0..n).flat_map(|i| positions[i * stride..i * stride + 3].iter().copied()));
        e.key = Some(key);
        slot
    }

    pub(super) fn touch(&mut self, slot: usize) {
        self.clock += 1;
        self.evals[slot].last_use = self.clock;
    }
}
