//! Issue 37 at the command line: readers that keep or refuse, inputs that are not files, rigs and
//! manifests checked where they are read. Each run that could hang runs under a time limit.

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::run::scanrig;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Runs `scanrig ARGS` and kills it after `limit`: `None` means it hung.
fn scanrig_within(limit: Duration, args: &[&dyn AsRef<std::ffi::OsStr>]) -> Option<Output> {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_scanrig"));
    cmd.stdin(Stdio::null()).stdout(Stdio::piped()).stderr(Stdio::piped());
    for a in args {
        cmd.arg(a);
    }
    let mut child = cmd.spawn().unwrap();
    let start = Instant::now();
    while start.elapsed() < limit {
        if child.try_wait().unwrap().is_some() {
            let o = child.wait_with_output().unwrap();
            crate::run::no_panic(&o, args);
            return Some(o);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let _ = child.kill();
    let _ = child.wait();
    None
}

fn mkfifo(path: &Path) {
    assert!(Command::new("mkfifo").arg(path).status().unwrap().success());
}

const LIMIT: Duration = Duration::from_secs(60);

/// `convert` refused the .e57 input its help lists: it reads it.
#[test]
fn convert_reads_the_e57_its_help_lists() {
    let d = fixtures::temp_dir("convert-e57");
    let cloud = rig::PointCloud {
        colors: Some(vec![[10, 20, 30]; 50]),
        ..rig::PointCloud::from_positions((0..50).map(|i| rig::Point3::new(i as f64, 2.0, -3.5)).collect())
    };
    rig::e57::write_cloud(&d.join("c.e57"), &cloud).unwrap();
    let o = scanrig(&[&"convert", &d.join("c.e57"), &d.join("c.ply")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let back = rig::ply::read_cloud(&d.join("c.ply")).unwrap();
    assert_eq!(back.len(), 50);
    assert_eq!(back.colors.unwrap()[0], [10, 20, 30]);
    assert!((back.positions[7] - cloud.positions[7]).norm() < 1e-4);
}

/// What a reader cannot keep is printed as a warning naming the file.
#[test]
fn convert_prints_what_a_reader_did_not_keep() {
    let d = fixtures::temp_dir("convert-warn");
    std::fs::write(d.join("m.obj"), "v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let o = scanrig(&[&"convert", &d.join("m.obj"), &d.join("m.ply")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("warning:") && err.contains("m.obj") && err.contains("1 of 3 vertices"), "{err}");
    // And what the output's format cannot hold (a hostile user's probe: said nowhere before): a
    // cloud's confidence in E57, a quad mesh's quads in STL (and how many triangles were written).
    let mut cloud = rig::PointCloud::from_positions((0..20).map(|k| rig::Point3::new(k as f64, 0.0, 1.0)).collect());
    cloud.confidence = Some(vec![0.5; 20]);
    rig::ply::write_cloud(&d.join("c.ply"), &cloud, &Default::default()).unwrap();
    let o = scanrig(&[&"convert", &d.join("c.ply"), &d.join("c.e57")]);
    let err = stderr(&o);
    assert!(o.status.success() && err.contains("c.e57: the points' confidence"), "{err}");
    std::fs::write(d.join("q.obj"), "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
    let o = scanrig(&[&"convert", &d.join("q.obj"), &d.join("q.stl")]);
    let (err, out) = (stderr(&o), String::from_utf8_lossy(&o.stdout).into_owned());
    assert!(
        o.status.success() && err.contains("its faces of four or more corners (1) are written as triangles"),
        "{err}"
    );
    assert!(out.contains("1 faces (2 triangles written)"), "{out}");
}

/// `convert z.ply y.ply` with z.ply a link to /dev/zero grew by 1 GB/s: refused at once.
#[test]
fn convert_refuses_a_link_to_dev_zero() {
    let d = fixtures::temp_dir("convert-zero");
    let z = d.join("z.ply");
    std::os::unix::fs::symlink("/dev/zero", &z).unwrap();
    let o = scanrig_within(LIMIT, &[&"convert", &z, &d.join("y.ply")]).expect("convert hung on /dev/zero");
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains("z.ply") && err.contains("character device, not a file"), "{err}");
    assert!(!d.join("y.ply").exists());
}

/// A FIFO in place of scan.json, or of a frame: refused, not waited on.
#[test]
fn process_refuses_a_fifo_in_place_of_the_manifest_or_a_frame() {
    let d = fixtures::temp_dir("fifo-scan");
    let scan = d.join("scan");
    let o = scanrig(&[&"sim", &"--views", &"1", &"--resolution", &"160x128", &"--no-truth", &"--out", &scan]);
    assert!(o.status.success(), "{}", stderr(&o));
    // A frame replaced by a FIFO.
    let m = rig::Manifest::read(&scan).unwrap();
    let frame = scan.join(&m.views[0].frames[2].file);
    std::fs::remove_file(&frame).unwrap();
    mkfifo(&frame);
    let o =
        scanrig_within(LIMIT, &[&"process", &scan, &"--until", &"triangulate"]).expect("process hung on a FIFO frame");
    assert!(!o.status.success());
    let err = stderr(&o);
    let name = frame.file_name().unwrap().to_string_lossy().into_owned();
    assert!(err.contains(&name) && err.contains("FIFO"), "{err}");
    // The manifest replaced by a FIFO.
    std::fs::remove_file(scan.join("scan.json")).unwrap();
    mkfifo(&scan.join("scan.json"));
    let o = scanrig_within(LIMIT, &[&"process", &scan]).expect("process hung on a FIFO scan.json");
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains("scan.json") && err.contains("FIFO"), "{err}");
}

/// Distortion 1e30 in rig.toml kept 1.4 % of the points with exit 0; `angle_deg 1e308` in scan.json
/// went through: both refused when read, naming the file and the field.
#[test]
fn process_refuses_a_rig_or_manifest_no_scanner_has() {
    let d = fixtures::temp_dir("bad-rig-values");
    let scan = d.join("scan");
    let o = scanrig(&[&"sim", &"--views", &"2", &"--resolution", &"160x128", &"--no-truth", &"--out", &scan]);
    assert!(o.status.success(), "{}", stderr(&o));
    let rig_path = scan.join("rig.toml");
    let good = std::fs::read_to_string(&rig_path).unwrap();
    let distortion = good.lines().find(|l| l.starts_with("distortion")).unwrap().to_string();
    std::fs::write(&rig_path, good.replace(&distortion, "distortion = [1e30, 0.0, 0.0, 0.0, 0.0]")).unwrap();
    let o = scanrig(&[&"process", &scan]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains("rig.toml") && err.contains("camera.distortion") && err.contains("k1"), "{err}");
    std::fs::write(&rig_path, &good).unwrap();
    let mut m: serde_json::Value = serde_json::from_slice(&std::fs::read(scan.join("scan.json")).unwrap()).unwrap();
    m["views"][1]["angle_deg"] = 1e308.into();
    std::fs::write(scan.join("scan.json"), serde_json::to_vec(&m).unwrap()).unwrap();
    let o = scanrig(&[&"process", &scan]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains("scan.json") && err.contains("views[1].angle_deg"), "{err}");
}

/// A FabScanPi config with `turntable.radius` 0 (dropped in silence) or distortion 1e30: refused by
/// `import`, naming the field.
#[test]
fn import_refuses_a_fabscan_config_no_scanner_has() {
    let Some(real) = fixtures::data_file("fabscanpi-calibration/dummy.config.json") else { return };
    let d = fixtures::temp_dir("import-bad-config");
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(real).unwrap()).unwrap();
    for (name, edit, field) in [
        ("radius0.json", ("turntable", "radius", serde_json::json!(0)), "turntable.radius"),
        (
            "dist.json",
            ("calibration", "distortion_vector", serde_json::json!([1e30, 0, 0, 0, 0])),
            "calibration.distortion_vector",
        ),
    ] {
        let mut w = v.clone();
        w[edit.0][edit.1] = edit.2;
        let path = d.join(name);
        std::fs::write(&path, serde_json::to_vec(&w).unwrap()).unwrap();
        let out = d.join(format!("{name}.toml"));
        let o = scanrig(&[&"import", &"fabscan", &path, &"-o", &out]);
        assert!(!o.status.success(), "{name}");
        let err = stderr(&o);
        assert!(err.contains(field), "{name}: {err}");
        assert!(!out.exists());
    }
}

/// A camera whose principal point lies outside its image, imported from OpenCV YAML: refused naming
/// the file and the field, and no rig is written.
#[test]
fn calibrate_import_refuses_a_principal_point_outside_the_image() {
    let d = fixtures::temp_dir("import-yaml-pp");
    let mut cam = rig::PinholeCamera::ideal(640, 480, 500.0);
    cam.cx = 900.0;
    let yaml = d.join("cam.yml");
    std::fs::write(&yaml, rig::opencv_yaml::camera_to_string(&cam)).unwrap();
    let out = d.join("rig.toml");
    let o = scanrig(&[&"calibrate", &"import", &yaml, &"-o", &out]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains("cam.yml") && err.contains("`camera`") && err.contains("outside the 640×480 image"), "{err}");
    assert!(!out.exists());
}
