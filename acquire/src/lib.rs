//! # acquire — driving real scanner hardware
//!
//! Turntables over a serial port (the Horus/Ciclop G-code dialect, with FabScanPi beside it), cameras
//! (V4L2 behind a cargo feature, image-folder replay), projector output, and resumable scan sessions
//! that write the same scan folder as the simulator and never lose a captured view.
//!
//! - [`turntable`]: the trait a session drives and its typed errors;
//! - [`horus`]: the Horus 0.2 dialect and driver; [`virtual_horus`]: the same firmware, virtual, on a
//!   pseudo-terminal, with faults to inject;
//! - [`mod@line`]: the byte link and line reading with deadlines.
#![deny(missing_docs)]

pub mod horus;
pub mod line;
pub mod turntable;
#[cfg(unix)]
pub mod virtual_horus;

pub use horus::{HorusOptions, HorusTurntable};
pub use turntable::{Turntable, TurntableError};
