//! The vocabulary crate: file readers and writers, rig files, the camera model, in one binary.

mod camera_model;
mod common;
mod fuzz_readers;
mod malformed;
mod rig_files;
mod roundtrip;
mod scanner_files;
mod trusted_inputs;
