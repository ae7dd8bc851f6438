//! [`Image`]: an RGB image of scalars, row-major, row 0 at the top.
//!
//! Pixels are stored interleaved (`r, g, b, r, g, b, …`), row by row from the top; pixel
//! (column `x`, row `y`) starts at index `3·(y·width + x)`. File formats live outside the
//! no_std core (evogs-cli reads and writes PNG).

use alloc::vec;
use alloc::vec::Vec;
use evogs_math::Real;

/// An RGB image, row-major, row 0 at the top, channels interleaved.
///
/// ```
/// use evogs_splat::Image;
/// let mut img = Image::<f32>::new(4, 3);
/// img.set(1, 2, [0.1, 0.2, 0.3]);
/// assert_eq!(img.get(1, 2), [0.1, 0.2, 0.3]);
/// assert_eq!(img.data().len(), 4 * 3 * 3);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Image<T> {
    width: usize,
    height: usize,
    data: Vec<T>,
}

impl<T: Real> Image<T> {
    /// A black image.
    #[must_use]
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            data: vec![T::ZERO; width * height * 3],
        }
    }

    /// An image filled with one colour.
    #[must_use]
    pub fn filled(width: usize, height: usize, rgb: [T; 3]) -> Self {
        let mut img = Self::new(width, height);
        for px in img.data.chunks_exact_mut(3) {
            px.copy_from_slice(&rgb);
        }
        img
    }

    /// An image from interleaved RGB data; `None` if the length is not `3·width·height`.
    #[must_use]
    pub fn from_vec(width: usize, height: usize, data: Vec<T>) -> Option<Self> {
        (data.len() == width * height * 3).then_some(Self {
            width,
            height,
            data,
        })
    }

    /// Width in pixels.
    #[inline]
    #[must_use]
    pub const fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    #[inline]
    #[must_use]
    pub const fn height(&self) -> usize {
        self.height
    }

    /// The interleaved RGB values.
    #[inline]
    #[must_use]
    pub fn data(&self) -> &[T] {
        &self.data
    }

    /// The interleaved RGB values, mutable.
    #[inline]
    pub fn data_mut(&mut self) -> &mut [T] {
        &mut self.data
    }

    /// Consumes the image, returning its data.
    #[must_use]
    pub fn into_vec(self) -> Vec<T> {
        self.data
    }

    /// The pixel at column `x`, row `y`.
    ///
    /// # Panics
    /// If the pixel is outside the image.
    #[inline]
    #[must_use]
    pub fn get(&self, x: usize, y: usize) -> [T; 3] {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside {}x{}",
            self.width,
            self.height
        );
        let i = 3 * (y * self.width + x);
        [self.data[i], self.data[i + 1], self.data[i + 2]]
    }

    /// Sets the pixel at column `x`, row `y`.
    ///
    /// # Panics
    /// If the pixel is outside the image.
    #[inline]
    pub fn set(&mut self, x: usize, y: usize, rgb: [T; 3]) {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside {}x{}",
            self.width,
            self.height
        );
        let i = 3 * (y * self.width + x);
        self.data[i..i + 3].copy_from_slice(&rgb);
    }

    /// Converts the scalar type (through `f64`).
    #[must_use]
    pub fn cast<U: Real>(&self) -> Image<U> {
        Image {
            width: self.width,
            height: self.height,
            data: self.data.iter().map(|v| U::from_f64(v.to_f64())).collect(),
        }
    }

    /// `true` if the two images have the same size.
    #[inline]
    #[must_use]
    pub fn same_size(&self, other: &Self) -> bool {
        self.width == other.width && self.height == other.height
    }
}

#[cfg(test)]
mod tests {
    use super::Image;

    #[test]
    fn from_vec_and_into_vec_hand_back_the_same_values() {
        let data: Vec<f64> = (0..2 * 3 * 3).map(f64::from).collect();
        let img = Image::from_vec(2, 3, data.clone()).expect("2 × 3 × 3 values");
        assert_eq!(
            img.get(1, 2).map(f64::to_bits),
            [15.0, 16.0, 17.0].map(f64::to_bits),
            "row-major RGB"
        );
        assert_eq!(img.into_vec(), data, "the values, in order");
    }

    #[test]
    fn same_size_needs_both_sides_equal() {
        let a = Image::<f32>::new(4, 3);
        assert!(a.same_size(&Image::new(4, 3)), "4 × 3 and 4 × 3");
        assert!(!a.same_size(&Image::new(4, 2)), "another height");
        assert!(!a.same_size(&Image::new(3, 3)), "another width");
        assert!(!a.same_size(&Image::new(3, 4)), "transposed");
    }
}
