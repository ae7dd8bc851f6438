//! Small statistics for the diagnostic examples (`step_check`).

/// The value below which a fraction `q` of the sorted values lie (the nearest rank; NaN for
/// an empty list).
pub(crate) fn pct(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    #[allow(
        clippy::cast_possible_truncation,
        reason = "an index into a short list"
    )]
    let i = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted[i]
}
