//! What a scan session needs from a turntable controller board, whatever its firmware: turn the
//! platter to an absolute angle, switch lasers and the motor, and say plainly what went wrong.

use std::time::Duration;

/// A turntable controller (with the scanner's lasers on the same board, as on Ciclop-class rigs).
pub trait Turntable {
    /// Turns the platter to `angle_deg` (absolute, counter-clockwise seen from above, from where
    /// [`Turntable::set_zero`] was last called); returns once the move is done.
    fn move_to(&mut self, angle_deg: f64) -> Result<(), TurntableError>;
    /// Makes the current position angle zero.
    fn set_zero(&mut self) -> Result<(), TurntableError>;
    /// Switches laser `index` (0-based, as the rig file lists them).
    fn laser(&mut self, index: usize, on: bool) -> Result<(), TurntableError>;
    /// Energises (`true`) or releases the stepper.
    fn motor(&mut self, on: bool) -> Result<(), TurntableError>;
    /// Sets the turning speed (degrees per second).
    fn set_speed(&mut self, deg_per_s: f64) -> Result<(), TurntableError>;
    /// Sets the acceleration (degrees per second²).
    fn set_acceleration(&mut self, deg_per_s2: f64) -> Result<(), TurntableError>;
}

/// The largest absolute angle a move may ask for, degrees (a hundred turns from the zero mark).
pub const MAX_ANGLE_DEG: f64 = 36_000.0;
/// The speed range a move may ask for, degrees per second: below this a move of a few degrees takes
/// minutes, above it a stepper misses steps.
pub const SPEED_RANGE_DEG_PER_S: (f64, f64) = (0.1, 1_000.0);
/// The acceleration range, degrees per second squared.
pub const ACCELERATION_RANGE_DEG_PER_S2: (f64, f64) = (1.0, 100_000.0);

/// Why a turntable command failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TurntableError {
    /// A value no board should be sent (NaN, infinite, or far out of range): refused before sending,
    /// so the board is never left working on it.
    #[error("{what} {value} is out of range: it must be a number from {min} to {max}")]
    OutOfRange {
        /// The setting.
        what: &'static str,
        /// The value given.
        value: f64,
        /// The smallest accepted.
        min: f64,
        /// The largest accepted.
        max: f64,
    },
    /// The port could not be opened or used.
    #[error("{port}: {message}")]
    Port {
        /// The port's name.
        port: String,
        /// What the system said.
        message: String,
    },
    /// The board answered, but not with Horus firmware's greeting.
    #[error("not Horus firmware (check board and baud rate): the board said {0:?}")]
    NotHorus(String),
    /// The board runs the old Horus 0.1 firmware.
    #[error("old Horus firmware ({0:?}): update the board to Horus 0.2")]
    OldFirmware(String),
    /// The board said nothing within the time allowed.
    #[error("no reply to `{command}` within {timeout:?}")]
    Timeout {
        /// The command sent.
        command: String,
        /// How long the host waited.
        timeout: Duration,
    },
    /// The reply was neither `ok` nor `error: …`, on every try.
    #[error("`{command}`: unreadable reply {reply:?} after {tries} tries")]
    Garbled {
        /// The command sent.
        command: String,
        /// The last reply line.
        reply: String,
        /// Tries made.
        tries: usize,
    },
    /// The firmware refused the command.
    #[error("`{command}`: the firmware replied `error: {text}`")]
    Firmware {
        /// The command sent.
        command: String,
        /// The firmware's text after `error:`.
        text: String,
    },
    /// Several commands in a row failed: the board is gone (unplugged, or reset for good).
    #[error("the turntable stopped answering at `{command}` ({failures} command(s) failed in a row): is it unplugged?")]
    Unplugged {
        /// The last command tried.
        command: String,
        /// Consecutive failures.
        failures: usize,
    },
    /// The rig has no such laser.
    #[error("laser {index} does not exist (the board drives lasers 0 to {max})")]
    NoSuchLaser {
        /// The index asked for.
        index: usize,
        /// The highest index the dialect knows.
        max: usize,
    },
}

/// `value` when it lies in `[min, max]` (NaN never does), else [`TurntableError::OutOfRange`].
pub fn in_range(what: &'static str, value: f64, (min, max): (f64, f64)) -> Result<f64, TurntableError> {
    if value >= min && value <= max { Ok(value) } else { Err(TurntableError::OutOfRange { what, value, min, max }) }
}
