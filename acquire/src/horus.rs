//! The Horus 0.2 firmware dialect (bq Ciclop boards; a grbl 0.9 fork) and its driver. Everything
//! about the wire format lives here: the command spellings, the greeting, the reply forms, the host
//! sequence the reference host software uses (the team's notes on device wire formats are in
//! `PROTOCOLS.md` of the shared folder beside the repository, not in it). A second dialect
//! (FabScanPi) would sit beside this module behind the same [`Turntable`] trait.
//!
//! One line is sent, then exactly one reply line is read (`ok` or `error: <text>`): the firmware's
//! receive buffer is 128 bytes, so the host never streams. Every G/M command waits for motion to
//! finish before replying, so `ok` after `G1 X…` means the platter is there.

use crate::line::{LineReader, Link, ReadLineError};
use crate::turntable::{
    ACCELERATION_RANGE_DEG_PER_S2, MAX_ANGLE_DEG, SPEED_RANGE_DEG_PER_S, Turntable, TurntableError, in_range,
};
use std::time::Duration;

/// Soft reset (Ctrl-X): the firmware restarts and greets again.
pub const SOFT_RESET: u8 = 0x18;
/// The greeting's marker of the supported firmware.
pub const GREETING: &str = "Horus 0.2";
/// Lasers the board drives (`T1` … `T4`).
pub const LASERS: usize = 4;

/// A command line of the dialect, without its line end.
pub fn command(c: &Command) -> String {
    match c {
        Command::MoveTo(deg) => format!("G1X{}", number(*deg)),
        Command::Feed(f) => format!("G1F{}", number(*f)),
        Command::Zero => "G50".into(),
        Command::Motor(true) => "M17".into(),
        Command::Motor(false) => "M18".into(),
        Command::Laser(i, true) => format!("M71T{}", i + 1),
        Command::Laser(i, false) => format!("M70T{}", i + 1),
        Command::Acceleration(a) => format!("$120={}", number(*a)),
    }
}

/// What the host asks of the board.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Command {
    /// `G1 X<deg>`: absolute move.
    MoveTo(f64),
    /// `G1 F<deg/s>`: feed rate.
    Feed(f64),
    /// `G50`: the current position is zero.
    Zero,
    /// `M17` / `M18`.
    Motor(bool),
    /// `M71 T<n>` / `M70 T<n>` for 0-based laser `n − 1`.
    Laser(usize, bool),
    /// `$120=<deg/s²>`.
    Acceleration(f64),
}

/// A number as the host writes it: up to four decimals, no trailing zeros (`90`, `0.45`, `1.35`,
/// not `1.3500000000000001`, which cumulative steps would otherwise print).
pub fn number(v: f64) -> String {
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

/// A reply line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Reply {
    /// `ok`.
    Ok,
    /// `error: <text>`.
    Error(String),
    /// The greeting (after a reset).
    Greeting(String),
    /// Anything else.
    Other(String),
}

/// Classifies one reply line.
pub fn parse_reply(line: &str) -> Reply {
    let t = line.trim();
    if t.eq_ignore_ascii_case("ok") {
        Reply::Ok
    } else if let Some(rest) = t.strip_prefix("error:") {
        Reply::Error(rest.trim().to_string())
    } else if t.starts_with("Horus") || t.starts_with("Grbl") {
        Reply::Greeting(t.to_string())
    } else {
        Reply::Other(t.to_string())
    }
}

/// Timeouts and retries of the driver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HorusOptions {
    /// Wait for the greeting (opening the port resets an Arduino Uno: ~2 s).
    pub greeting_timeout: Duration,
    /// Wait for the reply to a command that does not move the platter.
    pub reply_timeout: Duration,
    /// Tries per command before it fails (a garbled or missing reply is retried).
    pub tries: usize,
    /// Consecutive failed commands after which the board counts as unplugged (the reference host's 3).
    pub unplugged_after: usize,
    /// Pause after energising the motor (the reference host's 1 s).
    pub motor_settle: Duration,
}

impl Default for HorusOptions {
    fn default() -> Self {
        HorusOptions {
            greeting_timeout: Duration::from_secs(3),
            reply_timeout: Duration::from_secs(2),
            tries: 2,
            unplugged_after: 3,
            motor_settle: Duration::from_secs(1),
        }
    }
}

/// A Horus 0.2 board on a link.
pub struct HorusTurntable<L: Link> {
    link: L,
    name: String,
    reader: LineReader,
    opts: HorusOptions,
    /// The feed and acceleration last sent: each is sent only on change (`$120` writes EEPROM).
    feed: Option<f64>,
    acceleration: Option<f64>,
    angle: f64,
    failures: usize,
}

