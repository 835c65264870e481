//! Issue 5, acceptance 1 (camera and projector): chessboard captures of the simulated
//! structured-light rig — its default sensor noise, 15 board poses, each under the full Gray-code and
//! phase-shift program — through corner detection, the camera's calibration, the projector's by
//! local homographies and the joint stereo refinement, against the simulator's truth.

use calib::{
    CameraOptions, Gray, StereoView, View, calibrate_camera, calibrate_projector, find_corners, projector_corners,
};
use decode::structured_light::{DecodeParams, decode_view};
use rig::math::{Point2, Point3};
use rig::npy::NpyData;
use rig::{Manifest, Pattern};

#[test]
fn simulated_board_views_calibrate_camera_and_projector() {
    let cfg = sim::SimConfig::builtin("structured-light").unwrap();
    // 11 mm squares: the default poses drift the board toward the image's edges, and with 15 mm
    // squares half of them leave corners outside the frame.
    let board = sim::Board { cols: 9, rows: 6, square_mm: 11.0, markers: None };
    let distance = cfg.rig.turntable.map(|t| t.point.coords.norm()).unwrap_or(400.0);
    let poses = sim::board::default_fixed_poses(&board, distance, 15);
    let dir = fixtures::temp_dir("calib-camera-sim");
    let opts = sim::ScanOptions { method: rig::Method::Board, seed: 7, truth: true };
    sim::simulate_board(&cfg, &board, &sim::BoardPoses::held(poses), opts, &dir, |_, _| {}).unwrap();

    let manifest = Manifest::read(&dir).unwrap();
    let object: Vec<Point3> = board.corners();
    let (mut views, mut errors, mut missing, mut found) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (v, view) in manifest.views.iter().enumerate() {
        let lit = view.frames.iter().find(|f| f.pattern == Pattern::White).expect("a lit frame");
        let img = Gray::from_image(&rig::image::read_png(&dir.join(&lit.file)).unwrap());
        let truth = match rig::npy::read(&dir.join(format!("truth/view_{v:03}/corners.npy"))).unwrap().data {
            NpyData::F64(d) => d.chunks(2).map(|c| Point2::new(c[0], c[1])).collect::<Vec<_>>(),
            _ => panic!("corners.npy is f64"),
        };
        let (w, h) = (cfg.rig.camera.width as f64, cfg.rig.camera.height as f64);
        let in_frame = truth.iter().all(|p| p.x > 3.0 && p.y > 3.0 && p.x < w - 4.0 && p.y < h - 4.0);
        let corners = match find_corners(&img, 9, 6) {
            Ok(c) => c,
            Err(e) => {
                // Only a board that leaves the frame may be missed.
                assert!(!in_frame, "view {v}: the whole board is in the image, yet {e}");
                missing.push(v);
                continue;
            }
        };
        errors.extend(corners.iter().zip(&truth).map(|(a, b)| (a - b).norm()));
        views.push(View { object: object.clone(), image: corners.clone() });
        found.push((v, corners));
    }
    errors.sort_by(|a, b| a.total_cmp(b));
    let mean = errors.iter().sum::<f64>() / errors.len() as f64;
    eprintln!(
        "{} of 15 views found (not found, board partly outside the image: {missing:?}); corners against truth: \
         mean {mean:.3} px, max {:.3} px over {} corners",
        views.len(),
        errors[errors.len() - 1],
        errors.len()
    );
    assert!(views.len() >= 10, "only {} views found", views.len());
    assert!(errors[errors.len() - 1] < 0.5, "a corner is {} px off", errors[errors.len() - 1]);

    let c = calibrate_camera(&views, cfg.rig.camera.width, cfg.rig.camera.height, CameraOptions::default()).unwrap();
    let truth = cfg.rig.camera;
    eprintln!(
        "fx {:.2} (truth {:.2}), fy {:.2} ({:.2}), cx {:.2} ({:.2}), cy {:.2} ({:.2}), rms {:.3} px, {} iterations",
        c.camera.fx, truth.fx, c.camera.fy, truth.fy, c.camera.cx, truth.cx, c.camera.cy, truth.cy, c.rms, c.iterations
    );
    assert!((c.camera.fx / truth.fx - 1.0).abs() <= 1e-3, "fx {}", c.camera.fx);
    assert!((c.camera.fy / truth.fy - 1.0).abs() <= 1e-3, "fy {}", c.camera.fy);
    assert!((c.camera.cx - truth.cx).abs() <= 0.5, "cx {}", c.camera.cx);
    assert!((c.camera.cy - truth.cy).abs() <= 0.5, "cy {}", c.camera.cy);
    assert!(c.rms <= 0.15, "rms {}", c.rms);

    // The projector: each view's frames decoded, corners carried over by local homographies.
    let proj = cfg.rig.projector.expect("the structured-light rig has a projector");
    let stereo: Vec<StereoView> = found
        .iter()
        .map(|(v, corners)| {
            let images: Vec<(Pattern, rig::image::Image8)> = manifest.views[*v]
                .frames
                .iter()
                .map(|f| (f.pattern, rig::image::read_png(&dir.join(&f.file)).unwrap()))
                .collect();
            let frames: Vec<(Pattern, &rig::image::Image8)> = images.iter().map(|(p, i)| (*p, i)).collect();
            let (map, _) = decode_view(&frames, proj.lens.width, proj.lens.height, &DecodeParams::default()).unwrap();
            StereoView {
                object: object.clone(),
                camera: corners.clone(),
                projector: projector_corners(corners, &map, 20),
            }
        })
        .collect();
    let p =
        calibrate_projector(&c.camera, &stereo, proj.lens.width, proj.lens.height, CameraOptions::default()).unwrap();
    let rot = p.from_camera.rotation.angle_to(&proj.from_camera.rotation).to_degrees();
    let t_true = proj.from_camera.translation.vector;
    let t_err = (p.from_camera.translation.vector - t_true).norm() / t_true.norm();
    eprintln!(
        "projector: {} views, {} corners ({} skipped); fx {:.2} ({:.2}), fy {:.2} ({:.2}), cx {:.2} ({:.2}), \
         cy {:.2} ({:.2}); rotation {rot:.4}° off, translation {:.3} % off; RMS projector {:.3}, stereo {:.3} \
         (camera {:.3}, projector {:.3}) px",
        p.views,
        p.corners_used,
        p.corners_skipped,
        p.lens.fx,
        proj.lens.fx,
        p.lens.fy,
        proj.lens.fy,
        p.lens.cx,
        proj.lens.cx,
        p.lens.cy,
        proj.lens.cy,
        100.0 * t_err,
        p.projector_rms,
        p.stereo_rms,
        p.stereo_camera_rms,
        p.stereo_projector_rms
    );
    assert!((p.lens.fx / proj.lens.fx - 1.0).abs() <= 5e-3, "projector fx {}", p.lens.fx);
    assert!((p.lens.fy / proj.lens.fy - 1.0).abs() <= 5e-3, "projector fy {}", p.lens.fy);
    assert!(rot <= 0.1, "extrinsic rotation {rot}° off");
    assert!(t_err <= 5e-3, "extrinsic translation {} % off", 100.0 * t_err);
    // Fixed terms stay fixed through the joint refinement: the principal point at the image centre
    // (where the simulated projector's is) and fy / fx at its first estimate.
    let fixed = CameraOptions { fix_principal_point: true, fix_aspect_ratio: true, ..CameraOptions::default() };
    let q = calibrate_projector(&c.camera, &stereo, proj.lens.width, proj.lens.height, fixed).unwrap();
    let centre = ((proj.lens.width as f64 - 1.0) / 2.0, (proj.lens.height as f64 - 1.0) / 2.0);
    assert_eq!((q.lens.cx, q.lens.cy), centre);
    assert!((q.lens.fx / proj.lens.fx - 1.0).abs() <= 5e-3, "projector fx {} with fixed terms", q.lens.fx);
}
