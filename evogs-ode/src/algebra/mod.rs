//! Vector-field algebra: sums, scalings, spatial mixes and rigid motions, each a
//! [`VectorField`](crate::VectorField) with its VJP.
//!
//! This is the motion editing of EvoGS: a learned field `v_θ` composes with injected
//! fields,
//!
//! ```text
//! v'(x) = λ(x)·v_inj(x) + (1 − λ(x))·v_θ(x)          (Mix, with a Mask giving λ)
//! v_rot(x) = ω × (x − c) on positions,  ω on rotations    (RigidRotation)
//! v_tr(x) = u on positions                                (Translation)
//! ```
//!
//! Fields act on **particle layouts**: a [`ParticleFrame`] names which block of the
//! per-particle pattern is the 3D position (`Euclidean(3)`) and which, if any, is the
//! orientation (`So3`). Because SO(3) blocks take world-frame angular velocities, giving
//! the rotation block the same ω as the positions makes an injected rotation turn each
//! particle's orientation exactly with it (RKMK integrates a constant rate exactly).
//!
//! Parameters of composites are the concatenation of their children's parameters, in
//! the order of the type name: `Sum<A, B>` → `[θ_A, θ_B]`, `Mix<A, B>` → `[θ_A, θ_B]`,
//! `Scaled<F>` → `θ_F` (the factor is a constant). Leaves: `RigidRotation` → `[ω, c]`,
//! `Translation` → `[u]`.

mod combine;
mod frame;
mod mask;
mod mix;
mod rigid;

pub use combine::{Scaled, Sum};
pub use frame::{FrameError, ParticleFrame};
pub use mask::{Edge, Mask};
pub use mix::Mix;
pub use rigid::{RigidRotation, Translation};
