//! # calib — estimating a scanner rig
//!
//! Operators calibrate before they scan; a scanner is only as accurate as its calibration. From
//! calibration captures to the numbers in `rig.toml`: chessboard corners found in pure Rust
//! ([`chessboard`], on the grey images of [`gray`]; a board partly seen, placed on the board by its
//! margin, by [`partial_board`]), plane homographies ([`homography`]), Zhang's closed-form
//! intrinsics ([`zhang`]) refined with distortion and per-view poses by Levenberg–Marquardt
//! ([`camera_calib`]) over the distortion terms the views support ([`lens_model`]), and the
//! turntable axis from a board swept on the platter ([`turntable_axis`], or the whole sweep
//! adjusted as one turn by [`sweep`]), the projector by local homographies around each corner
//! ([`projector`]) and the laser planes from the stripe on the board ([`laser_plane`]).
//! [`workflow::calibrate_rig`] runs them all on a capture folder or another tool's images: what
//! `scanrig calibrate` does.
#![deny(missing_docs)]

pub mod camera_calib;
pub mod charuco;
pub mod chessboard;
pub mod gray;
pub mod homography;
pub mod laser_plane;
pub mod least_squares;
pub mod lens_model;
pub mod partial_board;
pub mod projector;
pub mod sweep;
pub mod turntable_axis;
pub mod workflow;
pub mod zhang;

pub use camera_calib::{CalibError, CameraCalibration, CameraOptions, View, calibrate_camera};
pub use chessboard::{NotFound, find_corners};
pub use gray::Gray;
pub use laser_plane::{BoardRegion, LaserFit, LaserView, fit_laser_plane};
pub use lens_model::LensModel;
pub use partial_board::{BoardCorners, Placement, find_board};
pub use projector::{ProjectorCalibration, StereoView, calibrate_projector, projector_corners};
pub use sweep::{SweepFit, SweepView, fit_sweep};
pub use turntable_axis::{AxisFit, fit_axis, fit_axis_seen};
pub use workflow::{BoardSpec, CalibReport, RigCalibParams, Target, WorkflowError, calibrate_rig};
