//! What the bench reads from the operating system: the peak and current resident set size
//! of the process (Linux: `VmHWM` and `VmRSS` of `/proc/self/status`, the peak reset through
//! `/proc/self/clear_refs`) and the CPU model (`/proc/cpuinfo`). Elsewhere these are unknown (`None`).

/// The process's peak resident set size in bytes, if the system reports it.
#[must_use]
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status_field_kib(&status, "VmHWM:").map(|kib| kib * 1024)
}

/// The process's current resident set size in bytes, if the system reports it.
#[must_use]
pub fn current_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status_field_kib(&status, "VmRSS:").map(|kib| kib * 1024)
}

/// Resets the peak resident set size to the current one (Linux ≥ 4.0); `false` if the
/// system does not allow it (the peak then covers everything before too).
#[must_use]
pub fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// The CPU model name, if the system reports it.
#[must_use]
pub fn cpu_model() -> Option<String> {
    let info = std::fs::read_to_string("/proc/cpuinfo").ok()?;
    info.lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split_once(':'))
        .map(|(_, v)| v.trim().to_string())
}

/// The value in KiB of a `Name:   1234 kB` line of `/proc/self/status`.
fn status_field_kib(status: &str, name: &str) -> Option<u64> {
    status
        .lines()
        .find_map(|l| l.strip_prefix(name))
        .and_then(|v| v.split_whitespace().next())
        .and_then(|v| v.parse().ok())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_lines_are_read_in_kib() {
        let s = "Name:\tevogs\nVmPeak:\t  999 kB\nVmHWM:\t   2048 kB\nVmRSS:\t 1024 kB\n";
        assert_eq!(status_field_kib(s, "VmHWM:"), Some(2048));
        assert_eq!(status_field_kib(s, "VmSwap:"), None);
        if cfg!(target_os = "linux") {
            assert!(
                peak_rss_bytes().is_some_and(|b| b > 0),
                "Linux reports VmHWM"
            );
        }
    }
}
