//! `scanrig import` and `scanrig export` of other scanners' calibration files (issue 21), as a user
//! runs them: the real FabScanPi config through a rig file and back, Horus' layout both ways, and a
//! file that cannot be right refused by field with nothing written.

use crate::run::scanrig;
use serde_json::Value;

fn ok(o: &std::process::Output) -> String {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn fabscan_and_horus_files_go_through_rig_files_and_back() {
    let d = tempfile::tempdir().unwrap();
    let p = |n: &str| d.path().join(n);
    let config = match fixtures::data_file("fabscanpi-calibration/dummy.config.json") {
        Some(c) => c,
        None => {
            eprintln!("skipped the real config: ../shared/data is absent; using the test fixture");
            std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("rig/tests/fixtures/fabscan_config.json")
        }
    };
    let out = ok(&scanrig(&[&"import", &"fabscan", &config, &"-o", &p("fab.toml")]));
    assert!(out.contains("transpose true, hflip true"), "{out}");
    ok(&scanrig(&[&"export", &"fabscan", &p("fab.toml"), &"-o", &p("config.json")]));
    let (a, b): (Value, Value) = (
        serde_json::from_str(&std::fs::read_to_string(&config).unwrap()).unwrap(),
        serde_json::from_str(&std::fs::read_to_string(p("config.json")).unwrap()).unwrap(),
    );
    for key in ["camera_matrix", "distortion_vector", "laser_planes", "platform_rotation", "platform_translation"] {
        let strip = |v: &Value| match key {
            // FabScanPi also keeps each plane's fit deviation, which a rig has no place for.
            "laser_planes" => Value::from(
                v.as_array()
                    .unwrap()
                    .iter()
                    .map(|p| (p["normal"].clone(), p["distance"].clone()))
                    .map(|(n, d)| vec![n, d])
                    .collect::<Vec<_>>(),
            ),
            _ => v.clone(),
        };
        assert_eq!(strip(&a["calibration"][key]), strip(&b["calibration"][key]), "{key}");
    }
    // Alone the export says what it leaves out; into the scanner's own file it keeps the rest.
    let o = scanrig(&[&"export", &"fabscan", &p("fab.toml"), &"-o", &p("alone.json")]);
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stderr).contains("--into"), "{}", String::from_utf8_lossy(&o.stderr));
    let mut own = a.clone();
    own["turntable"]["steps"] = Value::from(6400);
    own["calibration"]["pattern"] = serde_json::json!({ "rows": 8, "columns": 10 });
    // The scanner's own file holds another calibration: the rig's numbers replace it.
    own["calibration"]["platform_translation"] = serde_json::json!([1.0, 2.0, 3.0]);
    std::fs::write(p("own.json"), own.to_string()).unwrap();
    let before = std::fs::read(p("own.json")).unwrap();
    ok(&scanrig(&[&"export", &"fabscan", &p("fab.toml"), &"--into", &p("own.json"), &"-o", &p("merged.json")]));
    let merged: Value = serde_json::from_str(&std::fs::read_to_string(p("merged.json")).unwrap()).unwrap();
    assert_eq!(
        (&merged["turntable"]["steps"], &merged["calibration"]["pattern"]["rows"]),
        (&Value::from(6400), &Value::from(8))
    );
    assert_eq!(merged["calibration"]["platform_translation"], a["calibration"]["platform_translation"]);
    assert_eq!(std::fs::read(p("own.json")).unwrap(), before, "the scanner's file is read, not written");
    // Written over itself: refused before anything is read.
    let o = scanrig(&[&"export", &"fabscan", &p("fab.toml"), &"--into", &p("own.json"), &"-o", &p("own.json")]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("--into"));
    assert_eq!(std::fs::read(p("own.json")).unwrap(), before);
    // The same rig as Horus settings, and back to an identical file.
    ok(&scanrig(&[&"export", &"horus", &p("fab.toml"), &"-o", &p("settings.json")]));
    ok(&scanrig(&[&"import", &"horus", &p("settings.json"), &"-o", &p("horus.toml")]));
    ok(&scanrig(&[&"export", &"horus", &p("horus.toml"), &"-o", &p("settings2.json")]));
    assert_eq!(std::fs::read(p("settings.json")).unwrap(), std::fs::read(p("settings2.json")).unwrap());

    // Wrong files: refused naming the field, and no rig left behind.
    let o = scanrig(&[&"import", &"horus", &p("config.json"), &"-o", &p("wrong.toml")]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("calibration_settings") && err.contains("config.json"), "{err}");
    let mut broken: Value = serde_json::from_str(&std::fs::read_to_string(p("config.json")).unwrap()).unwrap();
    broken["laser"]["numbers"] = Value::from(2);
    std::fs::write(p("broken.json"), broken.to_string()).unwrap();
    let o = scanrig(&[&"import", &"fabscan", &p("broken.json"), &"-o", &p("wrong.toml")]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("laser.numbers") && err.contains("plane"), "{err}");
    assert!(!p("wrong.toml").exists(), "a refused import wrote a rig");
    // A rig without a turntable cannot be either scanner's.
    let mut rig = rig::Rig::read(&p("fab.toml")).unwrap();
    rig.turntable = None;
    rig.platform_rotation = None;
    rig.write(&p("no_turntable.toml")).unwrap();
    let o = scanrig(&[&"export", &"horus", &p("no_turntable.toml"), &"-o", &p("x.json")]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("[turntable]"));
    assert!(!p("x.json").exists());
}

