//! Issue 5, acceptance 1 (the turntable axis): a board standing on the simulated platter, swept
//! through −60°…60°, against the simulator's axis.

use calib::{Gray, SweepView, find_corners, fit_axis, fit_sweep};
use rig::math::{Point3, Real};
use rig::{Manifest, Pattern};

#[test]
fn a_board_swept_on_the_platter_gives_the_turntable_axis() {
    let cfg = sim::SimConfig::builtin("structured-light").unwrap();
    let truth = cfg.rig.turntable.expect("the structured-light rig has a turntable");
    let board = sim::Board { cols: 9, rows: 6, square_mm: 11.0, markers: None };
    let angles: Vec<Real> = (-6..=6).map(|k| k as Real * 10.0).collect();
    let dir = fixtures::temp_dir("calib-axis-sim");
    let opts = sim::ScanOptions { method: rig::Method::Board, seed: 3, truth: false };
    sim::simulate_board(&cfg, &board, &sim::BoardPoses::sweep(angles.clone()), opts, &dir, |_, _| {}).unwrap();
    let manifest = Manifest::read(&dir).unwrap();
    let mut views = Vec::new();
    let mut sweep = Vec::new();
    for view in &manifest.views {
        let lit = view.frames.iter().find(|f| f.pattern == Pattern::White).unwrap();
        let img = Gray::from_image(&rig::image::read_png(&dir.join(&lit.file)).unwrap());
        if let Ok(c) = find_corners(&img, 9, 6) {
            sweep.push(SweepView { angle_deg: view.angle_deg, corners: c.clone() });
            views.push(c);
        }
    }
    let object: Vec<Point3> = board.corners();
    // The lowest inner corners stand two squares above the platter (a square to the margin's edge, a
    // square of margin).
    let platter = 2.0 * board.square_mm;
    let fit = fit_axis(&cfg.rig.camera, &object, &views, platter).unwrap();
    let angle = fit.axis.direction.angle(&truth.direction).to_degrees();
    let off = (fit.axis.point - truth.point).norm();
    eprintln!(
        "{} of {} views; axis direction {angle:.4}° off, platter centre {off:.3} mm off; circles RMS {:.4} mm",
        views.len(),
        angles.len(),
        fit.circle_rms_mm
    );
    assert!(views.len() >= 10, "{} views", views.len());
    assert!(angle <= 0.1, "direction {angle}°");
    assert!(off <= 0.2, "point {off} mm");
    // With the recorded angles, the sweep adjusted as one turn pins the axis tighter still.
    let fit = fit_sweep(&cfg.rig.camera, &object, &sweep, platter).unwrap();
    let angle = fit.axis.direction.angle(&truth.direction).to_degrees();
    let off = (fit.axis.point - truth.point).norm();
    eprintln!("sweep adjustment: direction {angle:.4}° off, platter centre {off:.3} mm off, RMS {:.3} px", fit.rms_px);
    assert!(angle <= 0.1, "direction {angle}°");
    assert!(off <= 0.2, "point {off} mm");
}
