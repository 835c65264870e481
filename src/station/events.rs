//! The station's one event stream (server-sent events): progress, each view as it lands, faults.
//! Every open page gets every event; a page that went away is dropped at the next event.

use serde_json::Value;
use std::io::Write;
use std::sync::Mutex;
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender, TrySendError, sync_channel};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// Milliseconds since the Unix epoch: the time stamps events carry, so a page on the same machine
/// measures how long an event took to reach its screen.
pub fn now_ms() -> f64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0.0, |d| d.as_secs_f64() * 1e3)
}

/// Events a page may fall behind by before it is dropped (a scan of 3,600 views sends two a view).
const BACKLOG: usize = 8192;

/// Subscribers, and the last events of each kind a page that opens late needs (the job's state).
#[derive(Default)]
pub struct Bus {
    subscribers: Mutex<Vec<SyncSender<String>>>,
    last_state: Mutex<Option<String>>,
}

impl Bus {
    /// Sends `data` as an event of `kind` to every open page.
    pub fn send(&self, kind: &str, data: Value) {
        let text = format!("event: {kind}\ndata: {data}\n\n");
        if kind == "state" {
            *self.last_state.lock().unwrap_or_else(|e| e.into_inner()) = Some(text.clone());
        }
        // A page that stopped reading falls behind and is dropped (its stream then ends), rather
        // than every event piling up for it.
        self.subscribers.lock().unwrap_or_else(|e| e.into_inner()).retain(|s| {
            !matches!(s.try_send(text.clone()), Err(TrySendError::Full(_) | TrySendError::Disconnected(_)))
        });
    }

    /// A new subscriber, given the last state event first.
    pub fn subscribe(&self) -> Receiver<String> {
        let (tx, rx) = sync_channel(BACKLOG);
        if let Some(s) = self.last_state.lock().unwrap_or_else(|e| e.into_inner()).clone() {
            let _ = tx.send(s);
        }
        self.subscribers.lock().unwrap_or_else(|e| e.into_inner()).push(tx);
        rx
    }
}

/// Streams events to one page until it goes away: the response head, then each event as it comes
/// (flushed at once: a buffered event would arrive late), and a `ping` event every `ping`, however
/// busy the stream: the controlling page answers each (POST /api/alive), which is how the station
/// knows it is still there (a page asleep keeps its stream open, and writes to it go on succeeding
/// until the socket's buffer fills). Pings also keep proxies and the browser from closing the
/// connection, and a page that closed is noticed at the next write (its control released).
pub fn stream(mut out: Box<dyn Write + Send>, events: Receiver<String>, ping: Duration) {
    let head = "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\n\
                X-Content-Type-Options: nosniff\r\nConnection: close\r\n\r\nretry: 1000\n\n";
    if out.write_all(head.as_bytes()).and_then(|_| out.flush()).is_err() {
        return;
    }
    let ping_text = "event: ping\ndata: {}\n\n";
    let mut pinged = Instant::now();
    loop {
        let text = match events.recv_timeout(ping.saturating_sub(pinged.elapsed())) {
            Ok(t) => t,
            Err(RecvTimeoutError::Timeout) => String::new(),
            Err(RecvTimeoutError::Disconnected) => return,
        };
        let mut write = |t: &str| out.write_all(t.as_bytes()).and_then(|_| out.flush());
        if !text.is_empty() && write(&text).is_err() {
            return;
        }
        if pinged.elapsed() >= ping {
            if write(ping_text).is_err() {
                return;
            }
            pinged = Instant::now();
        }
    }
}
