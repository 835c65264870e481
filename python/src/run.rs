//! Long calls without the GIL, interruptible: the work runs on its own thread while the caller's
//! thread wakes every 50 ms to let Python handle signals, so Ctrl-C raises `KeyboardInterrupt` at
//! once (the abandoned work finishes in the background and its result is dropped).

use pyo3::prelude::*;
use std::sync::mpsc;
use std::time::Duration;

/// Runs `work` off the GIL; a pending signal (Ctrl-C) ends the wait with its exception.
pub fn interruptible<T: Send + 'static>(py: Python<'_>, work: impl FnOnce() -> T + Send + 'static) -> PyResult<T> {
    let (send, receive) = mpsc::channel();
    std::thread::Builder::new()
        .name("scanrig-call".into())
        .spawn(move || {
            let _ = send.send(work());
        })
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(format!("could not start a thread: {e}")))?;
    let mut receive = receive;
    loop {
        // The receiver goes into the GIL-free wait and comes back with the answer (it is not Sync).
        let (answer, back) = py.detach(move || (receive.recv_timeout(Duration::from_millis(50)), receive));
        receive = back;
        match answer {
            Ok(result) => return Ok(result),
            Err(mpsc::RecvTimeoutError::Timeout) => py.check_signals()?,
            // The work panicked: a bug, said as one rather than a crash of the interpreter.
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                return Err(pyo3::exceptions::PyRuntimeError::new_err(
                    "scanrig: internal error (the computation panicked); please report it with the inputs",
                ));
            }
        }
    }
}
