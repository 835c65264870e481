//! # sim — the virtual rig
//!
//! Renders exactly the frames a real rig records (structured-light patterns, laser lines, chessboards for
//! calibration) of any mesh on a virtual turntable, with ground truth: per-view depth, visibility,
//! normals and projector coordinates. It is how users without hardware, and every regression test, see
//! the pipeline work. Ray casting with a BVH built once per mesh, Lambertian shading, projector and laser
//! shadows, lens distortion, noise and 8-bit quantisation; deterministic for a given seed.
//!
//! It depends only on the vocabulary crate [`rig`]. The renderer arrives with the simulator issue.
#![deny(missing_docs)]
