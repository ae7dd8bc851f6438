//! [`CacheAligned`]: a fixed-length buffer whose first element starts a cache line.
//!
//! The HexPlane reads and writes its planes in C-vectors of 32 or 16 values (128 or 64
//! bytes of f32) at offsets that are multiples of that size from the start of the
//! parameter vector. A `Vec` of that size comes from the system allocator 16 bytes past a
//! page boundary, so every C-vector straddled one more cache line than it needs and a
//! quarter of its 32-byte loads split across two lines; starting the buffer on a 64-byte
//! boundary makes each C-vector exactly its own lines.
//!
//! Without `unsafe`: the buffer holds a few values more than asked for and hands out the
//! aligned window of it.

use core::ops::{Deref, DerefMut};

/// The cache-line size the window is aligned to, in bytes.
pub const CACHE_LINE: usize = 64;

/// A buffer of `len` values of `T` starting on a [`CACHE_LINE`] boundary (dereferences to
/// that window; its length never changes).
#[derive(Debug)]
pub struct CacheAligned<T> {
    buf: Vec<T>,
    start: usize,
    len: usize,
}

/// The index of the first element of `buf` that starts a cache line (0 if none can: a
/// size that does not divide the line, or an empty buffer).
fn aligned_start<T>(buf: &[T]) -> usize {
    let size = core::mem::size_of::<T>().max(1);
    // A pointer's address is a plain integer: reading it needs no `unsafe`.
    let misalign = (buf.as_ptr() as usize) % CACHE_LINE;
    if buf.is_empty() || !misalign.is_multiple_of(size) || !CACHE_LINE.is_multiple_of(size) {
        0
    } else {
        ((CACHE_LINE - misalign) % CACHE_LINE) / size
    }
}

impl<T: Clone> CacheAligned<T> {
    /// `len` copies of `value`.
    #[must_use]
    pub fn new(len: usize, value: T) -> Self {
        let pad = CACHE_LINE / core::mem::size_of::<T>().max(1);
        let buf = vec![value; len + pad];
        Self {
            start: aligned_start(&buf),
            buf,
            len,
        }
    }

    /// A copy of `values`, aligned.
    #[must_use]
    pub fn from_slice(values: &[T]) -> Self {
        match values.first() {
            Some(v) => {
                let mut out = Self::new(values.len(), v.clone());
                out.clone_from_slice(values);
                out
            }
            None => Self::default(),
        }
    }

    /// Resizes to `len` values like `Vec::resize` (the first values kept, new ones
    /// `value`), in a new aligned buffer when the length changes.
    pub fn resize(&mut self, len: usize, value: T) {
        if len != self.len {
            let mut out = Self::new(len, value);
            let keep = len.min(self.len);
            out[..keep].clone_from_slice(&self[..keep]);
            *self = out;
        }
    }
}

impl<T> Default for CacheAligned<T> {
    /// An empty buffer.
    fn default() -> Self {
        Self {
            buf: Vec::new(),
            start: 0,
            len: 0,
        }
    }
}

impl<T: Clone> Clone for CacheAligned<T> {
    /// A new buffer, aligned on its own (the copy's address differs).
    fn clone(&self) -> Self {
        Self::from_slice(self)
    }

    /// Copies into the buffer it has when the lengths agree.
    fn clone_from(&mut self, source: &Self) {
        if self.len == source.len {
            self.clone_from_slice(source);
        } else {
            *self = source.clone();
        }
    }
}

impl<T> Deref for CacheAligned<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        &self.buf[self.start..self.start + self.len]
    }
}

impl<T> DerefMut for CacheAligned<T> {
    fn deref_mut(&mut self) -> &mut [T] {
        &mut self.buf[self.start..self.start + self.len]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_window_starts_a_cache_line_and_has_the_length_asked_for() {
        for len in [0, 1, 15, 16, 1000, 1 << 20] {
            let a = CacheAligned::new(len, 1.5_f32);
            assert_eq!(a.len(), len);
            assert!(a.iter().all(|v| v.to_bits() == 1.5_f32.to_bits()), "filled");
            if len > 0 {
                assert_eq!(a.as_ptr() as usize % CACHE_LINE, 0, "f32, {len}");
            }
            let b = CacheAligned::new(len, 0.0_f64);
            if len > 0 {
                assert_eq!(b.as_ptr() as usize % CACHE_LINE, 0, "f64, {len}");
            }
        }
    }

    #[test]
    fn resize_keeps_the_first_values_and_the_alignment() {
        let mut a = CacheAligned::<f32>::default();
        assert!(a.is_empty());
        a.resize(10, 2.0);
        a[3] = 7.0;
        a.resize(100, 1.0);
        assert_eq!(
            (a.len(), a[3].to_bits(), a[50].to_bits()),
            (100, 7.0_f32.to_bits(), 1.0_f32.to_bits())
        );
        assert_eq!(a.as_ptr() as usize % CACHE_LINE, 0);
        a.resize(4, 0.0);
        assert_eq!((a.len(), a[3].to_bits()), (4, 7.0_f32.to_bits()));
    }

    #[test]
    fn a_clone_is_equal_and_aligned_on_its_own() {
        let mut a = CacheAligned::new(100, 0.0_f32);
        for (i, v) in a.iter_mut().enumerate() {
            *v = i as f32;
        }
        let b = a.clone();
        assert_eq!(&*a, &*b);
        assert_eq!(b.as_ptr() as usize % CACHE_LINE, 0);
        assert_ne!(a.as_ptr(), b.as_ptr(), "a new buffer");
    }
}
