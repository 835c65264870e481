//! One scanrig run at a time per output folder (`process` in its processed folder, `scan` in its scan
//! folder): a lock file holding the owner's process id, created exclusively. A second run refuses with the owner's id; a lock whose owner is no longer running (a
//! killed run) is stale, and is taken over with a note.

use std::io::Write;
use std::path::{Path, PathBuf};

/// The lock file inside the output folder.
pub const LOCK_NAME: &str = ".scanrig.lock";

/// Why the folder could not be locked.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LockError {
    /// Another run holds it.
    #[error(
        "{path}: another scanrig (process {pid}) is writing into this folder; wait for it to finish, or \
         remove the lock file if that process is not a scanrig run"
    )]
    Busy {
        /// The lock file.
        path: PathBuf,
        /// Its owner.
        pid: u32,
    },
    /// The lock file could not be made.
    #[error("{path}: cannot create the lock file: {source}")]
    Io {
        /// The lock file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
}

/// A held lock, released when dropped.
#[derive(Debug)]
pub struct Lock {
    path: PathBuf,
    /// The owner of a stale lock this one replaced, if any.
    pub replaced_stale: Option<u32>,
}

fn running(pid: u32) -> bool {
    // Linux: a live process has a /proc entry. Elsewhere assume it runs (refusing is the safe side).
    if Path::new("/proc/self").exists() { Path::new(&format!("/proc/{pid}")).exists() } else { true }
}

impl Lock {
    /// Locks the folder `dir` (which must exist).
    pub fn acquire(dir: &Path) -> Result<Lock, LockError> {
        let path = dir.join(LOCK_NAME);
        let mut replaced_stale = None;
        for _ in 0..3 {
            match std::fs::OpenOptions::new().write(true).create_new(true).open(&path) {
                Ok(mut f) => {
                    let _ = writeln!(f, "{}", std::process::id());
                    return Ok(Lock { path, replaced_stale });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let owner = std::fs::read_to_string(&path).ok().and_then(|s| s.trim().parse::<u32>().ok());
                    match owner {
                        Some(pid) if pid != std::process::id() && running(pid) => {
                            return Err(LockError::Busy { path, pid });
                        }
                        // A dead owner, our own leftover, or an unreadable file from a crash mid-write.
                        stale => {
                            replaced_stale = Some(stale.unwrap_or(0));
                            let _ = std::fs::remove_file(&path);
                        }
                    }
                }
                Err(source) => return Err(LockError::Io { path, source }),
            }
        }
        Err(LockError::Io { path, source: std::io::Error::other("the lock file keeps reappearing") })
    }
}

impl Drop for Lock {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_live_owner_refuses_and_a_dead_one_is_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let held = Lock::acquire(dir.path()).unwrap();
        assert!(held.replaced_stale.is_none());
        // Our own pid in the file reads as a leftover of this process, so pretend another live one: 1.
        std::fs::write(dir.path().join(LOCK_NAME), "1\n").unwrap();
        let err = Lock::acquire(dir.path()).unwrap_err().to_string();
        assert!(err.contains("another scanrig (process 1)"), "{err}");
        // A pid that cannot be running (above Linux's pid_max).
        std::fs::write(dir.path().join(LOCK_NAME), "4294967\n").unwrap();
        let again = Lock::acquire(dir.path()).unwrap();
        assert_eq!(again.replaced_stale, Some(4294967));
        drop(held);
        drop(again);
        assert!(!dir.path().join(LOCK_NAME).exists());
    }
}
