//! Reading input files safely: only regular files, and never more than they hold.
//!
//! A FIFO given in place of a manifest or a frame would block a reader for ever, and a link to
//! `/dev/zero` would grow memory without end: every reader of this crate (meshes, clouds, images, rigs,
//! manifests, scanner configurations) goes through [`read_regular`], which follows links, refuses
//! anything that is not a regular file (naming the path and what it is), and reads at most the size the
//! file had when it was opened.

use crate::error::Error;
use std::fs::File;
use std::io::Read;
use std::path::Path;

/// What a path that is not a regular file is, for the message.
fn kind(meta: &std::fs::Metadata) -> &'static str {
    let t = meta.file_type();
    if t.is_dir() {
        return "a folder";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    "not a regular file"
}

fn not_a_file(path: &Path, meta: &std::fs::Metadata) -> Error {
    let what = kind(meta);
    let msg =
        if what == "not a regular file" { "not a regular file".to_string() } else { format!("is {what}, not a file") };
    Error::io(path, std::io::Error::new(std::io::ErrorKind::InvalidInput, msg))
}

/// Opens `path` for reading if it is a regular file (after following links), with its size in bytes.
/// A FIFO, a device, a socket or a folder is refused before it is opened, so nothing blocks.
pub fn open_regular(path: &Path) -> Result<(File, u64), Error> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(not_a_file(path, &meta));
    }
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    // The path may have been replaced between the check and the open: check what was opened.
    let meta = file.metadata().map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(not_a_file(path, &meta));
    }
    Ok((file, meta.len()))
}

/// Reads a whole regular file (see [`open_regular`]), at most the size it had when opened, and refuses one
/// larger than `max_bytes` where given (naming both sizes) before reading it.
pub fn read_regular(path: &Path, max_bytes: Option<u64>) -> Result<Vec<u8>, Error> {
    let (file, len) = open_regular(path)?;
    if let Some(max) = max_bytes
        && len > max
    {
        let msg = format!("the file has {len} bytes, more than the {max} this input may have");
        return Err(Error::io(path, std::io::Error::new(std::io::ErrorKind::InvalidData, msg)));
    }
    let mut out = Vec::with_capacity(usize::try_from(len).unwrap_or(0).min(1 << 30));
    file.take(len).read_to_end(&mut out).map_err(|e| Error::io(path, e))?;
    Ok(out)
}

/// Reads a regular file as UTF-8 text (see [`read_regular`]).
pub fn read_regular_to_string(path: &Path, max_bytes: Option<u64>) -> Result<String, Error> {
    let bytes = read_regular(path, max_bytes)?;
    String::from_utf8(bytes).map_err(|e| {
        let msg = format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to());
        Error::io(path, std::io::Error::new(std::io::ErrorKind::InvalidData, msg))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_regular_file_reads_whole_and_a_folder_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        std::fs::write(&p, b"hello").unwrap();
        assert_eq!(read_regular(&p, None).unwrap(), b"hello");
        let e = read_regular(&p, Some(3)).unwrap_err().to_string();
        assert!(e.contains("5 bytes") && e.contains("a.txt"), "{e}");
        let e = read_regular(dir.path(), None).unwrap_err().to_string();
        assert!(e.contains("is a folder, not a file"), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn a_link_to_dev_zero_is_refused_at_once() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("z.ply");
        std::os::unix::fs::symlink("/dev/zero", &p).unwrap();
        let e = read_regular(&p, None).unwrap_err().to_string();
        assert!(e.contains("z.ply") && e.contains("character device, not a file"), "{e}");
    }
}
