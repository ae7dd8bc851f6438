//! The evaluation cache of [`NeuralField`]: stored forward activations keyed by the exact
//! positions, time and parameter generation, reused by a VJP at the same input
//! (least-recently-used replacement).

use super::NeuralField;
use crate::field::chunk::CHUNK;
use crate::field::chunk::ChunkScratch;
use crate::field::gemm::Gemm;

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
    pub(super) chunks: Vec<ChunkScratch<T>>,
    pub(super) key: Option<EvalKey<T>>,
    pub(super) last_use: u64,
}

impl<T: Gemm> NeuralField<T> {
    /// How many evaluations to keep for later VJPs (at least 1). A VJP at exactly the
    /// positions, time and parameters of a stored evaluation reuses its activations instead
    /// of recomputing the forward pass; the discrete adjoint of an s-stage method evaluates
    /// its s stages and then takes their VJPs, so a capacity of s saves every recomputation.
    /// Each stored evaluation costs about `N·(12·C + 8·W)` scalars.
    pub fn set_eval_capacity(&mut self, capacity: usize) {
        self.capacity = capacity.max(1);
        self.evals.truncate(self.capacity);
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
        let slot = if self.evals.len() < self.capacity {
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
            e.chunks.push(ChunkScratch::new(&self.hex, &self.mlp));
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
