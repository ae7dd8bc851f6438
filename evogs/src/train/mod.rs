//! Training: the optimiser, the losses and regularisers, densification and the training loop.

pub mod adam;
pub mod batch;
pub mod coherence;
pub mod collective;
pub mod densify;
pub mod frames;
pub mod neighbours;
pub mod optim;
pub mod render_pass;
pub mod sampler;
pub mod schedule;
pub mod state;
pub mod step;
pub mod trainer;
pub mod views;
