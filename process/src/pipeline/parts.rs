//! A processed folder's outputs carried between machines. A distributed run (the Python package's
//! `scanrig.distributed`, on Ray) processes each view on its own worker into a scratch folder
//! ([`super::ProcessParams::views`]), [`pack`]s what that wrote, and hands the pack back as a task's
//! result; the scan's own task [`adopt`]s every view's pack into the real output folder and then runs
//! `process_scan` there, which finds the views current (their records and content hashes hold) and
//! goes on to the scan stages. A task killed half-way wrote nothing outside its scratch folder, so
//! running it again (Ray's retry) neither loses nor duplicates anything.

use super::records::{RECORDS_NAME, Records, ScanMark};
use crate::Error;
use rig::folder_lock::{LOCK_NAME, Lock};
use std::path::{Component, Path};

/// One file of a pack: its path inside the output folder (`/`-separated) and its bytes.
pub type PackedFile = (String, Vec<u8>);

/// Every output `out` holds — the files and their records (`stages.json`) — but not the run's own
/// lock or report (the adopting run writes its own).
pub fn pack(out: &Path) -> Result<Vec<PackedFile>, Error> {
    let mut files = Vec::new();
    let mut stack = vec![out.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let entries = std::fs::read_dir(&dir).map_err(|e| rig::Error::io(&dir, e))?;
        for entry in entries {
            let path = entry.map_err(|e| rig::Error::io(&dir, e))?.path();
            if path.is_dir() {
                stack.push(path);
                continue;
            }
            let name = relative_name(out, &path);
            if name == LOCK_NAME || name == super::layout::REPORT {
                continue;
            }
            let bytes = std::fs::read(&path).map_err(|e| rig::Error::io(&path, e))?;
            files.push((name, bytes));
        }
    }
    // A pack is the same whatever order the file system lists a folder in.
    files.sort();
    Ok(files)
}

fn relative_name(root: &Path, path: &Path) -> String {
    let rel = path.strip_prefix(root).unwrap_or(path);
    rel.components().map(|c| c.as_os_str().to_string_lossy()).collect::<Vec<_>>().join("/")
}

/// Writes the packs' files into `out` (each atomically) and merges their records into its
/// `stages.json`, under `out`'s lock, once `out` is found to be the folder of the scan in `scan`
/// (a user's folder, or another scan's results, is refused before anything is written, as
/// `process` refuses it). Returns how many files were written. A name that would
/// leave `out` (absolute, or with `..`) is refused: a pack names files inside its folder only.
pub fn adopt(scan: &Path, out: &Path, packs: &[Vec<PackedFile>]) -> Result<usize, Error> {
    let mark = ScanMark::of_scan(scan, &rig::scan_folder::Manifest::read(scan)?);
    std::fs::create_dir_all(out).map_err(|e| rig::Error::io(out, e))?;
    let _lock = Lock::acquire(out)?;
    super::run::claim(out, &mark)?;
    let mut records = Records::open(out, false);
    records.set_scan(mark);
    let mut written = 0;
    for (name, bytes) in packs.iter().flatten() {
        let inside = Path::new(name).components().all(|c| matches!(c, Component::Normal(_)));
        if !inside || name.is_empty() {
            return Err(Error::Part { name: name.clone(), why: "not a path inside the output folder".into() });
        }
        if name == RECORDS_NAME {
            let theirs = Records::parse(bytes)
                .ok_or_else(|| Error::Part { name: name.clone(), why: "not a records file of this version".into() })?;
            records.merge(theirs);
            continue;
        }
        let path = out.join(name);
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| rig::Error::io(dir, e))?;
        }
        rig::write_atomic(&path, bytes)?;
        written += 1;
    }
    records.save()?;
    Ok(written)
}
