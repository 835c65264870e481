//! # calib — estimating a scanner rig
//!
//! Operators calibrate before they scan; a scanner is only as accurate as its calibration. This crate
//! turns capture folders into a [`rig::Rig`]:
//!
//! - chessboard corner detection with sub-pixel refinement;
//! - camera intrinsics (Zhang's initialisation, then Levenberg–Marquardt over OpenCV's five-term model);
//! - the projector by local homographies of decoded Gray codes (Moreno–Taubin) and stereo refinement;
//! - laser planes from lit boards, robustly fitted;
//! - the turntable axis from a board swept through angles.
//!
//! It depends only on the vocabulary crate [`rig`]. The estimators arrive with the calibration issue;
//! until then the crate holds no code, so nothing here pretends to calibrate.
#![deny(missing_docs)]
