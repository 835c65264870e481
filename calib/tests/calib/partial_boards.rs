//! Issue 39, acceptance 1: boards partly seen. Twelve simulated views of a 9 × 6 board, each with a
//! third of its corners hidden — pushed past the image's edge in half of them, covered by a grey card
//! in the other half — which `find_corners` (the whole board or nothing) rejects every one of; the
//! calibration workflow finds the corners it can see, places them on the board, and calibrates the
//! camera within 0.5 % of the simulator's focal length and 2 px of its principal point.

use calib::{BoardSpec, Gray, Placement, find_corners};
use rig::math::{Isometry3, Point2, Translation3, Vector3};
use rig::npy::NpyData;
use rig::{Manifest, Pattern};

/// The share of `pose`'s corners that `camera` does not see in its image.
fn outside(camera: &rig::PinholeCamera, board: &sim::Board, pose: &Isometry3) -> f64 {
    let (w, h) = (camera.width as f64, camera.height as f64);
    let corners = board.corners();
    let out = corners
        .iter()
        .filter(|c| {
            camera.project(&(pose * *c)).is_none_or(|p| !(p.x > 4.0 && p.y > 4.0 && p.x < w - 5.0 && p.y < h - 5.0))
        })
        .count();
    out as f64 / corners.len() as f64
}

#[test]
fn boards_a_third_hidden_calibrate_the_camera() {
    let cfg = sim::SimConfig::builtin("laser").unwrap().with_camera_resolution(640, 480);
    let board = sim::Board { cols: 9, rows: 6, square_mm: 11.0, markers: None };
    let distance = cfg.rig.turntable.map(|t| t.point.coords.norm()).unwrap_or(400.0);
    let camera = cfg.rig.camera;
    let mut held = sim::board::default_fixed_poses(&board, distance, 12);
    let mut covers = Vec::new();
    for (k, pose) in held.iter_mut().enumerate() {
        if k % 2 == 0 {
            // Slide the board sideways (away from the image centre it is nearer) until a third of
            // its corners leave the image.
            let centre = camera.project(&(*pose * rig::math::Point3::new(44.0, 27.5, 0.0))).unwrap();
            let dir = if centre.x < camera.cx { -1.0 } else { 1.0 };
            while outside(&camera, &board, pose) < 0.3 {
                *pose = Translation3::from(Vector3::new(dir * 1.0, 0.0, 0.0)) * *pose;
            }
            covers.push(None);
        } else {
            // A card over the board's last three columns, or its last two rows: 18 of 54 corners.
            let cover = if k % 4 == 1 {
                sim::Cover { from: (5.5, -1.5), to: (9.5, 6.5) }
            } else {
                sim::Cover { from: (-1.5, 3.5), to: (9.5, 6.5) }
            };
            covers.push(Some(cover));
        }
    }
    let poses = sim::BoardPoses { held, sweep: Vec::new(), covers };
    let dir = fixtures::temp_dir("calib-partial-boards");
    let opts = sim::ScanOptions { method: rig::Method::Board, seed: 3, truth: true };
    sim::simulate_board(&cfg, &board, &poses, opts, &dir, |_, _| {}).unwrap();

    // Not one view holds the whole board.
    let manifest = Manifest::read(&dir).unwrap();
    for view in &manifest.views {
        let lit = view.frames.iter().find(|f| f.pattern == Pattern::White).unwrap();
        let img = Gray::from_image(&rig::image::read_png(&dir.join(&lit.file)).unwrap());
        assert!(find_corners(&img, 9, 6).is_err(), "{}: the whole board is in view", lit.file);
    }

    let (rig, report) =
        crate::calibrate_camera_from(&dir, BoardSpec { cols: 9, rows: 6, square_mm: 11.0, markers: None });
    let cam = report.camera.as_ref().unwrap();
    assert_eq!(report.board_found.found, 12, "{:?}", report.not_found);
    assert_eq!(report.board_found.partial, 12);

    // Each view: at most 70 % of the corners used, and an identified corner is where the
    // simulator put that corner.
    let mut identified = 0;
    for (v, view) in cam.views.iter().enumerate() {
        assert!(view.corner_ids.len() <= 38 && view.corner_ids.len() >= 20, "view {v}: {}", view.corner_ids.len());
        let truth = match rig::npy::read(&dir.join(format!("truth/view_{v:03}/corners.npy"))).unwrap().data {
            NpyData::F64(d) => d.chunks(2).map(|c| Point2::new(c[0], c[1])).collect::<Vec<_>>(),
            _ => panic!("corners.npy is f64"),
        };
        if view.placement == Placement::Identified {
            identified += 1;
            for (id, c) in view.corner_ids.iter().zip(&view.corners) {
                let e = (Point2::new(c[0], c[1]) - truth[*id]).norm();
                assert!(e < 0.5, "view {v}: corner {id} found {e:.2} px from its truth");
            }
        }
    }
    let truth = cfg.rig.camera;
    let c = rig.camera;
    eprintln!(
        "12 views, each a third hidden ({identified} placed on the board by its margin): fx {:.2} (truth {:.2}, \
         {:+.3} %), fy {:.2} ({:.2}), principal point ({:.2}, {:.2}) against ({:.2}, {:.2}); RMS {:.3} px; \
         model {:?}",
        c.fx,
        truth.fx,
        100.0 * (c.fx / truth.fx - 1.0),
        c.fy,
        truth.fy,
        c.cx,
        c.cy,
        truth.cx,
        truth.cy,
        cam.rms_px,
        cam.model.estimated
    );
    assert!(identified >= 6, "only {identified} views placed on the board");
    assert!((c.fx / truth.fx - 1.0).abs() < 0.005, "fx {} against {}", c.fx, truth.fx);
    assert!((c.fy / truth.fy - 1.0).abs() < 0.005, "fy {} against {}", c.fy, truth.fy);
    assert!((c.cx - truth.cx).abs() < 2.0 && (c.cy - truth.cy).abs() < 2.0, "({}, {})", c.cx, c.cy);
    assert!(cam.rms_px < 0.3, "RMS {}", cam.rms_px);
}
