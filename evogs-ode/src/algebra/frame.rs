//! [`ParticleFrame`]: where the position and the orientation sit in a particle.

use crate::{Block, BlockSpan, StateLayout};
use core::fmt;
use evogs_math::{Real, Vec3};

/// A particle layout with its position block (`Euclidean(3)`) and optional orientation
/// block (`So3`) identified. `Copy`.
///
/// ```
/// use evogs_ode::{Block, StateLayout, algebra::ParticleFrame};
/// let l = StateLayout::particles(&[Block::Euclidean(3), Block::So3, Block::Euclidean(3)], 10);
/// let frame = ParticleFrame::new(l, 0, Some(1)).unwrap();
/// assert_eq!(frame.layout().count(), 10);
/// assert!(ParticleFrame::new(l, 1, None).is_err()); // block 1 is not a position
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParticleFrame {
    layout: StateLayout,
    /// Ambient entries per particle.
    pa: usize,
    /// Tangent entries per particle.
    pt: usize,
    position: BlockSpan,
    rotation: Option<BlockSpan>,
}

/// Why a [`ParticleFrame`] cannot be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// The block index is not in the pattern.
    NoSuchBlock(usize),
    /// The position block is not `Euclidean(3)`.
    NotAPosition(usize),
    /// The rotation block is not `So3`.
    NotARotation(usize),
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoSuchBlock(i) => write!(f, "block {i} is not in the particle pattern"),
            Self::NotAPosition(i) => write!(f, "block {i} is not a 3D position (Euclidean(3))"),
            Self::NotARotation(i) => write!(f, "block {i} is not a rotation (So3)"),
        }
    }
}

impl core::error::Error for FrameError {}

impl ParticleFrame {
    /// Names block `position` of the pattern as the position and `rotation` (if any) as the
    /// orientation.
    ///
    /// # Errors
    /// If a block index is out of range or has the wrong kind.
    pub fn new(
        layout: StateLayout,
        position: usize,
        rotation: Option<usize>,
    ) -> Result<Self, FrameError> {
        let span = |i: usize| layout.spans().nth(i).ok_or(FrameError::NoSuchBlock(i));
        let position_span = span(position)?;
        if position_span.block != Block::Euclidean(3) {
            return Err(FrameError::NotAPosition(position));
        }
        let rotation = match rotation {
            Some(r) => {
                let s = span(r)?;
                if s.block != Block::So3 {
                    return Err(FrameError::NotARotation(r));
                }
                Some(s)
            }
            None => None,
        };
        Ok(Self {
            layout,
            pa: layout.particle_ambient_len(),
            pt: layout.particle_tangent_len(),
            position: position_span,
            rotation,
        })
    }

    /// `count` bare points: layout `[Euclidean(3)] × count`.
    #[must_use]
    pub fn points(count: usize) -> Self {
        let layout = StateLayout::particles(&[Block::Euclidean(3)], count);
        Self::new(layout, 0, None).expect("block 0 is a position")
    }

    /// `count` oriented points: layout `[Euclidean(3), So3] × count`.
    #[must_use]
    pub fn oriented_points(count: usize) -> Self {
        let layout = StateLayout::particles(&[Block::Euclidean(3), Block::So3], count);
        Self::new(layout, 0, Some(1)).expect("blocks 0 and 1 are a position and a rotation")
    }

    /// The state layout.
    #[must_use]
    pub const fn layout(&self) -> StateLayout {
        self.layout
    }

    /// The position block's span.
    #[must_use]
    pub const fn position_span(&self) -> BlockSpan {
        self.position
    }

    /// The rotation block's span, if any.
    #[must_use]
    pub const fn rotation_span(&self) -> Option<BlockSpan> {
        self.rotation
    }

    /// Ambient offset of particle `p`'s position in a state.
    #[inline]
    #[must_use]
    pub fn position_ambient(&self, p: usize) -> usize {
        p * self.pa + self.position.ambient
    }

    /// Tangent offset of particle `p`'s position in a derivative or cotangent.
    #[inline]
    #[must_use]
    pub fn position_tangent(&self, p: usize) -> usize {
        p * self.pt + self.position.tangent
    }

    /// Tangent offset of particle `p`'s rotation, if the frame has one.
    #[inline]
    #[must_use]
    pub fn rotation_tangent(&self, p: usize) -> Option<usize> {
        self.rotation.map(|r| p * self.pt + r.tangent)
    }

    /// Particle `p`'s position in a state `y`.
    #[inline]
    #[must_use]
    pub fn position<T: Real>(&self, y: &[T], p: usize) -> Vec3<T> {
        Vec3::from_slice(&y[self.position_ambient(p)..])
    }
}
