//! Frames kept as another scanner's camera captured them — on its side, mirrored — with the rig's
//! `[image]` saying how to turn them (issue 21): processing turns them on reading and gives the
//! same points as frames stored already turned, for laser and structured-light scans alike.

use process::{ProcessParams, process_scan};
use rig::Method;
use rig::image::ImageTransform;
use rig::scan_folder::Manifest;
use sim::{Albedo, ScanOptions, Scene, SimConfig, simulate_scan};

/// Simulates `method` on `cfg`, then copies the scan with every frame stored as a camera mounted by
/// `turn` would have captured it (the inverse of `turn`) and the rig saying `turn`. Returns both.
fn native_and_captured(
    cfg: &SimConfig,
    method: Method,
    name: &str,
    turn: ImageTransform,
) -> (fixtures::TempDir, fixtures::TempDir) {
    let vase = sim::fluted_vase(cfg.scene.object_size_mm);
    let scene = Scene::on_turntable(cfg, &vase, Albedo::Constant(cfg.scene.object_albedo));
    let native = fixtures::temp_dir(&format!("{name}-native"));
    simulate_scan(cfg, &scene, None, ScanOptions { method, seed: 8, truth: false }, &native, |_, _| {}).unwrap();
    let captured = fixtures::temp_dir(&format!("{name}-captured"));
    let m = Manifest::read(&native).unwrap();
    for view in &m.views {
        for f in &view.frames {
            let img = rig::image::read_image(&native.join(&f.file)).unwrap();
            // turned = vflip(hflip(transpose(raw))): undo in reverse order.
            let mut raw = img;
            if turn.vflip {
                raw = raw.flipped();
            }
            if turn.hflip {
                raw = raw.mirrored();
            }
            if turn.transpose {
                raw = raw.transposed();
            }
            assert_eq!(raw.transformed(&turn), rig::image::read_image(&native.join(&f.file)).unwrap());
            let path = captured.join(&f.file);
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            rig::image::write_png(&path, &raw, true).unwrap();
        }
    }
    m.write(&captured).unwrap();
    let mut rig = rig::Rig::read(&native.join(&m.rig)).unwrap();
    rig.image = turn;
    rig.write(&captured.join(&m.rig)).unwrap();
    (native, captured)
}

/// Both scans processed up to the merge: their merged clouds.
fn merged_both(native: &std::path::Path, captured: &std::path::Path) -> (rig::PointCloud, rig::PointCloud) {
    let params = ProcessParams { until: process::Stage::Merge, ..Default::default() };
    let merged = |scan: &std::path::Path| {
        process_scan(scan, &scan.join("processed"), &params, |_, _, _| {}).unwrap();
        rig::ply::read_cloud(&scan.join("processed/merged.ply")).unwrap()
    };
    (merged(native), merged(captured))
}

#[test]
fn laser_frames_stored_as_captured_give_the_same_points() {
    let mut cfg = SimConfig::builtin("laser").unwrap().with_camera_resolution(320, 240);
    cfg.scan.views = 4;
    let turn = ImageTransform { transpose: true, hflip: true, vflip: false };
    let (native, captured) = native_and_captured(&cfg, Method::Laser, "turned-laser", turn);
    let (a, b) = merged_both(&native, &captured);
    assert!(a.len() > 500, "{} points", a.len());
    assert_eq!(a.positions, b.positions, "point for point");
    // Without the rig's [image], the captured frames do not fit the camera: refused, not misread.
    let mut rig = rig::Rig::read(&captured.join("rig.toml")).unwrap();
    rig.image = ImageTransform::default();
    rig.write(&captured.join("rig.toml")).unwrap();
    let params = ProcessParams { until: process::Stage::Merge, ..Default::default() };
    let err = process_scan(&captured, &captured.join("processed2"), &params, |_, _, _| {}).unwrap_err().to_string();
    assert!(err.contains("240×320") || err.contains("width_px"), "{err}");
}

#[test]
fn structured_light_frames_stored_as_captured_give_the_same_points() {
    let mut cfg = SimConfig::builtin("structured-light").unwrap().with_camera_resolution(320, 256);
    cfg.scan.views = 2;
    let turn = ImageTransform { transpose: false, hflip: true, vflip: true };
    let (native, captured) = native_and_captured(&cfg, Method::StructuredLight, "turned-sl", turn);
    let (a, b) = merged_both(&native, &captured);
    assert!(a.len() > 5000, "{} points", a.len());
    assert_eq!(a.positions, b.positions, "point for point");
}