/// The simulator writes a laser scan as FabScanPi keeps one (frames on their side, mirrored, numbered
/// by position and laser, no laser-off frame) and its config.json; importing it gives a scan folder
/// whose merged cloud is the native one's byte for byte (FabScanPi's +angle being scanrig's −angle:
/// the other sign would mirror the object). Broken scan folders are refused with nothing left behind.
#[test]
fn a_fabscan_scan_folder_imports_to_the_native_scans_points() {
    let d = tempfile::tempdir().unwrap();
    let p = |n: &str| d.path().join(n);
    let native = p("native");
    ok(&scanrig(&[
        &"sim",
        &"--config",
        &"laser",
        &"--views",
        &"6",
        &"--resolution",
        &"320x240",
        &"--no-truth",
        &"--layout",
        &"fabscan",
        &"--out",
        &native,
    ]));
    let fab = native.join("fabscan/sim");
    let out = ok(&scanrig(&[&"import", &"fabscan", &fab, &"--step-deg", &"60", &"-o", &p("imported")]));
    assert!(out.contains("6 positions × 2 laser(s)"), "{out}");
    // FabScanPi records no laser-off frame: the native scan is processed without its own.
    let mut m = rig::Manifest::read(&native).unwrap();
    // FabScanPi's layout has no laser-off frame, and its colour frames are not imported yet.
    m.views
        .iter_mut()
        .for_each(|v| v.frames.retain(|f| !matches!(f.pattern, rig::Pattern::LaserOff | rig::Pattern::Texture)));
    m.write(&native).unwrap();
    for scan in [&native, &p("imported")] {
        ok(&scanrig(&[&"process", scan, &"--until", &"merge"]));
    }
    let (a, b) = (
        std::fs::read(native.join("processed/merged.ply")).unwrap(),
        std::fs::read(p("imported/processed/merged.ply")).unwrap(),
    );
    assert!(a.len() > 10_000);
    assert!(a == b, "the imported scan's merged cloud differs from the native one");
    // The frames are FabScanPi's files, unaltered.
    let imported = rig::Manifest::read(&p("imported")).unwrap();
    let first = &imported.views[0].frames[0].file;
    let name = std::path::Path::new(first).file_name().unwrap();
    assert_eq!(
        std::fs::read(p("imported").join(first)).unwrap(),
        std::fs::read(fab.join("raw_laser_raw").join(name)).unwrap()
    );

    // An existing output, a missing frame, a config of another camera: refused, nothing written.
    let o = scanrig(&[&"import", &"fabscan", &fab, &"--step-deg", &"60", &"-o", &p("imported")]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("exists"), "{}", String::from_utf8_lossy(&o.stderr));
    let broken = p("broken/sim");
    std::fs::create_dir_all(broken.join("raw_laser_raw")).unwrap();
    for e in std::fs::read_dir(fab.join("raw_laser_raw")).unwrap() {
        let e = e.unwrap();
        if e.file_name() != "sim_005.png" {
            std::fs::copy(e.path(), broken.join("raw_laser_raw").join(e.file_name())).unwrap();
        }
    }
    let config = native.join("fabscan/config.json");
    let o = scanrig(&[&"import", &"fabscan", &broken, &"--config", &config, &"--step-deg", &"60", &"-o", &p("x")]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("frame 005 is missing"), "{err}");
    let mut other: Value = serde_json::from_str(&std::fs::read_to_string(&config).unwrap()).unwrap();
    other["camera"]["resolution"] = serde_json::json!({"width": 640, "height": 480});
    other["calibration"]["camera_matrix"][0][2] = Value::from(240.0);
    other["calibration"]["camera_matrix"][1][2] = Value::from(320.0);
    std::fs::write(p("other.json"), other.to_string()).unwrap();
    let o =
        scanrig(&[&"import", &"fabscan", &fab, &"--config", &p("other.json"), &"--step-deg", &"60", &"-o", &p("x")]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("camera.resolution"), "{err}");
    assert!(!p("x").exists() && !p("x.partial").exists(), "a refused import left files");
}

