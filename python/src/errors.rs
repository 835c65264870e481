//! The `ScanrigError` hierarchy: every failure of the library reaches Python as one of these, with
//! the message the command line prints (its causes joined by ": ").

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(_scanrig, ScanrigError, PyException, "Any error scanrig reports.");
create_exception!(_scanrig, FileError, ScanrigError, "A file that cannot be read, parsed or written.");
create_exception!(
    _scanrig,
    StageError,
    ScanrigError,
    "A stage that refused its input or found its result implausible."
);

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("ScanrigError", py.get_type::<ScanrigError>())?;
    m.add("FileError", py.get_type::<FileError>())?;
    m.add("StageError", py.get_type::<StageError>())?;
    Ok(())
}

/// An error and its causes, as the command line prints them.
fn chain(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        let more = s.to_string();
        if !text.contains(&more) {
            text.push_str(": ");
            text.push_str(&more);
        }
        source = s.source();
    }
    text
}

/// A file error (reading, parsing, writing).
pub fn file(e: rig::Error) -> PyErr {
    FileError::new_err(chain(&e))
}

/// A stage's error.
pub fn stage(e: impl std::error::Error + 'static) -> PyErr {
    StageError::new_err(chain(&e))
}

/// What a reader could not keep, as Python `UserWarning`s (one per sentence, each naming the file):
/// the same sentences the command line prints, so nothing is dropped in silence here either.
pub fn warn_each(py: Python<'_>, warnings: &[String]) -> PyResult<()> {
    let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
    for w in warnings {
        let message = std::ffi::CString::new(w.replace('\0', " ")).expect("NULs replaced");
        PyErr::warn(py, &category, &message, 1)?;
    }
    Ok(())
}
