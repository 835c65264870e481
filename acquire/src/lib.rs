//! # acquire — driving real scanner hardware
//!
//! Turntables over a serial port (the Horus/Ciclop G-code dialect, with FabScanPi beside it), cameras
//! (V4L2 behind a cargo feature, image-folder replay), projector output, and resumable scan sessions
//! that write the same scan folder as the simulator and never lose a captured view.
//!
//! It depends only on the vocabulary crate [`rig`]. The drivers arrive with the acquisition issue.
#![deny(missing_docs)]
