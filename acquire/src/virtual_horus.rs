//! A virtual Horus 0.2 board on a pseudo-terminal: the same wire protocol as the firmware (see
//! [`crate::horus`]), a platter angle and lasers that the simulator camera can look at, and faults
//! real rigs have — dropped and garbled replies, `error:` replies, slow `ok`s, an unplugged cable —
//! injected on purpose, so the driver and the scan session are tested without hardware.

use crate::horus::GREETING;
use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

/// What the virtual board is doing, shared with whoever watches it (the simulator camera).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BoardState {
    /// Platter angle (degrees) relative to the last `G50`.
    pub angle_deg: f64,
    /// Lasers on (`T1` … `T4` as 0 … 3).
    pub lasers: [bool; 4],
    /// Stepper energised.
    pub motor: bool,
    /// Feed rate, once set.
    pub feed: Option<f64>,
    /// Acceleration last set by `$120`.
    pub acceleration: Option<f64>,
    /// Every command line received, as the firmware normalised it (upper case, no spaces).
    pub received: Vec<String>,
}

/// Faults to inject; command numbers count received command lines from 1.
#[derive(Debug, Clone, PartialEq)]
pub struct Faults {
    /// The greeting line (a wrong one imitates another firmware or a wrong baud rate).
    pub greeting: String,
    /// Commands whose reply is never sent.
    pub drop_reply: Vec<usize>,
    /// Commands answered with a garbled line instead of `ok`.
    pub garble: Vec<usize>,
    /// Commands answered `error: <text>`.
    pub error: Vec<(usize, String)>,
    /// Delay before every reply.
    pub slow: Duration,
    /// After this many commands the board goes silent and the line hangs up (an unplugged cable).
    pub unplug_after: Option<usize>,
    /// Moves take their real time at the feed rate (off: instant).
    pub real_time_moves: bool,
}

impl Default for Faults {
    fn default() -> Self {
        Faults {
            greeting: format!("{GREETING} ['$' for help]"),
            drop_reply: Vec::new(),
            garble: Vec::new(),
            error: Vec::new(),
            slow: Duration::ZERO,
            unplug_after: None,
            real_time_moves: false,
        }
    }
}

/// A running virtual board.
pub struct VirtualBoard {
    /// The pseudo-terminal to open as the board's serial port.
    pub port: String,
    /// The board's state.
    pub state: Arc<Mutex<BoardState>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    // Held open so the terminal stays up until the host opens it by name.
    _slave: serialport::TTYPort,
}

impl VirtualBoard {
    /// Starts a board with `faults` on a new pseudo-terminal.
    pub fn start(faults: Faults) -> std::io::Result<VirtualBoard> {
        let (mut master, slave) = serialport::TTYPort::pair().map_err(std::io::Error::other)?;
        let port = serialport::SerialPort::name(&slave)
            .ok_or_else(|| std::io::Error::other("the pseudo-terminal has no name"))?;
        serialport::SerialPort::set_timeout(&mut master, Duration::from_millis(20)).map_err(std::io::Error::other)?;
        let state = Arc::new(Mutex::new(BoardState::default()));
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (state, stop) = (state.clone(), stop.clone());
            std::thread::spawn(move || serve(master, faults, state, stop))
        };
        Ok(VirtualBoard { port, state, stop, thread: Some(thread), _slave: slave })
    }

    /// Pulls the cable out now: the board stops answering and its end of the line hangs up, as
    /// [`Faults::unplug_after`] does at a given command (for faults injected by hand, mid-scan).
    pub fn unplug(&self) {
        self.stop.store(true, Ordering::Relaxed);
    }

    /// True once [`VirtualBoard::unplug`] pulled the cable.
    pub fn unplugged(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// A copy of the board's state.
    pub fn snapshot(&self) -> BoardState {
        self.state.lock().expect("board state").clone()
    }
}

