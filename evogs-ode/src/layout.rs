//! State layouts: which parts of a state vector are Euclidean, rotations or rigid transforms.
//!
//! A state is a flat slice. Its layout is a short per-particle **pattern** of blocks,
//! repeated `count` times (particle-major), so one vector field can carry many particles
//! (every Gaussian of a scene at once) without a per-particle description:
//!
//! ```text
//! pattern [Euclidean(3), So3, Euclidean(3)], count 2:
//! ambient  y    = [p0 p0 p0 | qw qx qy qz | s0 s0 s0 | p1 p1 p1 | qw qx qy qz | s1 s1 s1]   (20)
//! tangent  dydt = [v0 v0 v0 | ω0 ω0 ω0    | r0 r0 r0 | v1 v1 v1 | ω1 ω1 ω1    | r1 r1 r1]   (18)
//! ```
//!
//! An [`Block::So3`] block stores a **unit quaternion (w, x, y, z)** in the state (4 ambient
//! entries) but has 3 tangent entries: a vector field returns a **world-frame angular
//! velocity** ω there, and steppers update the rotation on the manifold,
//! `R ← Exp(h ω)·R`. Cotangents (gradients) of SO(3) blocks are 3-vectors with respect to
//! a **left** perturbation `R ↦ Exp(δ)·R` (world frame).
//!
//! An [`Block::Se3`] block stores a rigid transform `T = (R, t)` as a **unit quaternion
//! (w, x, y, z) followed by the translation** (7 ambient entries) and has 6 tangent entries
//! ordered **(ρ, φ)**, translation part first: a vector field returns a **world-frame
//! (left) twist** ξ there (`Ṫ = ξ̂·T`, i.e. `Ṙ = φ̂R`, `ṫ = φ × t + ρ`), steppers update
//! `T ← Exp(h ξ)·T`, and cotangents are 6-vectors with respect to `T ↦ Exp(δ)·T`
//! (conventions of [`evogs_math::se3`]).
//!
//! Everything that is not a state (time derivatives, cotangents, adjoints) uses tangent
//! coordinates.

/// The largest number of blocks in a particle pattern.
pub const MAX_BLOCKS: usize = 8;

/// One block of a particle's state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Block {
    /// `n` Euclidean coordinates (ambient = tangent = n).
    Euclidean(usize),
    /// A rotation: a unit quaternion (w, x, y, z) in the state, a 3-vector in tangent space.
    So3,
    /// A rigid transform: a unit quaternion (w, x, y, z) and a translation (7 numbers) in the
    /// state, a twist (ρ, φ) (6 numbers, translation part first) in tangent space.
    Se3,
}

impl Block {
    /// Entries in the state vector.
    #[inline]
    #[must_use]
    pub const fn ambient_len(self) -> usize {
        match self {
            Self::Euclidean(n) => n,
            Self::So3 => 4,
            Self::Se3 => 7,
        }
    }
    /// Entries in tangent vectors (derivatives, cotangents).
    #[inline]
    #[must_use]
    pub const fn tangent_len(self) -> usize {
        match self {
            Self::Euclidean(n) => n,
            Self::So3 => 3,
            Self::Se3 => 6,
        }
    }
}

/// A block with its offsets inside one particle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlockSpan {
    /// The block.
    pub block: Block,
    /// Offset of the block in the particle's ambient (state) entries.
    pub ambient: usize,
    /// Offset of the block in the particle's tangent entries.
    pub tangent: usize,
}

/// A per-particle pattern of blocks repeated `count` times. `Copy`, no allocation.
///
/// ```
/// use evogs_ode::{Block, StateLayout};
/// let l = StateLayout::particles(&[Block::Euclidean(3), Block::So3, Block::Euclidean(3)], 1000);
/// assert_eq!(l.ambient_len(), 10_000);
/// assert_eq!(l.tangent_len(), 9_000);
/// assert!(!l.is_euclidean());
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StateLayout {
    pattern: [Block; MAX_BLOCKS],
    n_blocks: usize,
    count: usize,
}

