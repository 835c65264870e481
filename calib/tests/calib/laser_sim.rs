//! Issue 5, acceptance 1 (laser planes): a board standing on the simulated laser rig's platter, swept
//! through −60°…60°, its laser lines found on the board and fitted, against the simulator's planes.

use calib::laser_plane::on_even_print;
use calib::{BoardRegion, Gray, LaserView, SweepView, find_corners, fit_laser_plane, fit_sweep};
use decode::laser_line::{LaserParams, detect_line_within};
use rig::math::{Point2, Point3, Real};
use rig::{Manifest, Pattern};

#[test]
fn laser_lines_on_a_swept_board_give_the_laser_planes() {
    let cfg = sim::SimConfig::builtin("laser").unwrap();
    let board = sim::Board { cols: 11, rows: 6, square_mm: 13.0, markers: None };
    let angles: Vec<Real> = (-12..=12).map(|k| k as Real * 5.0).collect();
    let dir = fixtures::temp_dir("calib-laser-sim");
    let opts = sim::ScanOptions { method: rig::Method::Board, seed: 5, truth: false };
    sim::simulate_board(&cfg, &board, &sim::BoardPoses::sweep(angles.clone()), opts, &dir, |_, _| {}).unwrap();
    let manifest = Manifest::read(&dir).unwrap();
    let object: Vec<Point3> = board.corners();
    let camera = cfg.rig.camera;
    let read = |file: &str| rig::image::read_png(&dir.join(file)).unwrap();
    let mut found = Vec::new();
    for view in &manifest.views {
        let frame = |p: Pattern| view.frames.iter().find(|f| f.pattern == p).map(|f| read(&f.file));
        let lit = frame(Pattern::White).expect("a lit frame");
        let Ok(corners) = find_corners(&Gray::from_image(&lit), 11, 6) else { continue };
        found.push((view, lit, corners));
    }
    assert!(found.len() >= 15, "the board was found in {} views", found.len());
    // Board poses from the whole sweep adjusted as one turn (per-view poses tilt the planes).
    let sweep: Vec<SweepView> = found
        .iter()
        .map(|(v, _, c)| SweepView { angle_deg: v.angle_deg, corners: c.clone(), ids: Vec::new() })
        .collect();
    // The lowest inner corners stand two squares above the platter (a square to the margin's edge, a
    // square of margin).
    let platter = 2.0 * board.square_mm;
    let fit = fit_sweep(&camera, &object, &sweep, platter).unwrap();
    eprintln!("sweep: RMS {:.3} px, {} iterations", fit.rms_px, fit.iterations);
    let mut views = vec![Vec::new(); cfg.rig.lasers.len()];
    for ((view, lit, corners), pose) in found.iter().zip(fit.poses) {
        let frame = |p: Pattern| view.frames.iter().find(|f| f.pattern == p).map(|f| read(&f.file));
        let region = BoardRegion::new(corners, 11, 6).unwrap();
        let off = frame(Pattern::LaserOff).expect("a laser-off frame");
        for (i, laser_views) in views.iter_mut().enumerate() {
            let on = frame(Pattern::Laser { index: i }).expect("a laser frame");
            let (peaks, _) = detect_line_within(&on, &off, &LaserParams::default(), |c, r| {
                region.contains(Point2::new(c as Real, r as Real))
            });
            let pixels: Vec<Point2> =
                peaks.iter().map(|p| Point2::new(p.col, p.row as Real)).filter(|&p| on_even_print(lit, p, 6)).collect();
            laser_views.push(LaserView { pose, pixels });
        }
    }
    for (i, laser_views) in views.iter().enumerate() {
        let fit = fit_laser_plane(&camera, laser_views, 0.5).unwrap();
        let truth = cfg.rig.lasers[i].plane;
        // The fit's sign convention is d ≥ 0; compare the same plane.
        let s = if fit.plane.normal.dot(&truth.normal) < 0.0 { -1.0 } else { 1.0 };
        let angle = (fit.plane.normal.into_inner() * s).angle(&truth.normal).to_degrees();
        let off = (fit.plane.distance * s - truth.distance).abs();
        eprintln!(
            "laser {i}: {} views, {} points ({} inliers), normal {angle:.4}° off, distance {off:.4} mm off; \
             spread RMS {:.3} mm, max {:.3} mm",
            fit.views, fit.points, fit.inliers, fit.rms_mm, fit.max_mm
        );
        assert!(angle <= 0.1, "laser {i}: normal {angle}° off");
        assert!(off <= 0.1, "laser {i}: distance {off} mm off");
    }
}
