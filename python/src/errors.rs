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
pub fn chain(e: &(dyn std::error::Error + 'static)) -> String {
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

/// A stage's error from a function whose keyword arguments `names` (as the command line spells
/// them) its hints may name: "give a smaller --spacing; --force keeps this remesh" is said as
/// "give a smaller spacing=; force=True keeps this remesh" ([`keywords`]).
pub fn stage_as<E: std::error::Error + 'static>(names: &'static [&'static str]) -> impl Fn(E) -> PyErr {
    move |e| StageError::new_err(keywords(&chain(&e), names))
}

/// `text` with each command-line option among `names` spelt as the Python keyword argument that
/// sets the same: with its value, `--samples-per-cell 0` as `samples_per_cell=0` and `--base open`
/// as `base='open'`; without one, `a smaller --spacing` as `a smaller spacing` (and `--force` as
/// `force=True`; `--memory-budget` is `memory_budget_gb`). Options not among `names` keep their
/// spelling: the function has no such argument.
pub fn keywords(text: &str, names: &[&str]) -> String {
    // The command line's word values (--base, --method) as Python strings.
    const WORDS: [&str; 5] = ["open", "closed", "flat", "fft", "adfft"];
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(at) = rest.find("--") {
        out.push_str(&rest[..at]);
        let after = &rest[at + 2..];
        let len =
            after.find(|c: char| !(c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-')).unwrap_or(after.len());
        let name = after[..len].trim_end_matches('-');
        rest = &after[name.len()..];
        if !names.contains(&name) {
            out.push_str(&format!("--{name}"));
            continue;
        }
        let keyword = match name {
            "force" => {
                out.push_str("force=True");
                continue;
            }
            "memory-budget" => "memory_budget_gb".to_string(),
            _ => name.replace('-', "_"),
        };
        out.push_str(&keyword);
        // Its value, where one follows: a number, or one of the command line's words.
        let Some(next) = rest.strip_prefix(' ') else { continue };
        let len = next.find(|c: char| c.is_whitespace() || matches!(c, ',' | ';' | ')' | ':')).unwrap_or(next.len());
        // A sentence's full stop is not the value's.
        let len = if next[..len].ends_with('.') { len - 1 } else { len };
        let value = &next[..len];
        // Finite numbers only: Python spells NaN and infinity otherwise.
        if value.parse::<f64>().is_ok_and(|v| v.is_finite()) {
            out.push_str(&format!("={value}"));
        } else if WORDS.contains(&value) {
            out.push_str(&format!("='{value}'"));
        } else {
            continue;
        }
        rest = &next[len..];
    }
    out.push_str(rest);
    out
}

/// What a reader could not keep, as Python `UserWarning`s (one per sentence, each naming the file):
/// the same sentences the command line prints, so nothing is dropped in silence here either.
pub fn warn_each(py: Python<'_>, warnings: &[String]) -> PyResult<()> {
    warn_each_as(py, warnings, &[])
}

/// [`warn_each`] from a function whose keyword arguments `names` the warnings may name ([`keywords`]):
/// a forced result's "(--force)" reads "(force=True)".
pub fn warn_each_as(py: Python<'_>, warnings: &[String], names: &[&str]) -> PyResult<()> {
    let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
    for w in warnings {
        let message = std::ffi::CString::new(keywords(w, names).replace('\0', " ")).expect("NULs replaced");
        PyErr::warn(py, &category, &message, 1)?;
    }
    Ok(())
}