/// Projector–camera calibration captures in the usual layout — a folder per board pose, Gray codes in
/// OpenCV order, white and black last — calibrate exactly as the same frames do through scanrig's own
/// capture folder; a pattern of pose folders works too, and a pose folder short of an image is
/// refused saying what it needs.
#[test]
fn opencv_pose_folders_calibrate_as_the_native_captures_do() {
    let d = tempfile::tempdir().unwrap();
    let p = |n: &str| d.path().join(n);
    let caps = p("caps");
    ok(&scanrig(&[
        &"sim",
        &"--board",
        &"9x6",
        &"--square",
        &"11",
        &"--resolution",
        &"640x512",
        &"--poses",
        &"5",
        &"--no-truth",
        &"--layout",
        &"opencv",
        &"--out",
        &caps,
    ]));
    // The native captures with the same frames: no phase shift (the pose layout has none).
    let mut m = rig::Manifest::read(&caps).unwrap();
    m.views.iter_mut().for_each(|v| v.frames.retain(|f| !matches!(f.pattern, rig::Pattern::Phase { .. })));
    m.write(&caps).unwrap();
    let args = |src: &dyn AsRef<std::ffi::OsStr>, out: &std::path::Path| {
        scanrig(&[&"calibrate", &"all", src, &"-o", &out, &"--square", &"11", &"--projector", &"1024x768"])
    };
    ok(&args(&caps, &p("native.toml")));
    ok(&args(&caps.join("opencv"), &p("poses.toml")));
    ok(&args(&caps.join("opencv/pose_*"), &p("glob.toml")));
    let native = rig::Rig::read(&p("native.toml")).unwrap();
    for other in ["poses.toml", "glob.toml"] {
        let r = rig::Rig::read(&p(other)).unwrap();
        assert_eq!(r.camera, native.camera, "{other}");
        let (a, b) = (r.projector.unwrap(), native.projector.unwrap());
        assert_eq!((a.lens, a.from_camera), (b.lens, b.from_camera), "{other}");
    }
    // Without --projector the size comes from the image count, with a note.
    let o = scanrig(&[&"calibrate", &"all", &caps.join("opencv"), &"-o", &p("inferred.toml"), &"--square", &"11"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && err.contains("taken as a 1024x1024 projector"), "{err}");
    let inferred = rig::Rig::read(&p("inferred.toml")).unwrap().projector.unwrap();
    assert_eq!(inferred.from_camera, native.projector.as_ref().unwrap().from_camera, "the size does not move the pose");
    std::fs::remove_file(caps.join("opencv/pose_02/graycode_17.png")).unwrap();
    let o = args(&caps.join("opencv"), &p("short.toml"));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("pose_02") && err.contains("41 images") && err.contains("needs 42"),
        "{err}"
    );
    assert!(!p("short.toml").exists());
}

/// The real FabScanPi sweep calibrates its laser planes through the import path: the rig imported
/// from its config.json says how its camera is mounted, so `calibrate` needs no --transpose or
/// --flip, and the rig it writes keeps the mounting for processing.
#[test]
fn the_fabscanpi_sweep_calibrates_through_the_imported_rig() {
    let Some(config) = fixtures::data_file("fabscanpi-calibration/dummy.config.json") else { return };
    let sweep = config.with_file_name("calibration_8x10");
    let d = tempfile::tempdir().unwrap();
    let p = |n: &str| d.path().join(n);
    ok(&scanrig(&[&"import", &"fabscan", &config, &"-o", &p("rig.toml")]));
    // The frames with laser lines (lit, laser 0, laser 1 from 067 to 115).
    std::fs::create_dir_all(p("sweep")).unwrap();
    for f in 67..=115 {
        let name = format!("calibration_{f:03}.jpg");
        std::fs::copy(sweep.join(&name), p("sweep").join(&name)).unwrap();
    }
    ok(&scanrig(&[
        &"calibrate",
        &"laser",
        &p("sweep"),
        &"--rig",
        &p("rig.toml"),
        &"-o",
        &p("lasers.toml"),
        &"--board",
        &"10x8",
        &"--square",
        &"7",
    ]));
    let (imported, calibrated) = (rig::Rig::read(&p("rig.toml")).unwrap(), rig::Rig::read(&p("lasers.toml")).unwrap());
    assert_eq!(calibrated.image, imported.image, "the mounting is kept");
    let (a, b) = (imported.lasers[0].plane, calibrated.lasers[0].plane);
    let angle = a.normal.angle(&b.normal).to_degrees();
    eprintln!(
        "FabScanPi laser 0 through the import path: {angle:.2}° and {:.2} mm from its config",
        (a.distance - b.distance).abs()
    );
    assert!(angle < 2.0 && (a.distance - b.distance).abs() < 2.0, "{angle}° / {} mm", a.distance - b.distance);
    assert_eq!(calibrated.lasers.len(), 2, "both lasers' planes from the sweep");
}
