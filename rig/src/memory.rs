//! Memory: the process's peak, for reports and benchmarks, and the machine's available memory, which
//! every job that allocates in proportion to an input or option checks before it starts — a job that
//! cannot fit is refused with the option to change, rather than aborted by the allocator half-way.

/// Peak resident set size of this process so far, in bytes (Linux `VmHWM`); `None` where the
/// platform does not say.
pub fn peak_resident_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Memory the machine can give a job now, in bytes (Linux `MemAvailable`); `None` where the platform
/// does not say.
pub fn available_bytes() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// A job that needs more memory than the machine has.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{what} needs about {:.1} GB of memory, and this machine has {:.1} GB available{hint}", gb(.need), gb(.available))]
pub struct TooLarge {
    /// What needs it: the input or option that sets the size.
    pub what: String,
    /// Bytes needed (estimated).
    pub need: u64,
    /// Bytes available.
    pub available: u64,
    /// What to change, starting with "; " (or empty).
    pub hint: String,
}

fn gb(bytes: &u64) -> f64 {
    *bytes as f64 / 1e9
}

/// Refuses a job estimated at `need` bytes (`None`: a size that overflows) when the machine has less
/// available. `what` names the input or option behind the size, `hint` what to change instead.
pub fn check(need: Option<u64>, what: &str, hint: &str) -> Result<(), TooLarge> {
    let available = available_bytes().unwrap_or(u64::MAX);
    let need = need.unwrap_or(u64::MAX);
    if need <= available {
        return Ok(());
    }
    let hint = if hint.is_empty() { String::new() } else { format!("; {hint}") };
    Err(TooLarge { what: what.into(), need, available, hint })
}

/// `a × b × …` in bytes without overflow (`None` if it does).
pub fn product(factors: &[u64]) -> Option<u64> {
    factors.iter().try_fold(1u64, |acc, &f| acc.checked_mul(f))
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_job_larger_than_the_machine_is_refused_by_name() {
        assert!(super::check(Some(1 << 20), "a small job", "").is_ok());
        let Some(have) = super::available_bytes() else { return };
        let e = super::check(Some(have.saturating_mul(4)), "--resolution 99999x99999", "choose a smaller one")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("--resolution 99999x99999 needs about") && e.ends_with("; choose a smaller one"), "{e}");
        assert!(super::check(super::product(&[u64::MAX, 2]), "an overflowing size", "").is_err());
        assert_eq!(super::product(&[3, 4, 5]), Some(60));
    }

    #[test]
    fn peak_memory_grows_with_a_touched_allocation() {
        let Some(before) = super::peak_resident_bytes() else { return };
        let v = vec![1u8; 64 << 20];
        std::hint::black_box(&v);
        let after = super::peak_resident_bytes().unwrap();
        assert!(after >= before && after >= 64 << 20, "{before} → {after}");
    }
}