impl StateLayout {
    /// A plain Euclidean state of dimension `n`.
    #[must_use]
    pub const fn euclidean(n: usize) -> Self {
        let mut pattern = [Block::Euclidean(0); MAX_BLOCKS];
        pattern[0] = Block::Euclidean(n);
        Self {
            pattern,
            n_blocks: 1,
            count: 1,
        }
    }

    /// `count` particles, each laid out as `pattern`.
    ///
    /// # Panics
    /// If the pattern is empty or has more than [`MAX_BLOCKS`] blocks.
    #[must_use]
    pub fn particles(pattern: &[Block], count: usize) -> Self {
        assert!(
            !pattern.is_empty() && pattern.len() <= MAX_BLOCKS,
            "pattern needs 1..={MAX_BLOCKS} blocks"
        );
        let mut p = [Block::Euclidean(0); MAX_BLOCKS];
        p[..pattern.len()].copy_from_slice(pattern);
        Self {
            pattern: p,
            n_blocks: pattern.len(),
            count,
        }
    }

    /// The per-particle pattern.
    #[inline]
    #[must_use]
    pub fn pattern(&self) -> &[Block] {
        &self.pattern[..self.n_blocks]
    }

    /// Number of particles.
    #[inline]
    #[must_use]
    pub const fn count(&self) -> usize {
        self.count
    }

    /// Ambient (state) entries per particle.
    #[must_use]
    pub fn particle_ambient_len(&self) -> usize {
        self.pattern().iter().map(|b| b.ambient_len()).sum()
    }

    /// Tangent entries per particle.
    #[must_use]
    pub fn particle_tangent_len(&self) -> usize {
        self.pattern().iter().map(|b| b.tangent_len()).sum()
    }

    /// Length of a state vector.
    #[must_use]
    pub fn ambient_len(&self) -> usize {
        self.particle_ambient_len() * self.count
    }

    /// Length of a tangent vector (derivative or cotangent).
    #[must_use]
    pub fn tangent_len(&self) -> usize {
        self.particle_tangent_len() * self.count
    }

    /// `true` if there is no Lie-group (SO(3) or SE(3)) block: ambient and tangent
    /// coordinates coincide.
    #[must_use]
    pub fn is_euclidean(&self) -> bool {
        self.pattern()
            .iter()
            .all(|b| matches!(b, Block::Euclidean(_)))
    }

    /// The blocks of one particle with their offsets.
    pub fn spans(&self) -> impl Iterator<Item = BlockSpan> + '_ {
        let mut a = 0;
        let mut t = 0;
        self.pattern().iter().map(move |&block| {
            let s = BlockSpan {
                block,
                ambient: a,
                tangent: t,
            };
            a += block.ambient_len();
            t += block.tangent_len();
            s
        })
    }

    /// The span of block `i` of the pattern.
    ///
    /// # Panics
    /// If `i` is not a block index of the pattern.
    #[must_use]
    pub fn span(&self, i: usize) -> BlockSpan {
        self.spans()
            .nth(i)
            .unwrap_or_else(|| panic!("block {i} out of range"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_follow_the_pattern() {
        let l = StateLayout::particles(&[Block::Euclidean(3), Block::So3, Block::Euclidean(2)], 5);
        let spans: alloc::vec::Vec<_> = l.spans().collect();
        assert_eq!(
            spans[1],
            BlockSpan {
                block: Block::So3,
                ambient: 3,
                tangent: 3
            },
            "rotation block"
        );
        assert_eq!(spans[2].ambient, 7, "after the quaternion");
        assert_eq!(spans[2].tangent, 6, "after the 3 tangent entries");
        assert_eq!((l.ambient_len(), l.tangent_len()), (45, 40), "totals");
        assert!(StateLayout::euclidean(4).is_euclidean(), "euclidean layout");
        let l = StateLayout::particles(&[Block::Euclidean(2), Block::Se3, Block::So3], 3);
        assert_eq!(l.span(2).ambient, 9, "after the 7 numbers of the transform");
        assert_eq!(
            l.span(2).tangent,
            8,
            "after the 6 tangent entries of the transform"
        );
        assert_eq!((l.ambient_len(), l.tangent_len()), (39, 33), "SE(3) totals");
        assert!(!l.is_euclidean(), "an SE(3) block is not Euclidean");
    }
}
