//! Peak memory per stage: the process' resident high-water mark (`VmHWM` in `/proc/self/status`),
//! read when a stage ends and reset for the next (writing 5 to `/proc/self/clear_refs`, Linux 4.0+).
//! Elsewhere, or where the kernel refuses, there is no figure rather than a wrong one.
//!
//! Between scan stages the pipeline hands freed memory back to the system ([`release_freed`],
//! glibc's `malloc_trim`): the worker threads' allocator arenas otherwise keep what a stage freed
//! resident, and the next stage's peak would start from the last one's.

use rig::math::Real;

/// The resident peak since the last call (MB), and a fresh start for the next stage's.
pub fn take_peak_mb() -> Option<Real> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let kb: Real =
        status.lines().find_map(|l| l.strip_prefix("VmHWM:"))?.trim().trim_end_matches("kB").trim().parse().ok()?;
    // Failing to reset only makes the next figure cover more than its stage: it is still a bound.
    let _ = std::fs::write("/proc/self/clear_refs", "5");
    Some(kb / 1024.0)
}

/// Caps glibc's allocator at two arenas (half the cores on larger machines). A view's grids, made
/// on whichever thread ran the view and freed by another, otherwise stayed resident in per-thread
/// arenas between smaller live blocks (`malloc_trim` returns only whole free pages): with views run
/// two at a time, fusion's peak rose from 1.03 to 1.39 GB; with two arenas it is 1.17–1.25 GB, no
/// slower within this 2-core machine's noise (mapping every block of 4 MB or more on its own instead
/// held the peak at 1.03 GB but doubled the page faults: 3 s more CPU). Measured on 2 cores only;
/// on more, threads sharing an arena contend for its lock, hence half the cores there. The CLI calls
/// it first thing, before threads start (an arena, once made, stays); a library caller keeps its
/// own allocator policy. `MALLOC_ARENA_MAX` in the environment wins.
pub fn limit_arenas() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    if std::env::var_os("MALLOC_ARENA_MAX").is_none() {
        let cores = std::thread::available_parallelism().map_or(2, |n| n.get());
        // SAFETY: mallopt only sets a parameter of glibc's allocator; it takes no pointers.
        unsafe {
            libc::mallopt(libc::M_ARENA_MAX, (cores / 2).max(2) as libc::c_int);
        }
    }
}

/// Returns freed heap memory to the system (glibc; elsewhere the allocator keeps its own policy).
pub fn release_freed() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only walks glibc's own arenas under their locks; it takes no pointers of
    // ours and is safe to call at any time from any thread.
    unsafe {
        libc::malloc_trim(0);
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_peak_covers_what_was_held_and_resets() {
        if !std::path::Path::new("/proc/self/status").exists() {
            eprintln!("SKIPPED: no /proc here, so no peak memory figures");
            return;
        }
        let _ = super::take_peak_mb();
        let big = vec![1u8; 200 << 20];
        std::hint::black_box(&big);
        // Freed before the reading: the peak still covers it; the reset then starts from what is
        // held now, so the next reading is far lower.
        drop(big);
        let with = super::take_peak_mb().unwrap();
        let after = super::take_peak_mb().unwrap();
        assert!(with >= 200.0, "200 MB held, peak {with} MB");
        assert!(after < with - 150.0, "the peak was reset: {after} MB after {with} MB");
    }
}