impl<L: Link> HorusTurntable<L> {
    /// Greets the board over `link` (named `name` in errors): soft reset, the greeting checked, then
    /// a feed rate set (a `G1 X` before any feed is an error) and the position zeroed — the
    /// reference host's opening.
    pub fn connect(link: L, name: &str, opts: HorusOptions) -> Result<Self, TurntableError> {
        let mut t = HorusTurntable {
            link,
            name: name.to_string(),
            reader: LineReader::default(),
            opts,
            feed: None,
            acceleration: None,
            angle: 0.0,
            failures: 0,
        };
        t.greet()?;
        t.set_speed(1.0)?;
        t.set_zero()?;
        Ok(t)
    }

    /// The link (to inspect a recorder).
    pub fn link(&self) -> &L {
        &self.link
    }

    fn port_error(&self, e: std::io::Error) -> TurntableError {
        TurntableError::Port { port: self.name.clone(), message: e.to_string() }
    }

    fn greet(&mut self) -> Result<(), TurntableError> {
        self.reader.clear();
        let io = |t: &Self, e| t.port_error(e);
        self.link.write_all(&[SOFT_RESET]).map_err(|e| io(self, e))?;
        self.link.write_all(b"\r\n").map_err(|e| io(self, e))?;
        self.link.flush().map_err(|e| io(self, e))?;
        // Lines before the greeting (a blank, noise from the reset) are skipped; the first line naming
        // a firmware decides.
        let deadline = std::time::Instant::now() + self.opts.greeting_timeout;
        let mut seen = Vec::new();
        loop {
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            match self.reader.read_line(&mut self.link, left) {
                Ok(line) => match parse_reply(&line) {
                    Reply::Greeting(g) if g.contains(GREETING) => return Ok(()),
                    Reply::Greeting(g) if g.starts_with("Horus 0.1") => return Err(TurntableError::OldFirmware(g)),
                    Reply::Greeting(g) => return Err(TurntableError::NotHorus(g)),
                    _ => seen.push(line),
                },
                Err(ReadLineError::Timeout) => {
                    return Err(TurntableError::NotHorus(if seen.is_empty() {
                        format!("nothing within {:?}", self.opts.greeting_timeout)
                    } else {
                        seen.join(" | ")
                    }));
                }
                Err(ReadLineError::Io(e)) => return Err(self.port_error(e)),
            }
        }
    }

    /// Sends one command and waits for its `ok`, retrying a garbled or missing reply; after a
    /// missing reply the board is resynchronised by a soft reset (and its feed and acceleration
    /// restored) before the retry.
    fn send(&mut self, c: Command, timeout: Duration) -> Result<(), TurntableError> {
        let text = command(&c);
        let mut last = None;
        for attempt in 0..self.opts.tries {
            if attempt > 0 && matches!(last, Some(TurntableError::Timeout { .. })) && self.resync().is_err() {
                // No greeting after a reset either: the board is gone.
                self.failures += 1;
                return Err(TurntableError::Unplugged { command: text, failures: self.failures });
            }
            match self.exchange(&text, timeout) {
                Ok(()) => {
                    self.failures = 0;
                    return Ok(());
                }
                Err(e @ (TurntableError::Firmware { .. } | TurntableError::Port { .. })) => {
                    self.failures = 0;
                    return Err(e);
                }
                Err(e) => last = Some(e),
            }
        }
        self.failures += 1;
        let e = last.expect("at least one try");
        if self.failures >= self.opts.unplugged_after {
            return Err(TurntableError::Unplugged { command: text, failures: self.failures });
        }
        Err(e)
    }

    fn exchange(&mut self, text: &str, timeout: Duration) -> Result<(), TurntableError> {
        let mut bytes = text.as_bytes().to_vec();
        bytes.extend_from_slice(b"\r\n");
        self.link.write_all(&bytes).and_then(|_| self.link.flush()).map_err(|e| self.unplugged_or(e, text))?;
        match self.reader.read_line(&mut self.link, timeout) {
            Ok(line) => match parse_reply(&line) {
                Reply::Ok => Ok(()),
                Reply::Error(t) => Err(TurntableError::Firmware { command: text.into(), text: t }),
                Reply::Greeting(g) | Reply::Other(g) => {
                    Err(TurntableError::Garbled { command: text.into(), reply: g, tries: self.opts.tries })
                }
            },
            Err(ReadLineError::Timeout) => Err(TurntableError::Timeout { command: text.into(), timeout }),
            Err(ReadLineError::Io(e)) => Err(self.unplugged_or(e, text)),
        }
    }

