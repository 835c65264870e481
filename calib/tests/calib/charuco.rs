//! Issue 39, acceptance 1 (ChArUco): twelve simulated views of an 11 × 9 ChArUco board (OpenCV's
//! layout, DICT_4X4_50), each with half its markers under a grey card, calibrate the camera within
//! 0.5 % of the simulator's focal length and 2 px of its principal point, every corner found at its
//! own number.

use calib::BoardSpec;
use calib::charuco::{dictionary, find_charuco, marker_bits, parse};
use rig::math::Point2;
use rig::npy::NpyData;
use rig::{Manifest, Pattern};

#[test]
fn a_charuco_board_half_covered_calibrates_the_camera() {
    let cfg = sim::SimConfig::builtin("laser").unwrap();
    let (cols, rows, square, markers) = parse("charuco:11x9:square=12:marker=9:dict=4x4_50").unwrap();
    let (bits, codes) = marker_bits(&dictionary(markers.dictionary).unwrap());
    let board = sim::Board {
        cols,
        rows,
        square_mm: square,
        markers: Some(sim::Markers { size_mm: markers.marker_mm, bits, codes }),
    };
    let distance = cfg.rig.turntable.map(|t| t.point.coords.norm()).unwrap_or(400.0);
    let held = sim::board::default_fixed_poses(&board, distance, 12);
    // A card over the left, right, top or bottom half of the squares in turn: about half of the
    // 49 markers hidden in each view.
    let halves = [
        ((-1.5, -1.5), (4.5, 8.5)),
        ((4.5, -1.5), (10.5, 8.5)),
        ((-1.5, -1.5), (10.5, 3.5)),
        ((-1.5, 3.5), (10.5, 8.5)),
    ];
    let covers = (0..12).map(|k| Some(sim::Cover { from: halves[k % 4].0, to: halves[k % 4].1 })).collect();
    let poses = sim::BoardPoses { held, sweep: Vec::new(), covers };
    let dir = fixtures::temp_dir("calib-charuco");
    let opts = sim::ScanOptions { method: rig::Method::Board, seed: 5, truth: true };
    sim::simulate_board(&cfg, &board, &poses, opts, &dir, |_, _| {}).unwrap();

    // Each view: the corners found are where the simulator put the corners of those numbers.
    let manifest = Manifest::read(&dir).unwrap();
    let (mut errors, mut found_views, mut shares) = (Vec::new(), 0, Vec::new());
    for (v, view) in manifest.views.iter().enumerate() {
        let lit = view.frames.iter().find(|f| f.pattern == Pattern::White).unwrap();
        let img = rig::image::read_png(&dir.join(&lit.file)).unwrap();
        let truth = match rig::npy::read(&dir.join(format!("truth/view_{v:03}/corners.npy"))).unwrap().data {
            NpyData::F64(d) => d.chunks(2).map(|c| Point2::new(c[0], c[1])).collect::<Vec<_>>(),
            _ => panic!("corners.npy is f64"),
        };
        let Ok(b) = find_charuco(&img, cols as usize, rows as usize, square, &markers) else { continue };
        found_views += 1;
        shares.push(b.ids.len() as f64 / (cols * rows) as f64);
        for (id, p) in b.ids.iter().zip(&b.pixels) {
            let e = (p - truth[*id]).norm();
            assert!(e < 1.0, "view {v}: corner {id} found {e:.2} px from its truth");
            errors.push(e);
        }
    }
    errors.sort_by(f64::total_cmp);
    let mean = errors.iter().sum::<f64>() / errors.len() as f64;
    let most = shares.iter().copied().fold(0.0, f64::max);
    eprintln!(
        "ChArUco, half covered: board found in {found_views} of 12 views, at most {:.0} % of the corners in one; \
         corners against truth: mean {mean:.3} px, p95 {:.3} px over {}",
        100.0 * most,
        errors[errors.len() * 95 / 100],
        errors.len()
    );
    assert!(found_views >= 10, "{found_views}");
    assert!(most <= 0.6, "a view kept {:.0} % of its corners: the card hides too little", 100.0 * most);

    let (rig, report) = crate::calibrate_camera_from(
        &dir,
        BoardSpec { cols: cols as usize, rows: rows as usize, square_mm: square, markers: Some(markers) },
    );
    let (c, truth) = (rig.camera, cfg.rig.camera);
    let rms = report.camera.as_ref().unwrap().rms_px;
    eprintln!(
        "fx {:.2} (truth {:.2}, {:+.3} %), principal point ({:.2}, {:.2}) against ({:.2}, {:.2}); RMS {rms:.3} px",
        c.fx,
        truth.fx,
        100.0 * (c.fx / truth.fx - 1.0),
        c.cx,
        c.cy,
        truth.cx,
        truth.cy
    );
    assert!((c.fx / truth.fx - 1.0).abs() < 0.005 && (c.fy / truth.fy - 1.0).abs() < 0.005, "{c:?}");
    assert!((c.cx - truth.cx).abs() < 2.0 && (c.cy - truth.cy).abs() < 2.0, "{c:?}");
}
