//! Long calls without the GIL, interruptible: the work runs on a thread of the library's own rayon
//! pool while the caller's thread wakes every 50 ms to let Python handle signals, so Ctrl-C raises
//! `KeyboardInterrupt` at once (the abandoned work finishes in the background and its result is
//! dropped). A pool thread rather than a new one per call: the stage's parallel loops then share
//! that thread with the pool (two busy threads on two cores, as when Rust calls the stage), and its
//! allocator arena is warm from earlier calls.

use pyo3::prelude::*;
use std::panic::AssertUnwindSafe;
use std::sync::mpsc;
use std::time::Duration;

/// Runs `work` off the GIL; a pending signal (Ctrl-C) ends the wait with its exception.
pub fn interruptible<T: Send + 'static>(py: Python<'_>, work: impl FnOnce() -> T + Send + 'static) -> PyResult<T> {
    let (send, receive) = mpsc::channel();
    // A panic is caught here: unwinding out of a rayon::spawn closure would abort the interpreter.
    rayon::spawn(move || {
        let _ = send.send(std::panic::catch_unwind(AssertUnwindSafe(work)));
    });
    let mut receive = receive;
    loop {
        // The receiver goes into the GIL-free wait and comes back with the answer (it is not Sync).
        let (answer, back) = py.detach(move || (receive.recv_timeout(Duration::from_millis(50)), receive));
        receive = back;
        match answer {
            Ok(Ok(result)) => return Ok(result),
            Err(mpsc::RecvTimeoutError::Timeout) => py.check_signals()?,
            // The work panicked: a bug, said as one rather than a crash of the interpreter.
            Ok(Err(_)) | Err(mpsc::RecvTimeoutError::Disconnected) => {
                return Err(pyo3::exceptions::PyRuntimeError::new_err(
                    "scanrig: internal error (the computation panicked); please report it with the inputs",
                ));
            }
        }
    }
}
