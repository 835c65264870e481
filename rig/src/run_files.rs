//! Which files a run may write, held in one place: every writer in scanrig goes through
//! [`write_atomic`](crate::write_atomic), and every reader of this crate through one read function, so
//! the rules below hold for every subcommand without a check of its own.
//!
//! While a [`Run`](crate::run_files::Run) is open (the command line opens one per command), a write is refused when its path
//! - is a file the run has read (an input), unless the run wrote that file first;
//! - lies inside a folder the run reads as input ([`input_folder`](crate::run_files::input_folder)), unless it also lies inside
//!   one of the run's own output folders ([`workspace`](crate::run_files::workspace)), such as `process`'s `processed/`
//!   (which sits inside the scan folder it reads).
//!
//! Files are compared by device and inode where they exist, so a link or another spelling of the
//! same path is caught too. Outside a run (the library used from Rust, the Python bindings) nothing is
//! tracked: a notebook may read a cloud and write it back on purpose.
//!
//! Temporary files and folders are named by [`temp_sibling`](crate::run_files::temp_sibling): a random name that starts with `.` and
//! holds `scanrig-tmp`, created exclusively, so it is never a name a user owns and removing it on
//! failure removes only what the run made.

use crate::error::Error;
use std::collections::HashSet;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// What an open run has read, written and been told.
#[derive(Default)]
struct State {
    /// Files read, by (device, inode).
    read: HashSet<(u64, u64)>,
    /// Files written, by (device, inode) after the write.
    written: HashSet<(u64, u64)>,
    /// Folders read as input (canonical).
    input_dirs: Vec<PathBuf>,
    /// Folders the run writes its results into (canonical).
    workspaces: Vec<PathBuf>,
    /// Files the run reads and then rewrites on purpose (canonical).
    updates: Vec<PathBuf>,
}

/// One per process: runs are the command line's, one command at a time.
static STATE: Mutex<Option<State>> = Mutex::new(None);

fn with_state<R>(f: impl FnOnce(&mut State) -> R) -> Option<R> {
    let mut guard = STATE.lock().unwrap_or_else(|p| p.into_inner());
    guard.as_mut().map(f)
}

/// An open run: while it lives, reads and writes are tracked and writes checked (module doc).
/// Dropping it ends the tracking.
#[derive(Debug)]
pub struct Run {
    _private: (),
}

impl Run {
    /// Opens the run (a second open run in the same process replaces the first's record).
    pub fn open() -> Run {
        *STATE.lock().unwrap_or_else(|p| p.into_inner()) = Some(State::default());
        Run { _private: () }
    }
}

impl Drop for Run {
    fn drop(&mut self) {
        *STATE.lock().unwrap_or_else(|p| p.into_inner()) = None;
    }
}

/// Declares, for the open run if any, a folder it reads as input: nothing is written inside it, except inside a
/// [`workspace`].
pub fn input_folder(dir: &Path) {
    if let Ok(c) = dir.canonicalize() {
        with_state(|s| s.input_dirs.push(c));
    }
}

/// Declares, for the open run if any, a folder it writes its results into (created if missing): reads inside it are
/// the run's own earlier outputs, not inputs, and may be replaced.
pub fn workspace(dir: &Path) -> Result<(), Error> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let c = dir.canonicalize().map_err(|e| Error::io(dir, e))?;
    with_state(|s| s.workspaces.push(c));
    Ok(())
}

/// Declares, for the open run if any, a file it reads and then rewrites on purpose: `calibrate … -o rig.toml` adds its
/// step to the rig already there.
pub fn updates(file: &Path) {
    if let Some(c) = canonical_target(file) {
        with_state(|s| s.updates.push(c));
    }
}

fn file_id(path: &Path) -> Option<(u64, u64)> {
    std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

/// `path` with its folder made canonical (the file itself need not exist).
fn canonical_target(path: &Path) -> Option<PathBuf> {
    let parent = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    Some(parent.canonicalize().ok()?.join(path.file_name()?))
}

fn in_workspace(s: &State, target: &Path) -> bool {
    s.workspaces.iter().any(|w| target.starts_with(w))
}

/// Records that the run read `path` (called by this crate's one read function).
pub(crate) fn note_read(path: &Path) {
    with_state(|s| {
        let inside = canonical_target(path).is_some_and(|t| in_workspace(s, &t));
        if !inside && let Some(id) = file_id(path) {
            s.read.insert(id);
        }
    });
}

/// Records that the run wrote `path` (called after every successful write).
pub(crate) fn note_written(path: &Path) {
    with_state(|s| {
        if let Some(id) = file_id(path) {
            s.written.insert(id);
        }
    });
}

/// Why writing `path` now would lose something of the user's, if it would (module doc).
pub fn refusal(path: &Path) -> Option<String> {
    with_state(|s| {
        let target = canonical_target(path);
        let updated = target.as_ref().is_some_and(|t| s.updates.contains(t));
        if let Some(id) = file_id(path)
            && s.read.contains(&id)
            && !s.written.contains(&id)
            && !updated
        {
            return Some("it is an input of this run; write the result to another file".to_string());
        }
        let target = target?;
        if in_workspace(s, &target) {
            return None;
        }
        s.input_dirs.iter().find(|d| target.starts_with(d)).map(|d| {
            format!("it is inside {}, a folder this run reads as input; write the result elsewhere", d.display())
        })
    })
    .flatten()
}

/// Fails, naming the path and why, when writing `path` now would replace an input (module doc).
pub fn check_write(path: &Path) -> Result<(), Error> {
    match refusal(path) {
        Some(why) => Err(Error::Refused { path: path.to_path_buf(), why }),
        None => Ok(()),
    }
}

/// A new, empty temporary file beside `target`, named so no user could own it (`.NAME.scanrig-tmp…`,
/// random, created exclusively). Removed when dropped unless persisted.
pub fn temp_sibling(target: &Path) -> Result<tempfile::NamedTempFile, Error> {
    let dir = target.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = target.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    // 0666 less the umask, as a plain create gives: tempfile's own default, 0600, would leave every
    // result unreadable to other users once renamed into place.
    tempfile::Builder::new()
        .prefix(&format!(".{name}.scanrig-tmp"))
        .permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666))
        .tempfile_in(dir)
        .map_err(|e| Error::io(target, e))
}

