//! Selecting the items of a per-Gaussian array: pruning (the items of the Gaussians that
//! stay, in order) and reordering (a permutation of the Gaussians).

/// Keeps the `stride`-sized items of `data` whose flag in `keep` is true, in order.
pub fn retain_items<T: Copy>(data: &mut Vec<T>, keep: &[bool], stride: usize) {
    let mut w = 0;
    for (i, &k) in keep.iter().enumerate() {
        if k {
            if w != i {
                data.copy_within(i * stride..(i + 1) * stride, w * stride);
            }
            w += 1;
        }
    }
    data.truncate(w * stride);
}

/// Reorders the `stride`-sized items of `data`: item `i` becomes the old item `order[i]`
/// (`order` is a permutation of the items).
///
/// # Panics
/// If `order` does not have one entry per item or an entry is out of range.
pub fn permute_items<T: Copy>(data: &mut Vec<T>, order: &[usize], stride: usize) {
    assert_eq!(data.len(), order.len() * stride, "one order entry per item");
    let mut out = Vec::with_capacity(data.len());
    for &i in order {
        out.extend_from_slice(&data[i * stride..(i + 1) * stride]);
    }
    *data = out;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn permute_moves_whole_items() {
        let mut d = vec![1, 10, 2, 20, 3, 30];
        permute_items(&mut d, &[2, 0, 1], 2);
        assert_eq!(d, vec![3, 30, 1, 10, 2, 20]);
    }
}
