//! Tick values and labels for a logarithmic axis: round values inside the range, labelled
//! with as few significant digits as keep every label different from the others.

/// Up to a handful of round tick values inside `[lo, hi]` (`0 < lo < hi`), increasing: the
/// powers of ten there, else the 1-2-5 steps of each decade, else every digit, else (a range
/// within one digit step) evenly spaced round values.
#[must_use]
pub(super) fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return Vec::new();
    }
    let inside = |mantissas: &[f64]| -> Vec<f64> {
        let (e0, e1) = (decade(lo), decade(hi) + 1);
        let mut out = Vec::new();
        for e in e0..=e1 {
            for m in mantissas {
                let v = m * 10f64.powi(e);
                if v >= lo * (1.0 - 1e-12) && v <= hi * (1.0 + 1e-12) {
                    out.push(v);
                }
            }
        }
        out
    };
    for mantissas in [
        &[1.0][..],
        &[1.0, 2.0, 5.0],
        &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0],
    ] {
        let t = inside(mantissas);
        if t.len() >= 3 {
            return thin(t, 8);
        }
    }
    // A narrow range: evenly spaced round values, a 1-2-5 step giving three to seven ticks.
    let raw = (hi - lo) / 4.0;
    let p = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|s| (hi - lo) / s <= 6.0)
        .unwrap_or(10.0 * p);
    let mut out = Vec::new();
    let mut k = (lo / step).ceil();
    while k * step <= hi * (1.0 + 1e-12) && out.len() < 8 {
        out.push(k * step);
        k += 1.0;
    }
    out
}

/// The decade of `x > 0`: ⌊log₁₀ x⌋.
#[allow(
    clippy::cast_possible_truncation,
    reason = "the log10 of a finite positive f64 lies within ±324"
)]
fn decade(x: f64) -> i32 {
    x.log10().floor() as i32
}

/// Every other element until at most `max` remain (keeping the first).
fn thin(mut t: Vec<f64>, max: usize) -> Vec<f64> {
    while t.len() > max {
        t = t.into_iter().step_by(2).collect();
    }
    t
}

/// `v` with `digits` significant digits: plain decimals from 0.0001 to 99999, else
/// scientific (`2.5e-5`); trailing zeros dropped.
#[must_use]
pub(super) fn fmt_sig(v: f64, digits: usize) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let e = decade(v.abs());
    let trim = |s: String| -> String {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    };
    let digits_i = i32::try_from(digits).unwrap_or(17);
    if (-4..5).contains(&e) {
        let decimals = usize::try_from((digits_i - 1 - e).max(0)).unwrap_or(0);
        // Round to the significant digits left of the point too (12345 → 12000).
        let left = e + 1 - digits_i;
        let v = if left > 0 {
            let scale = 10f64.powi(left);
            (v / scale).round() * scale
        } else {
            v
        };
        trim(format!("{v:.decimals$}"))
    } else {
        let s = format!("{v:.*e}", digits.saturating_sub(1));
        match s.split_once('e') {
            Some((m, x)) => format!("{}e{x}", trim(m.to_string())),
            None => s,
        }
    }
}

/// Labels for `ticks`, all different: the fewest significant digits (1 to 17) for which no
/// two labels are equal.
#[must_use]
pub(super) fn distinct_labels(ticks: &[f64]) -> Vec<String> {
    let mut labels = Vec::new();
    for digits in 1..=17 {
        labels = ticks.iter().map(|&v| fmt_sig(v, digits)).collect();
        let mut sorted = labels.clone();
        sorted.sort();
        sorted.dedup();
        if sorted.len() == labels.len() {
            break;
        }
    }
    labels
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_never_repeat() {
        for (lo, hi) in [
            (1e-4, 1.0),
            (0.02, 0.3),
            (0.0213, 0.0215),
            (0.031, 0.089),
            (0.5, 0.500_001),
            (3e-7, 4e-7),
            (12.0, 13000.0),
        ] {
            let t = log_ticks(lo, hi);
            assert!(t.len() >= 2, "{lo}..{hi}: ticks {t:?}");
            assert!(
                t.iter()
                    .all(|&v| v >= lo * 0.999_999 && v <= hi * 1.000_001),
                "{lo}..{hi}: inside {t:?}"
            );
            assert!(t.windows(2).all(|w| w[0] < w[1]), "increasing {t:?}");
            let l = distinct_labels(&t);
            let mut d = l.clone();
            d.dedup();
            assert_eq!(d, l, "{lo}..{hi}: labels {l:?} repeat");
        }
    }

    #[test]
    fn labels_are_short_and_round() {
        assert_eq!(
            distinct_labels(&log_ticks(1e-3, 1.0)),
            ["0.001", "0.01", "0.1", "1"],
            "decades"
        );
        assert_eq!(
            distinct_labels(&log_ticks(0.02, 0.3)),
            ["0.02", "0.05", "0.1", "0.2"],
            "1-2-5"
        );
        assert_eq!(fmt_sig(2.5e-5, 2), "2.5e-5", "scientific");
        assert_eq!(fmt_sig(12345.0, 2), "12000", "plain");
    }
}