/// A new, empty temporary folder beside `target` (same naming as [`temp_sibling`]); removed with its
/// contents when dropped unless kept.
pub fn temp_folder_beside(target: &Path) -> Result<tempfile::TempDir, Error> {
    let dir = target.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = target.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    tempfile::Builder::new().prefix(&format!(".{name}.scanrig-tmp")).tempdir_in(dir).map_err(|e| Error::io(target, e))
}

/// Reads a whole regular file, naming it in the error: a FIFO, a device or a folder is refused, and no
/// more than the file's size is read (see [`crate::input::read_regular`]).
///
/// While a run is open the file counts as its input (this module).
pub(crate) fn read_bytes(path: &Path) -> Result<Vec<u8>, Error> {
    let bytes = crate::input::read_regular(path, None)?;
    note_read(path);
    Ok(bytes)
}

/// The first `max` bytes of a regular file (all of it if shorter), as [`read_bytes`] reads a whole
/// one: a header or a leading comment without reading a cloud of gigabytes behind it.
pub(crate) fn read_prefix(path: &Path, max: u64) -> Result<Vec<u8>, Error> {
    use std::io::Read;
    let (file, len) = crate::input::open_regular(path)?;
    let mut bytes = Vec::with_capacity(len.min(max) as usize);
    file.take(max).read_to_end(&mut bytes).map_err(|e| Error::io(path, e))?;
    note_read(path);
    Ok(bytes)
}

/// Writes a file atomically: into a temporary sibling of a name no user owns, then renamed over the
/// target, so a crash never leaves a half-written file where a complete one is expected. While a run
/// is open, a target that is one of its inputs, or inside a folder it reads, is refused
/// (this module).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    use std::io::Write;
    check_write(path)?;
    let mut tmp = temp_sibling(path)?;
    let result = (|| {
        tmp.as_file_mut().write_all(bytes)?;
        tmp.as_file().sync_all()?;
        tmp.persist(path).map_err(|e| e.error)
    })();
    result.map_err(|e| Error::io(path, e))?;
    note_written(path);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One test: the run's record is one per process, and these steps must not interleave with
    /// another test's run.
    #[test]
    fn a_run_refuses_its_inputs_and_input_folders_but_not_its_own_files() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("c.ply");
        std::fs::write(&input, b"x").unwrap();
        let frames = dir.path().join("frames");
        std::fs::create_dir(&frames).unwrap();
        let link = dir.path().join("link.ply");
        std::os::unix::fs::symlink(&input, &link).unwrap();

        // No run: nothing tracked.
        note_read(&input);
        assert!(refusal(&input).is_none());

        let run = Run::open();
        note_read(&input);
        input_folder(&frames);
        let why = check_write(&input).unwrap_err().to_string();
        assert!(why.contains("c.ply") && why.contains("input of this run"), "{why}");
        assert!(refusal(&link).is_some(), "another name for the input");
        let why = check_write(&frames.join("map.npy")).unwrap_err().to_string();
        assert!(why.contains("frames") && why.contains("reads as input"), "{why}");
        assert!(refusal(&dir.path().join("out.ply")).is_none());

        // A workspace inside the input folder may be written, and its files read and replaced.
        let ws = frames.join("processed");
        workspace(&ws).unwrap();
        let own = ws.join("mesh.ply");
        std::fs::write(&own, b"y").unwrap();
        note_read(&own);
        assert!(refusal(&own).is_none());

        // A file the run wrote, then read, may be written again.
        let out = dir.path().join("out.ply");
        std::fs::write(&out, b"z").unwrap();
        note_written(&out);
        note_read(&out);
        assert!(refusal(&out).is_none());

        // A file updated on purpose.
        updates(&input);
        assert!(refusal(&input).is_none());
        drop(run);
        assert!(refusal(&input).is_none(), "tracking ends with the run");

        let t = temp_sibling(&input).unwrap();
        let name = t.path().file_name().unwrap().to_string_lossy().into_owned();
        assert!(name.starts_with(".c.ply.scanrig-tmp"), "{name}");
    }
}
