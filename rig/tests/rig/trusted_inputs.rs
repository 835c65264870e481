//! Issue 37, "readers that keep or refuse" and "rigs and manifests checked where they are read": each
//! defect of the issue as a test. Inputs that are not files (a FIFO, a link to /dev/zero) are refused
//! at once, under a time limit; rigs with values no scanner has are refused naming the file and field.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Runs `f` on a thread and fails if it has not returned within `limit` (a hang is a failure, not a
/// test that never ends).
fn within<T: Send + 'static>(limit: Duration, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(limit).expect("the reader hung (no answer within the time limit)")
}

fn mkfifo(path: &Path) {
    let ok = std::process::Command::new("mkfifo").arg(path).status().expect("mkfifo runs").success();
    assert!(ok, "mkfifo {}", path.display());
}

// ---- Inputs that are not files -------------------------------------------------------------------

/// A FIFO in place of scan.json, of a rig, of a frame or of a mesh: refused at once, naming the path.
#[test]
fn a_fifo_in_place_of_any_input_is_refused_without_hanging() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_path_buf();
    for name in ["scan.json", "rig.toml", "frame.png", "frame.jpg", "cloud.ply", "mesh.obj", "m.stl", "c.e57", "m.glb"]
    {
        mkfifo(&d.join(name));
    }
    let started = Instant::now();
    let errors: Vec<String> = within(Duration::from_secs(20), move || {
        vec![
            rig::Manifest::read(&d).unwrap_err().to_string(),
            rig::Rig::read(&d.join("rig.toml")).unwrap_err().to_string(),
            rig::image::read_image(&d.join("frame.png")).unwrap_err().to_string(),
            rig::image::read_image(&d.join("frame.jpg")).unwrap_err().to_string(),
            rig::read_cloud(&d.join("cloud.ply")).unwrap_err().to_string(),
            rig::read_mesh(&d.join("mesh.obj")).unwrap_err().to_string(),
            rig::read_mesh(&d.join("m.stl")).unwrap_err().to_string(),
            rig::read_cloud(&d.join("c.e57")).unwrap_err().to_string(),
            rig::read_mesh(&d.join("m.glb")).unwrap_err().to_string(),
            rig::input::read_regular(&d.join("m.glb"), None).unwrap_err().to_string(),
        ]
    });
    assert!(started.elapsed() < Duration::from_secs(5));
    for e in errors {
        assert!(e.contains("is a FIFO (named pipe), not a file"), "{e}");
    }
}