impl Drop for VirtualBoard {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn serve(mut link: serialport::TTYPort, faults: Faults, state: Arc<Mutex<BoardState>>, stop: Arc<AtomicBool>) {
    let mut line = Vec::new();
    let mut count = 0usize;
    let mut buf = [0u8; 256];
    while !stop.load(Ordering::Relaxed) {
        let n = match link.read(&mut buf) {
            Ok(n) => n,
            Err(e) if matches!(e.kind(), std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock) => continue,
            Err(_) => {
                std::thread::sleep(Duration::from_millis(20));
                continue;
            }
        };
        for &b in &buf[..n] {
            match b {
                0x18 => {
                    line.clear();
                    // grbl forgets its modal feed on reset; the position stays.
                    state.lock().expect("board state").feed = None;
                    let _ = link.write_all(format!("\r\n{}\r\n", faults.greeting).as_bytes());
                }
                b'?' => {
                    let a = state.lock().expect("board state").angle_deg;
                    let _ = link
                        .write_all(format!("<Idle,MPos:{a:.3},0.000,0.000,WPos:{a:.3},0.000,0.000>\r\n").as_bytes());
                }
                b'!' | b'~' => {}
                b'\r' | b'\n' => {
                    let text = normalise(&line);
                    line.clear();
                    if text.is_empty() {
                        continue;
                    }
                    count += 1;
                    if faults.unplug_after.is_some_and(|n| count > n) {
                        // The cable is out: nothing more is read or written; the host's end hangs up.
                        return;
                    }
                    let reply = execute(&text, &state, faults.real_time_moves);
                    std::thread::sleep(faults.slow);
                    if faults.drop_reply.contains(&count) {
                        continue;
                    }
                    let reply = if faults.garble.contains(&count) {
                        vec!["o\u{fffd}k#".to_string()]
                    } else if let Some((_, t)) = faults.error.iter().find(|(c, _)| *c == count) {
                        vec![format!("error: {t}")]
                    } else {
                        reply
                    };
                    for r in reply {
                        let _ = link.write_all(format!("{r}\r\n").as_bytes());
                    }
                }
                _ if line.len() < 80 => line.push(b),
                _ => {} // the firmware's line buffer is 80 characters
            }
        }
    }
}

/// As the firmware reads a line: spaces dropped, upper case, `( … )` comments removed.
fn normalise(raw: &[u8]) -> String {
    let mut out = String::new();
    let mut comment = false;
    for &b in raw {
        match b {
            b'(' => comment = true,
            b')' => comment = false,
            _ if comment || b.is_ascii_whitespace() => {}
            _ => out.push(b.to_ascii_uppercase() as char),
        }
    }
    out
}

/// A number after a letter in a normalised line (`G1X90F200` → X: 90).
fn word(text: &str, letter: char) -> Option<f64> {
    let i = text.find(letter)?;
    let rest = &text[i + 1..];
    let end = rest.find(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-')).unwrap_or(rest.len());
    rest[..end].parse().ok()
}

/// Runs one command; the reply lines.
fn execute(text: &str, state: &Mutex<BoardState>, real_time: bool) -> Vec<String> {
    let ok = vec!["ok".to_string()];
    let mut s = state.lock().expect("board state");
    s.received.push(text.to_string());
    let laser = |s: &mut BoardState, on: bool| match word(text, 'T').map(|t| t as usize) {
        Some(t @ 1..=4) => {
            s.lasers[t - 1] = on;
            ok.clone()
        }
        _ => vec!["error: Invalid gcode ID:70".to_string()],
    };
    if let Some(rest) = text.strip_prefix("$120=") {
        return match rest.parse::<f64>() {
            Ok(a) => {
                s.acceleration = Some(a);
                ok
            }
            Err(_) => vec!["error: Bad number format".into()],
        };
    }
    if text == "$$" {
        return vec!["$120=".to_string() + &s.acceleration.unwrap_or(180.0).to_string(), "ok".into()];
    }
    if text.starts_with("G1") && !text.starts_with("G1X") && !text.starts_with("G1F") {
        return vec!["error: Unsupported command".into()];
    }
    if text.starts_with("G1") {
        if let Some(f) = word(text, 'F') {
            s.feed = Some(f);
        }
        if let Some(x) = word(text, 'X') {
            let Some(feed) = s.feed else { return vec!["error: Undefined feed rate".into()] };
            let travel = (x - s.angle_deg).abs() / feed.max(1e-3);
            s.angle_deg = x;
            if real_time {
                drop(s);
                std::thread::sleep(Duration::from_secs_f64(travel.min(60.0)));
            }
        }
        return ok;
    }
    match text {
        "G50" => {
            s.angle_deg = 0.0;
            ok
        }
        "M17" => {
            s.motor = true;
            ok
        }
        "M18" => {
            s.motor = false;
            ok
        }
        _ if text.starts_with("M71") => laser(&mut s, true),
        _ if text.starts_with("M70") => laser(&mut s, false),
        _ if text.starts_with("M50") => vec!["0".into(), "ok".into()],
        _ => vec!["error: Unsupported command".into()],
    }
}
