//! scanrig from Python (PyO3): the library's stages as functions on NumPy arrays, with the same
//! defaults and messages as the command line. No algorithm lives here — each function checks its
//! arrays, releases the GIL, calls the library, and hands the result back as arrays and a report
//! dict with the keys of the JSON reports. The Python package `scanrig` (python/scanrig) wraps this
//! module `scanrig._scanrig` with dataclasses and the `ScanrigError` hierarchy.

mod arrays;
mod calibrate;
mod capture;
mod distributed;
mod errors;
mod files;
mod grids;
mod run;
mod stages;

use pyo3::prelude::*;

/// The compiled half of the `scanrig` package.
#[pymodule]
fn _scanrig(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    files::register(m)?;
    capture::register(m)?;
    calibrate::register(m)?;
    distributed::register(m)?;
    grids::register(m)?;
    stages::register(m)?;
    m.add_function(wrap_pyfunction!(arrays::_read_address, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