/// `convert z.ply y.ply` with z.ply a link to /dev/zero grew by 1 GB/s: refused at once.
#[test]
fn a_link_to_dev_zero_is_refused_without_reading() {
    let dir = tempfile::tempdir().unwrap();
    let z = dir.path().join("z.ply");
    std::os::unix::fs::symlink("/dev/zero", &z).unwrap();
    let zz = z.clone();
    let e = within(Duration::from_secs(20), move || rig::read_cloud(&zz).unwrap_err().to_string());
    assert!(e.contains("z.ply") && e.contains("is a character device, not a file"), "{e}");
    // A link to a regular file reads as the file.
    let real = dir.path().join("real.obj");
    std::fs::write(&real, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let link = dir.path().join("link.obj");
    std::os::unix::fs::symlink(&real, &link).unwrap();
    assert_eq!(rig::read_mesh(&link).unwrap().face_count(), 1);
}

// ---- Readers that keep or refuse -----------------------------------------------------------------

fn ply_with_colours(ty: &str, values: [&str; 3]) -> Vec<u8> {
    format!(
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n\
         property {ty} red\nproperty {ty} green\nproperty {ty} blue\nend_header\n0 0 0 {} {} {}\n",
        values[0], values[1], values[2]
    )
    .into_bytes()
}

/// 16-bit PLY colours were clamped to 255 (a mid grey came out white): they are scaled.
#[test]
fn sixteen_bit_ply_colours_are_scaled_not_clamped() {
    let cloud = |b: Vec<u8>| rig::ply::cloud_from_ply(&rig::ply::parse(&b).unwrap());
    let c = cloud(ply_with_colours("ushort", ["65535", "32768", "0"])).unwrap();
    assert_eq!(c.colors.unwrap()[0], [255, 128, 0]);
    let c = cloud(ply_with_colours("uchar", ["255", "128", "0"])).unwrap();
    assert_eq!(c.colors.unwrap()[0], [255, 128, 0]);
    let c = cloud(ply_with_colours("float", ["1", "0.5", "0"])).unwrap();
    assert_eq!(c.colors.unwrap()[0], [255, 128, 0]);
    // Floats written 0–255 are read as such; an `int` colour of 300 is refused, not clamped.
    let c = cloud(ply_with_colours("float", ["255", "128", "0"])).unwrap();
    assert_eq!(c.colors.unwrap()[0], [255, 128, 0]);
    let e = cloud(ply_with_colours("int", ["300", "0", "0"])).unwrap_err().to_string();
    assert!(e.contains("colour `red` 300 is outside 0–255") && e.contains("element `vertex` #0"), "{e}");
}

/// OBJ vertex colours written 0–255 read as white: they are read as 8-bit values.
#[test]
fn obj_colours_written_0_to_255_are_not_white() {
    let obj = rig::obj::parse(b"v 0 0 0 255 128 0\nv 1 0 0 0 0 255\nv 0 1 0 10 20 30\nf 1 2 3\n").unwrap();
    assert_eq!(obj.colors.unwrap(), vec![[255, 128, 0], [0, 0, 255], [10, 20, 30]]);
    let obj = rig::obj::parse(b"v 0 0 0 1 0.5 0\n").unwrap();
    assert_eq!(obj.colors.unwrap(), vec![[255, 128, 0]]);
    let e = rig::obj::parse(b"v 0 0 0 255 0 0\nv 1 0 0 -1 0 0\n").unwrap_err().to_string();
    assert!(e.contains("line 2") && e.contains("outside 0–255"), "{e}");
    // Colours on some vertices only are named in a warning.
    let obj = rig::obj::parse(b"v 0 0 0 1 0 0\nv 1 0 0\n").unwrap();
    assert!(obj.colors.is_none());
    assert!(obj.warnings.iter().any(|w| w.contains("1 of 2 vertices")), "{:?}", obj.warnings);
}

/// GLB normals fewer than positions were dropped in silence: refused, naming the attribute.
#[test]
fn glb_normals_fewer_than_positions_are_refused() {
    let v = [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0]].map(rig::Point3::from).to_vec();
    let mut mesh = rig::PolyMesh::from_faces(v, [[0u32, 1, 2]]);
    mesh.normals = Some(vec![rig::Vector3::z(); 3]);
    let bytes = rig::glb::mesh_to_bytes(&mesh);
    let (back, warnings) = rig::glb::parse_reported(&bytes).unwrap();
    assert!(back.normals.is_some() && warnings.is_empty());
    // The NORMAL accessor's count cut to 2 in the JSON chunk (same length: the digit is replaced).
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json = String::from_utf8(bytes[20..20 + json_len].to_vec()).unwrap();
    let normal_accessor = 1;
    let accessors: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(accessors["meshes"][0]["primitives"][0]["attributes"]["NORMAL"], normal_accessor);
    let needle = "\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}";
    // POSITION's accessor carries its bounds between `count` and `type`: the first match is NORMAL's.
    let at = json.find(needle).expect("the NORMAL accessor as written");
    let mut cut = bytes.clone();
    let digit = 20 + at + "\"componentType\":5126,\"count\":".len();
    assert_eq!(cut[digit], b'3');
    cut[digit] = b'2';
    let e = rig::glb::parse(&cut).unwrap_err().to_string();
    assert!(e.contains("NORMAL holds 2 entries for its 3 positions"), "{e}");
}

