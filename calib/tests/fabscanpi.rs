//! Issue 5, acceptance 2 (the camera): the FabScanPi's real calibration sweep — a 10 × 8 board of
//! 7 mm squares on the turntable, Raspberry Pi camera JPEGs, transposed then mirrored as that
//! scanner's software does — against the scanner's own calibration (fx 1319.597, fy 1322.35).

use calib::{CameraOptions, Gray, View, calibrate_camera, find_corners};
use rig::math::{Point3, Real};

#[test]
fn the_fabscanpi_sweep_calibrates_its_camera() {
    let Some(dir) =
        fixtures::data_file("fabscanpi-calibration/README.md").map(|p| p.with_file_name("calibration_8x10"))
    else {
        return;
    };
    // The lit pattern frames: 000–067, every third from 070 to 115, and 118–133.
    let frames: Vec<usize> = (0..=67).chain((70..=115).step_by(3)).chain(118..=133).collect();
    let object: Vec<Point3> =
        (0..8).flat_map(|j| (0..10).map(move |i| Point3::new(i as Real * 7.0, j as Real * 7.0, 0.0))).collect();
    let mut views = Vec::new();
    for &k in &frames {
        let img = rig::image::read_image(&dir.join(format!("calibration_{k:03}.jpg"))).unwrap();
        // Transposed, then mirrored left to right: `rotate: true, hflip: true` in its config.
        let img = img.transposed().mirrored();
        assert_eq!((img.width, img.height), (1232, 1640));
        if let Ok(image) = find_corners(&Gray::from_image(&img), 10, 8) {
            views.push(View { object: object.clone(), image });
        }
    }
    let c = calibrate_camera(&views, 1232, 1640, CameraOptions::default()).unwrap();
    eprintln!(
        "board in {} of {} pattern frames; fx {:.2} fy {:.2} cx {:.2} cy {:.2}, RMS {:.3} px",
        views.len(),
        frames.len(),
        c.camera.fx,
        c.camera.fy,
        c.camera.cx,
        c.camera.cy,
        c.rms
    );
    assert!(views.len() >= 60, "board found in {} frames", views.len());
    assert!((c.camera.fx - 1319.597).abs() <= 3.0, "fx {}", c.camera.fx);
    assert!((c.camera.fy - 1322.35).abs() <= 3.0, "fy {}", c.camera.fy);
    assert!(c.rms <= 1.0, "rms {}", c.rms);
}
