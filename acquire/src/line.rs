//! The byte link to a controller board: a serial port, a pseudo-terminal, or a recorder around one
//! (for golden transcripts). Lines are read one at a time with a deadline.

use std::io::{self, Read, Write};
use std::time::{Duration, Instant};

/// A bidirectional byte link with read timeouts.
pub trait Link: Read + Write + Send {
    /// Sets how long one `read` may block.
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()>;
}

impl Link for Box<dyn serialport::SerialPort> {
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        self.set_timeout(timeout).map_err(io::Error::other)
    }
}

#[cfg(unix)]
impl Link for serialport::TTYPort {
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        serialport::SerialPort::set_timeout(self, timeout).map_err(io::Error::other)
    }
}

/// A link that keeps a copy of every byte written (the host's side of a transcript).
pub struct Recorder<L> {
    /// The wrapped link.
    pub inner: L,
    /// Everything written so far.
    pub sent: std::sync::Arc<std::sync::Mutex<Vec<u8>>>,
}

impl<L: Link> Read for Recorder<L> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        self.inner.read(buf)
    }
}

impl<L: Link> Write for Recorder<L> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.sent.lock().expect("recorder lock").extend_from_slice(&buf[..n]);
        Ok(n)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

impl<L: Link> Link for Recorder<L> {
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        self.inner.set_read_timeout(timeout)
    }
}

/// Reads bytes into lines (split at `\r` or `\n`, empty lines skipped), keeping what follows a line
/// for the next call.
#[derive(Default)]
pub struct LineReader {
    pending: Vec<u8>,
}

/// Why no line came.
#[derive(Debug)]
pub enum ReadLineError {
    /// The deadline passed.
    Timeout,
    /// The link failed (closed, unplugged).
    Io(io::Error),
}

impl LineReader {
    /// The next non-empty line, waiting at most `timeout` in all.
    pub fn read_line(&mut self, link: &mut dyn Link, timeout: Duration) -> Result<String, ReadLineError> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(line) = self.take_line() {
                return Ok(line);
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(ReadLineError::Timeout);
            }
            link.set_read_timeout(left.min(Duration::from_millis(100))).map_err(ReadLineError::Io)?;
            let mut buf = [0u8; 256];
            match link.read(&mut buf) {
                Ok(0) => std::thread::sleep(Duration::from_millis(5)),
                Ok(n) => self.pending.extend_from_slice(&buf[..n]),
                Err(e) if matches!(e.kind(), io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock) => {}
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(ReadLineError::Io(e)),
            }
        }
    }

    /// Drops whatever was received but not read (after a resync).
    pub fn clear(&mut self) {
        self.pending.clear();
    }

    fn take_line(&mut self) -> Option<String> {
        while let Some(end) = self.pending.iter().position(|&b| b == b'\r' || b == b'\n') {
            let line: Vec<u8> = self.pending.drain(..=end).collect();
            let text = String::from_utf8_lossy(&line[..line.len() - 1]).trim().to_string();
            if !text.is_empty() {
                return Some(text);
            }
        }
        None
    }
}
