//! The process's peak memory, for reports and benchmarks.

/// Peak resident set size of this process so far, in bytes (Linux `VmHWM`); `None` where the
/// platform does not say.
pub fn peak_resident_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

#[cfg(test)]
mod tests {
    #[test]
    fn peak_memory_grows_with_a_touched_allocation() {
        let Some(before) = super::peak_resident_bytes() else { return };
        let v = vec![1u8; 64 << 20];
        std::hint::black_box(&v);
        let after = super::peak_resident_bytes().unwrap();
        assert!(after >= before && after >= 64 << 20, "{before} → {after}");
    }
}
