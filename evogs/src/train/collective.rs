//! The processes that share one training run: [`Collective`], with [`Solo`] for one
//! process. The `evogs` binary implements it over MPI (its `mpi` feature); a test implements
//! it over threads.
//!
//! Data-parallel training needs one operation: every rank's bytes, gathered in rank order,
//! on every rank ([`Collective::all_gather`]). Each rank then sums the same values in the
//! same order, so every rank holds the same parameters and the result does not depend on
//! timing (an all-reduce would leave the summation order to the library).

use crate::fnv::Fnv1a;

/// A group of processes that train one run together (ranks `0..size`).
pub trait Collective {
    /// This process's rank, `0..size`.
    fn rank(&self) -> usize;

    /// Number of processes.
    fn size(&self) -> usize;

    /// Every rank's `mine`, concatenated in rank order, on every rank. Every rank passes
    /// the same number of bytes.
    ///
    /// # Errors
    /// A rank did not answer in time, or the transport failed (the message says which).
    fn all_gather(&self, mine: &[u8]) -> Result<Vec<u8>, String>;
}

/// One process: rank 0 of 1 (gathering returns its own bytes).
#[derive(Clone, Copy, Debug, Default)]
pub struct Solo;

impl Collective for Solo {
    fn rank(&self) -> usize {
        0
    }

    fn size(&self) -> usize {
        1
    }

    fn all_gather(&self, mine: &[u8]) -> Result<Vec<u8>, String> {
        Ok(mine.to_vec())
    }
}

/// `true` on every rank if `flag` is `true` on any rank (a stop request, a checkpoint due
/// on one rank's clock).
///
/// # Errors
/// As [`Collective::all_gather`].
pub fn any(c: &dyn Collective, flag: bool) -> Result<bool, String> {
    Ok(c.all_gather(&[u8::from(flag)])?.iter().any(|&b| b != 0))
}

/// Waits until every rank reaches this point.
///
/// # Errors
/// As [`Collective::all_gather`].
pub fn barrier(c: &dyn Collective) -> Result<(), String> {
    c.all_gather(&[0]).map(drop)
}

/// Checks that every rank holds the same `hash` (of its parameters): an error that names
/// the ranks whose hash differs from rank 0's.
///
/// # Errors
/// Differing hashes, or as [`Collective::all_gather`].
pub fn agree(c: &dyn Collective, what: &str, hash: u64) -> Result<(), String> {
    let all = c.all_gather(&hash.to_le_bytes())?;
    let hashes: Vec<u64> = all
        .chunks_exact(8)
        .map(|b| u64::from_le_bytes(b.try_into().unwrap_or_default()))
        .collect();
    let differ: Vec<String> = hashes
        .iter()
        .enumerate()
        .filter(|&(_, &h)| h != hashes[0])
        .map(|(r, h)| format!("rank {r} ({h:016x})"))
        .collect();
    if differ.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "the ranks' {what} differ: rank 0 holds {:016x}, {}",
            hashes[0],
            differ.join(", ")
        ))
    }
}

/// FNV-1a (64 bit) of a sequence of `f32` values by their bits, as [`agree`] compares.
#[must_use]
pub fn hash_f32(values: impl IntoIterator<Item = f32>) -> u64 {
    let mut h = Fnv1a::default();
    values
        .into_iter()
        .for_each(|v| h.write(&v.to_bits().to_le_bytes()));
    h.finish()
}

/// [`hash_f32`] of every parameter of `model` (canonical Gaussians, anchors, fields) in the
/// order of [`ModelGrad::for_each`](crate::model::ModelGrad::for_each): what the ranks of a
/// run compare at every checkpoint.
#[must_use]
pub fn parameter_hash(model: &crate::model::Model<f32>) -> u64 {
    let params = crate::model::ModelGrad {
        canonical: model.canonical.clone(),
        anchors: model.anchors.clone(),
        field: crate::aligned::CacheAligned::from_slice(model.field.params()),
        waypoint_field: model
            .waypoint_field
            .as_ref()
            .map_or_else(Vec::new, |f| f.params().to_vec()),
    };
    let mut h = Fnv1a::default();
    params.for_each(|v| h.write(&v.to_bits().to_le_bytes()));
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_process_gathers_its_own_bytes() {
        assert_eq!(Solo.all_gather(&[1, 2, 3]).unwrap(), vec![1, 2, 3]);
        assert!(any(&Solo, true).unwrap());
        assert!(!any(&Solo, false).unwrap());
        assert!(agree(&Solo, "parameters", 7).is_ok());
        assert_ne!(hash_f32([0.0]), hash_f32([-0.0]), "bits, not values");
    }
}
