//! Running the `scanrig` binary as a user would, for every test in this binary: always with
//! `RUST_BACKTRACE=1`, and always checking that no panic message, internal-error report or backtrace
//! reached stderr — so the whole catalogue of commands the tests run, good input and bad, is also a
//! test that scanrig never panics at its user (issue 19).

use std::process::{Command, Output};

/// Runs `scanrig ARGS…` and returns its output, after asserting stderr holds no panic.
pub fn scanrig(args: &[&dyn AsRef<std::ffi::OsStr>]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_scanrig"));
    cmd.env("RUST_BACKTRACE", "1");
    for a in args {
        cmd.arg(a);
    }
    let o = cmd.output().unwrap();
    no_panic(&o, args);
    o
}

/// A pose as `registered.poses.json` and `register --json` write it: `object_from_camera`, row-major 4 × 4.
pub fn pose_from_json(pose: &serde_json::Value) -> rig::Isometry3 {
    matrix_pose(&pose["object_from_camera"])
}

/// A rigid motion from a row-major 4 × 4 JSON array (`align --json`'s `pose`, a pass's
/// `first_from_pass`, `truth/passes.json`).
pub fn matrix_pose(rows: &serde_json::Value) -> rig::Isometry3 {
    let v: Vec<f64> = rows
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|r| r.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()))
        .collect();
    nalgebra::try_convert::<_, rig::Isometry3>(nalgebra::Matrix4::from_row_slice(&v)).unwrap()
}

/// No panic message, internal-error report or Rust backtrace in the output's stderr.
pub fn no_panic(o: &Output, args: &[&dyn AsRef<std::ffi::OsStr>]) {
    let err = String::from_utf8_lossy(&o.stderr);
    let shown: Vec<String> = args.iter().map(|a| a.as_ref().to_string_lossy().into_owned()).collect();
    for sign in ["panicked", "stack backtrace", "RUST_BACKTRACE", "internal error", "memory allocation of"] {
        assert!(!err.contains(sign), "`scanrig {}` printed `{sign}`:\n{err}", shown.join(" "));
    }
}
