//! The neural velocity field: HexPlane encoder + MLP, batched, with exact VJPs, and its
//! reading as an acceleration field ([`second_order`]).

mod chunk;
pub mod gemm;
mod heads;
pub mod hexplane;
mod lanes;
pub mod mlp;
pub mod neural;
pub mod profile;
pub mod regularize;
pub mod second_order;

pub use chunk::CHUNK;
pub use gemm::Gemm;
pub use hexplane::{HexPlane, HexPlaneConfig, TimeMapping};
pub use mlp::Mlp;
pub use neural::{Batch, BatchVjp, FieldRecord, NeuralField, NeuralFieldConfig, gaussian_layout};
pub use profile::{FieldProfile, FieldTimes};
pub use second_order::{SECOND_ORDER_STRIDE, SECOND_ORDER_TANGENT, SecondOrderField};
