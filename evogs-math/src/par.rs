//! Parallelism as a value: [`Par`].
//!
//! Kernels that can run in parallel take a `Par` argument instead of consulting a hidden
//! global. Work is always split into fixed-size chunks that do not depend on the number of
//! threads, and partial results are reduced in chunk order, so a `Par::Rayon` run gives
//! results **bitwise identical** to `Par::Seq` on any thread count.

/// How a kernel may use threads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Par {
    /// Run on the calling thread.
    #[default]
    Seq,
    /// Run chunks on rayon's global thread pool (requires the `rayon` feature).
    #[cfg(feature = "rayon")]
    Rayon,
}

impl Par {
    /// `Par::Rayon` when the `rayon` feature is enabled, else `Par::Seq`.
    #[must_use]
    pub const fn best() -> Self {
        #[cfg(feature = "rayon")]
        {
            Self::Rayon
        }
        #[cfg(not(feature = "rayon"))]
        {
            Self::Seq
        }
    }

    /// `true` for the sequential variant.
    #[must_use]
    pub const fn is_seq(self) -> bool {
        matches!(self, Self::Seq)
    }
}

#[cfg(test)]
mod tests {
    use super::Par;

    #[test]
    fn only_the_sequential_variant_is_sequential() {
        assert!(Par::Seq.is_seq());
        #[cfg(feature = "rayon")]
        assert!(!Par::Rayon.is_seq());
    }
}
