//! Issue 5, acceptance 1 (the turntable axis): a board standing on the simulated platter, swept
//! through −60°…60°, against the simulator's axis.

use calib::{Gray, SweepView, find_corners, fit_axis, fit_axis_seen, fit_sweep};
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
            sweep.push(SweepView { angle_deg: view.angle_deg, corners: c.clone(), ids: Vec::new() });
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

    // Issue 39: each view a part of the board, as a board half hidden or cut by the image's edge
    // gives it — the first six columns in even views, the last six in odd ones (a third of the
    // corners gone) — its corners known by their numbers.
    let part = |k: usize| -> Vec<usize> {
        (0..54).filter(|i| if k.is_multiple_of(2) { i % 9 < 6 } else { i % 9 >= 3 }).collect()
    };
    let ids: Vec<Vec<usize>> = (0..views.len()).map(part).collect();
    let pixels: Vec<Vec<rig::math::Point2>> =
        views.iter().zip(&ids).map(|(c, i)| i.iter().map(|&k| c[k]).collect()).collect();
    let seen: Vec<(&[usize], &[rig::math::Point2])> =
        ids.iter().zip(&pixels).map(|(i, p)| (i.as_slice(), p.as_slice())).collect();
    let fit = fit_axis_seen(&cfg.rig.camera, &object, &seen, platter).unwrap();
    let (angle, off) = (fit.axis.direction.angle(&truth.direction).to_degrees(), (fit.axis.point - truth.point).norm());
    let partial: Vec<SweepView> = sweep
        .iter()
        .zip(&ids)
        .zip(&pixels)
        .map(|((v, i), p)| SweepView { angle_deg: v.angle_deg, corners: p.clone(), ids: i.clone() })
        .collect();
    let swept = fit_sweep(&cfg.rig.camera, &object, &partial, platter).unwrap();
    let (s_angle, s_off) =
        (swept.axis.direction.angle(&truth.direction).to_degrees(), (swept.axis.point - truth.point).norm());
    eprintln!(
        "two thirds of each board: circles {angle:.4}° / {off:.3} mm off, sweep {s_angle:.4}° / {s_off:.3} mm off \
         (RMS {:.3} px)",
        swept.rms_px
    );
    assert!(angle <= 0.1 && off <= 0.2, "circles {angle}° {off} mm");
    assert!(s_angle <= 0.1 && s_off <= 0.2, "sweep {s_angle}° {s_off} mm");
}
