//! Command-line counts (`--iters`, `--seeds`, `--jobs`, `--gaussians`, `--threads`,
//! `--warmup`): clap value parsers that refuse `-5`, `0`, `1.5` or `x` with a message that
//! says what is expected.

/// A whole number of at least 1 (`--iters`, `--seeds`, `--jobs`).
///
/// # Errors
/// Anything else, quoted.
pub fn positive_count(s: &str) -> Result<u64, String> {
    match s.trim().parse::<u64>() {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err(format!("`{s}` is not a whole number of at least 1")),
    }
}

/// [`positive_count`] as a size in memory (`--seeds`, `--jobs`, `--gaussians`, `--threads`).
///
/// # Errors
/// Anything [`positive_count`] refuses, or a count beyond `usize`.
pub fn positive_size(s: &str) -> Result<usize, String> {
    usize::try_from(positive_count(s)?).map_err(|_| format!("`{s}` is too large"))
}

/// A whole number of at least 0 (warm-up iterations).
///
/// # Errors
/// Anything else, quoted.
pub fn whole_count(s: &str) -> Result<u64, String> {
    s.trim()
        .parse::<u64>()
        .map_err(|_| format!("`{s}` is not a whole number of at least 0"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_refuse_what_is_not_a_whole_number_in_range() {
        for bad in ["-5", "0", "1.5", "x", ""] {
            let e = positive_count(bad).expect_err(bad);
            assert!(e.contains("whole number of at least 1"), "{bad}: {e}");
            assert!(positive_size(bad).is_err(), "{bad}");
        }
        assert_eq!(positive_count(" 7 "), Ok(7));
        assert_eq!(positive_size("3"), Ok(3));
        assert_eq!(whole_count("0"), Ok(0));
        for bad in ["-1", "1.5"] {
            let e = whole_count(bad).expect_err(bad);
            assert!(e.contains("whole number of at least 0"), "{bad}: {e}");
        }
    }
}
