//! Pruning a per-Gaussian array: the items of the Gaussians that stay, in order.

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