/// Every real JPEG in the shared data decodes without a complaint; each with 30 bytes flipped in its
/// entropy-coded data is refused (it decoded without a word).
#[test]
fn real_jpegs_decode_and_damaged_ones_are_refused() {
    let Some(dir) = fixtures::data_file("fabscanpi-scan-sample/frames/20210213-230202_000.jpg")
        .and_then(|p| p.parent().map(Path::to_path_buf))
    else {
        return;
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
    if let Some(cal) = fixtures::data_file("fabscanpi-calibration/calibration_8x10/calibration_003.jpg") {
        files.extend(std::fs::read_dir(cal.parent().unwrap()).unwrap().map(|e| e.unwrap().path()).take(12));
    }
    files.retain(|p| rig::image::is_image_file(p) && p.extension().is_some_and(|e| e == "jpg"));
    files.sort();
    assert!(!files.is_empty());
    for (n, path) in files.iter().enumerate() {
        let bytes = std::fs::read(path).unwrap();
        rig::image::decode_jpeg(&bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let scan = bytes.windows(2).rposition(|w| w == [0xFF, 0xDA]).unwrap() + 32;
        let end = bytes.len() - 2;
        let mut bad = bytes.clone();
        let mut state = n as u64 + 1;
        for _ in 0..30 {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            bad[scan + (state >> 33) as usize % (end - scan)] ^= 0xFF;
        }
        let e = rig::image::decode_jpeg(&bad).unwrap_err().to_string();
        assert!(e.contains("corrupt JPEG data"), "{}: {e}", path.display());
    }
}

// ---- Rigs and manifests checked where they are read ----------------------------------------------

const RIG: &str = r#"format = 1
name = "desk"
[camera]
width_px = 1280
height_px = 1024
fx_px = 1400.0
fy_px = 1400.0
cx_px = 639.5
cy_px = 511.5
distortion = [0.1, -0.2, 0.001, 0.001, 0.05]
[[lasers]]
name = "left"
normal = [0.866, 0.0, 0.5]
distance_mm = 150.0
[turntable]
axis_point_mm = [0.0, 60.0, 400.0]
axis_direction = [0.0, -1.0, 0.0]
platter_radius_mm = 100.0
"#;

fn rig_error(edit: (&str, &str)) -> String {
    assert!(RIG.contains(edit.0), "{}", edit.0);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rig.toml");
    std::fs::write(&path, RIG.replace(edit.0, edit.1)).unwrap();
    rig::Rig::read(&path).unwrap_err().to_string()
}

/// Values no scanner has, written in rig.toml, refused naming the file and the field.
#[test]
fn rig_toml_values_no_scanner_has_are_refused() {
    assert!(rig::Rig::from_toml_str(RIG).is_ok());
    let cases = [
        (("[0.1, -0.2", "[1e30, -0.2"), "camera.distortion", "k1"),
        (("0.001, 0.001, 0.05]", "0.001, 0.001, -5e3]"), "camera.distortion", "k3"),
        (("0.001, 0.001, 0.05]", "2.0, 0.001, 0.05]"), "camera.distortion", "p1"),
        (("cx_px = 639.5", "cx_px = 5000.0"), "camera", "outside the 1280×1024 image"),
        (("cy_px = 511.5", "cy_px = -40.0"), "camera", "outside the 1280×1024 image"),
        (("platter_radius_mm = 100.0", "platter_radius_mm = 0.0"), "turntable.platter_radius_mm", "positive"),
        (("platter_radius_mm = 100.0", "platter_radius_mm = -5.0"), "turntable.platter_radius_mm", "positive"),
        (
            ("axis_point_mm = [0.0, 60.0, 400.0]", "axis_point_mm = [0.0, 60.0, -400.0]"),
            "turntable.axis_point_mm",
            "in front",
        ),
        (("distance_mm = 150.0", "distance_mm = 0.0"), "lasers[0]", "camera's centre"),
    ];
    for ((from, to), field, says) in cases {
        let e = rig_error((from, to));
        assert!(e.contains("rig.toml") && e.contains(&format!("field `{field}`")) && e.contains(says), "{to}: {e}");
    }
    // A plane entirely behind the camera: z = −150 (n = +z, d = −150).
    let e = rig_error((
        "normal = [0.866, 0.0, 0.5]\ndistance_mm = 150.0",
        "normal = [0.0, 0.0, 1.0]\ndistance_mm = -150.0",
    ));
    assert!(e.contains("field `lasers[0]`") && e.contains("behind the camera"), "{e}");
}

fn fabscan_config(edit: impl Fn(&mut serde_json::Value)) -> String {
    let text = include_str!("../fixtures/fabscan_config.json");
    let mut v: serde_json::Value = serde_json::from_str(text).unwrap();
    edit(&mut v);
    v.to_string()
}

/// Distortion 1e30, a principal point outside the image, a radius of 0 or below, imported from
/// FabScanPi and Horus configurations: refused naming the field.
#[test]
fn scanner_configs_with_values_no_scanner_has_are_refused() {
    use rig::scanner_calibration::{rig_from_fabscan, rig_from_horus};
    assert!(rig_from_fabscan(&fabscan_config(|_| {})).is_ok());
    let e = rig_from_fabscan(&fabscan_config(|v| v["calibration"]["distortion_vector"][0] = 1e30.into()))
        .unwrap_err()
        .to_string();
    assert!(e.contains("calibration.distortion_vector") && e.contains("k1"), "{e}");
    for r in [0.0, -70.0] {
        let e = rig_from_fabscan(&fabscan_config(|v| v["turntable"]["radius"] = r.into())).unwrap_err().to_string();
        assert!(e.contains("field `turntable.radius`") && e.contains("positive"), "{r}: {e}");
    }
    let horus = include_str!("../fixtures/horus_settings.json");
    assert!(rig_from_horus(horus).is_ok());
    let mut v: serde_json::Value = serde_json::from_str(horus).unwrap();
    v["calibration_settings"]["distortion_vector"]["value"][4] = 1e30.into();
    let e = rig_from_horus(&v.to_string()).unwrap_err().to_string();
    assert!(e.contains("calibration_settings.distortion_vector") && e.contains("k3"), "{e}");
    let mut v: serde_json::Value = serde_json::from_str(horus).unwrap();
    v["calibration_settings"]["camera_matrix"]["value"][0][2] = 1e5.into();
    let e = rig_from_horus(&v.to_string()).unwrap_err().to_string();
    assert!(e.contains("calibration_settings.camera_matrix") && e.contains("outside"), "{e}");
}

/// The real FabScanPi configuration stays accepted.
#[test]
fn the_real_fabscanpi_config_is_accepted() {
    let Some(path) = fixtures::data_file("fabscanpi-calibration/dummy.config.json") else { return };
    let rig = rig::scanner_calibration::rig_from_fabscan(&std::fs::read_to_string(path).unwrap()).unwrap();
    rig.validate().unwrap();
}

/// `angle_deg 1e308` (or NaN, inf) in scan.json: refused naming the view.
#[test]
fn a_manifest_angle_no_turntable_has_is_refused() {
    let m = rig::Manifest::fresh(rig::Method::Laser, "test", None, &[0.0, 90.0], &[]);
    let json = serde_json::to_string(&m).unwrap();
    assert!(rig::Manifest::from_json(json.as_bytes()).is_ok());
    for bad in ["1e308", "-4000", "1e400"] {
        let text = json.replacen("90.0", bad, 1);
        let e = rig::Manifest::from_json(text.as_bytes()).unwrap_err().to_string();
        assert!(e.contains("views[1].angle_deg") || e.contains("line"), "{bad}: {e}");
        if bad != "1e400" {
            assert!(e.contains("views[1].angle_deg") && e.contains("not a turntable angle"), "{bad}: {e}");
        }
    }
}

/// Passes: a further pass's views number on and say their pass; a pass that skips one, comes back
/// or is 0 is refused naming the view.
#[test]
fn a_manifest_of_passes_numbers_on_and_refuses_passes_out_of_order() {
    let patterns = [rig::Pattern::White, rig::Pattern::Black];
    let mut m = rig::Manifest::fresh(rig::Method::StructuredLight, "test", None, &[0.0, 90.0], &patterns);
    m.append_pass(2, &[0.0, 90.0], &patterns);
    assert_eq!(m.passes(), 2);
    assert_eq!(m.views[2].frames[1].file, "frames/view_002/01_black.png");
    let json = serde_json::to_string(&m).unwrap();
    let back = rig::Manifest::from_json(json.as_bytes()).unwrap();
    assert_eq!(back.views.iter().map(|v| v.pass).collect::<Vec<_>>(), [1, 1, 2, 2]);
    for (view, pass) in [(2, 3), (0, 0), (3, 1), (2, 7)] {
        let mut bad = m.clone();
        bad.views[view].pass = pass;
        let e = rig::Manifest::from_json(serde_json::to_string(&bad).unwrap().as_bytes()).unwrap_err().to_string();
        assert!(e.contains(".pass") && e.contains("passes count from 1"), "view {view} pass {pass}: {e}");
    }
    // A scan whose first view is of pass 2 has no pass 1 to place the others by.
    let mut second_only = m.clone();
    second_only.views.iter_mut().for_each(|v| v.pass = 2);
    let e = rig::Manifest::from_json(serde_json::to_string(&second_only).unwrap().as_bytes()).unwrap_err().to_string();
    assert!(e.contains("views[0].pass") && e.contains("opens the scan"), "{e}");
}

/// OFF's per-vertex extras and face colours are named, not dropped in silence.
#[test]
fn off_extras_that_are_not_kept_are_named() {
    let (m, w) =
        rig::off::parse_reported(b"COFF\n3 1 0\n0 0 0 1 0 0 1\n1 0 0 1 0 0 1\n0 1 0 1 0 0 1\n3 0 1 2 255 0 0\n")
            .unwrap();
    assert_eq!(m.face_count(), 1);
    assert!(w.iter().any(|w| w.contains("colours (COFF)")), "{w:?}");
    assert!(w.iter().any(|w| w.contains("colours of 1 faces")), "{w:?}");
    let (_, w) = rig::off::parse_reported(b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").unwrap();
    assert!(w.is_empty(), "{w:?}");
}
