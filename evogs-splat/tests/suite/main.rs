//! The integration tests of `evogs-splat`, one binary (one link, one compile of the generic
//! code they share): each module is one file of tests, run as `cargo test -p evogs-splat --test suite`.

mod metrics_oracle;
mod metrics_ssim;
mod metrics_vjp;
mod projection_oracle;
mod projection_rules;
#[cfg(feature = "proptest")]
mod properties;
mod raster_oracle;
mod splat_camera;
mod splat_common;
mod splat_fd;
mod splat_render_fd;
mod splat_robust;
mod splat_rules;
mod tiled_binning;
mod tiled_chain;
mod tiled_common;
mod tiled_oracle;
mod tiled_random;
