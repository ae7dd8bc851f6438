//! The run's model evaluated at requested times, with the encoded frames of the most
//! recent times kept (a playing page asks for the same times again on every loop).

use super::wire::encode_frame;
use evogs::model::Model;
use evogs_splat::Splats;
use std::collections::VecDeque;

/// Frames kept by default (40 bytes per Gaussian each: 64 frames of 100 000 Gaussians are
/// 256 MB).
pub const DEFAULT_CACHE_FRAMES: usize = 64;

/// Computes frames with the run's own model ([`Model::splats_at`], what `evogs render` and
/// `evogs export` use) and keeps the last `capacity` of them, least recently used first out.
pub struct FrameSource {
    model: Model<f32>,
    scratch: Splats<f32>,
    cache: VecDeque<(u64, Vec<u8>)>,
    capacity: usize,
    computed: usize,
}

impl std::fmt::Debug for FrameSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FrameSource")
            .field("gaussians", &self.model.len())
            .field("cached", &self.cache.len())
            .field("capacity", &self.capacity)
            .field("computed", &self.computed)
            .finish_non_exhaustive()
    }
}

impl FrameSource {
    /// A source over `model` keeping `capacity` frames (at least one).
    #[must_use]
    pub fn new(model: Model<f32>, capacity: usize) -> Self {
        Self {
            model,
            scratch: Splats::default(),
            cache: VecDeque::new(),
            capacity: capacity.max(1),
            computed: 0,
        }
    }

    /// The model.
    #[must_use]
    pub const fn model(&self) -> &Model<f32> {
        &self.model
    }

    /// How many frames were computed rather than taken from the cache.
    #[must_use]
    pub const fn computed(&self) -> usize {
        self.computed
    }

    /// The encoded frame at `t` ([`super::wire::encode_frame`]).
    ///
    /// # Errors
    /// A time the model refuses, with [`Model::check_time`]'s text (the text `evogs render`
    /// gives after its `--times: `).
    pub fn frame(&mut self, t: f64) -> Result<&[u8], String> {
        self.model.check_time(t)?;
        let key = t.to_bits();
        if let Some(i) = self.cache.iter().position(|(k, _)| *k == key) {
            let hit = self.cache.remove(i).unwrap_or_default();
            self.cache.push_back(hit);
        } else {
            // A fresh integration from the anchors for every time, as `evogs render` does,
            // so a frame does not depend on which times were asked for before it.
            let mut stepper = None;
            let _tape = self.model.splats_at(t, &mut stepper, &mut self.scratch);
            let bytes = encode_frame(&self.scratch, t);
            self.computed += 1;
            if self.cache.len() == self.capacity {
                self.cache.pop_front();
            }
            self.cache.push_back((key, bytes));
        }
        Ok(self.cache.back().map_or(&[][..], |(_, b)| b.as_slice()))
    }
}
