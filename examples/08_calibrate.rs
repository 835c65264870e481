//! 08 — Calibrate the camera (Zhang's method, as OpenCV's `calibrateCamera`) from chessboard
//! captures the simulator renders, and compare with the camera it rendered them with.
//!
//! `cargo run --release --example 08_calibrate`

use calib::{CameraOptions, Gray, View, calibrate_camera, find_corners};
use rig::{Manifest, Pattern};

fn main() {
    // The laser rig at its 640 × 480 readout, a 9 × 6 board of 11 mm squares held in 12 poses before it.
    let cfg = sim::SimConfig::builtin("laser").expect("a built-in config").with_camera_resolution(640, 480);
    let board = sim::Board { cols: 9, rows: 6, square_mm: 11.0, markers: None };
    let distance = cfg.rig.turntable.map(|t| t.point.coords.norm()).unwrap_or(400.0);
    let poses = sim::BoardPoses::held(sim::board::default_fixed_poses(&board, distance, 12));
    let dir = tempfile::tempdir().expect("a temporary folder");
    let opts = sim::ScanOptions { method: rig::Method::Board, seed: 1, truth: false };
    sim::simulate_board(&cfg, &board, &poses, opts, dir.path(), |_, _| {}).expect("the simulated captures");

    // Each pose's lit frame, and its inner corners where the whole board is in the image (a board
    // partly outside it is left out, as `scanrig calibrate camera` leaves it out).
    let manifest = Manifest::read(dir.path()).expect("the captures' scan.json");
    let views: Vec<View> = manifest
        .views
        .iter()
        .filter_map(|view| {
            let lit = view.frames.iter().find(|f| f.pattern == Pattern::White)?;
            let image = rig::image::read_image(&dir.path().join(&lit.file)).ok()?;
            let corners = find_corners(&Gray::from_image(&image), board.cols as usize, board.rows as usize).ok()?;
            Some(View { object: board.corners(), image: corners })
        })
        .collect();

    let (w, h) = (cfg.rig.camera.width, cfg.rig.camera.height);
    let c = calibrate_camera(&views, w, h, CameraOptions::default()).expect("a calibration");
    let truth = cfg.rig.camera;
    println!(
        "board found in {} of 12 poses; fx {:.2} (rendered with {:.2}), fy {:.2} ({:.2}), principal point \
         ({:.2}, {:.2}) against ({:.2}, {:.2}); reprojection RMS {:.3} px",
        views.len(),
        c.camera.fx,
        truth.fx,
        c.camera.fy,
        truth.fy,
        c.camera.cx,
        c.camera.cy,
        truth.cx,
        truth.cy,
        c.rms
    );
    assert!(views.len() >= 8 && (c.camera.fx / truth.fx - 1.0).abs() < 2e-3 && c.rms < 0.3, "{c:?}");
}