    /// A link that fails outright (the device node gone, the other end closed) is an unplugged board.
    fn unplugged_or(&self, _e: std::io::Error, text: &str) -> TurntableError {
        TurntableError::Unplugged { command: text.into(), failures: self.failures + 1 }
    }

    fn resync(&mut self) -> Result<(), TurntableError> {
        self.greet()?;
        let (feed, acc) = (self.feed.take(), self.acceleration.take());
        if let Some(f) = feed {
            self.set_speed(f)?;
        }
        if let Some(a) = acc {
            self.set_acceleration(a)?;
        }
        Ok(())
    }
}

impl<L: Link> Turntable for HorusTurntable<L> {
    fn move_to(&mut self, angle_deg: f64) -> Result<(), TurntableError> {
        in_range("the angle (degrees)", angle_deg, (-MAX_ANGLE_DEG, MAX_ANGLE_DEG))?;
        // The reply comes when the move is done: allow its duration, with margin, on top.
        // Cruise plus ramps (speed / acceleration covers both ramps' extra time), with margin.
        let speed = self.feed.unwrap_or(1.0).max(1e-3);
        let ramp = self.acceleration.unwrap_or(180.0).max(1e-3);
        let seconds = (angle_deg - self.angle).abs() / speed + speed / ramp;
        let travel = Duration::from_secs_f64((seconds * 1.5).min(3600.0));
        self.send(Command::MoveTo(angle_deg), self.opts.reply_timeout + travel)?;
        self.angle = angle_deg;
        Ok(())
    }

    fn set_zero(&mut self) -> Result<(), TurntableError> {
        self.send(Command::Zero, self.opts.reply_timeout)?;
        self.angle = 0.0;
        Ok(())
    }

    fn laser(&mut self, index: usize, on: bool) -> Result<(), TurntableError> {
        if index >= LASERS {
            return Err(TurntableError::NoSuchLaser { index, max: LASERS - 1 });
        }
        self.send(Command::Laser(index, on), self.opts.reply_timeout)
    }

    fn motor(&mut self, on: bool) -> Result<(), TurntableError> {
        self.send(Command::Motor(on), self.opts.reply_timeout)?;
        if on {
            std::thread::sleep(self.opts.motor_settle);
        }
        Ok(())
    }

    fn set_speed(&mut self, deg_per_s: f64) -> Result<(), TurntableError> {
        in_range("the speed (degrees per second)", deg_per_s, SPEED_RANGE_DEG_PER_S)?;
        if self.feed != Some(deg_per_s) {
            self.send(Command::Feed(deg_per_s), self.opts.reply_timeout)?;
            self.feed = Some(deg_per_s);
        }
        Ok(())
    }

    fn set_acceleration(&mut self, deg_per_s2: f64) -> Result<(), TurntableError> {
        in_range("the acceleration (degrees per second²)", deg_per_s2, ACCELERATION_RANGE_DEG_PER_S2)?;
        if self.acceleration != Some(deg_per_s2) {
            self.send(Command::Acceleration(deg_per_s2), self.opts.reply_timeout)?;
            self.acceleration = Some(deg_per_s2);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_are_spelled_as_the_firmware_reads_them() {
        assert_eq!(command(&Command::MoveTo(90.0)), "G1X90");
        assert_eq!(command(&Command::MoveTo(0.45 * 3.0)), "G1X1.35");
        assert_eq!(command(&Command::MoveTo(-0.00001)), "G1X0");
        assert_eq!(command(&Command::Feed(200.0)), "G1F200");
        assert_eq!(command(&Command::Laser(1, true)), "M71T2");
        assert_eq!(command(&Command::Laser(0, false)), "M70T1");
        assert_eq!(command(&Command::Acceleration(200.0)), "$120=200");
    }

    #[test]
    fn replies_are_classified() {
        assert_eq!(parse_reply("ok"), Reply::Ok);
        assert_eq!(parse_reply("error: Undefined feed rate"), Reply::Error("Undefined feed rate".into()));
        assert_eq!(parse_reply("Horus 0.2 ['$' for help]"), Reply::Greeting("Horus 0.2 ['$' for help]".into()));
        assert_eq!(parse_reply("o#k"), Reply::Other("o#k".into()));
    }
}
