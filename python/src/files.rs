//! Reading files without holding the GIL and without deafness to Ctrl-C: a FIFO without a
//! writer, a slow network file or a device blocks only the thread that reads it.

use pyo3::prelude::*;
use std::time::Duration;

/// How often a waiting read looks for a signal (Ctrl-C).
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// Runs `read` on a thread of its own while the calling thread, without the GIL, waits for it and
/// looks for signals: a `KeyboardInterrupt` (or any exception a signal handler raises) is the
/// call's error at once. The reading thread is then left to finish on its own (a read blocked in
/// the kernel, as the opening of a FIFO that has no writer, cannot be cancelled); what it reads
/// is dropped.
pub(crate) fn read_interruptibly<T: Send + 'static>(
    py: Python<'_>,
    read: impl FnOnce() -> T + Send + 'static,
) -> PyResult<T> {
    let (sent, received) = std::sync::mpsc::channel();
    std::thread::Builder::new()
        .name("kinechain-read".into())
        .spawn(move || {
            let _ = sent.send(read());
        })
        .map_err(|e| {
            crate::errors::Error::new_err(format!("cannot start a thread to read: {e}"))
        })?;
    py.detach(move || {
        loop {
            match received.recv_timeout(SIGNAL_POLL) {
                Ok(value) => return Ok(value),
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                    Python::attach(|py| py.check_signals())?;
                }
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                    return Err(crate::errors::Error::new_err(
                        "the read stopped without a result",
                    ));
                }
            }
        }
    })
}
