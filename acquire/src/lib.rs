//! # acquire — driving real scanner hardware
//!
//! Turntables over a serial port (the Horus/Ciclop G-code dialect, with FabScanPi beside it), cameras
//! (V4L2 behind a cargo feature, image-folder replay), projector output, and resumable scan sessions
//! that write the same scan folder as the simulator and never lose a captured view.
//!
//! - [`turntable`]: the trait a session drives and its typed errors;
//! - [`horus`]: the Horus 0.2 dialect and driver; [`virtual_horus`]: the same firmware, virtual, on a
//!   pseudo-terminal, with faults to inject;
//! - [`mod@line`]: the byte link and line reading with deadlines;
//! - [`camera`]: cameras (the trait, image-folder replay) and projector output;
//! - [`session`]: a resumable scan session writing the simulator's scan-folder layout;
//! - `v4l2_camera` (feature `v4l2`): V4L2 webcams; `projector_window` (feature
//!   `projector-window`): the projector as a fullscreen window.
#![deny(missing_docs)]

pub mod camera;
pub mod horus;
pub mod line;
#[cfg(feature = "projector-window")]
pub mod projector_window;
pub mod session;
pub mod turntable;
#[cfg(feature = "v4l2")]
pub mod v4l2_camera;
#[cfg(unix)]
pub mod virtual_horus;

pub use camera::{Camera, CameraError, FolderCamera, NoProjector, PatternOutput, Shot};
pub use horus::{HorusOptions, HorusTurntable};
pub use session::{Devices, Plan, SessionError, SessionReport};
pub use turntable::{Turntable, TurntableError};
