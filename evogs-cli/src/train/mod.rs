//! Training: the optimiser, the losses and regularisers, densification and the training loop.

pub mod adam;
pub mod coherence;
pub mod step;
