//! Other scanners' calibration files (issue 21): FabScanPi's config.json and Horus' settings.json to a
//! rig and back, number for number; what cannot be right refused naming the field.

use rig::scanner_calibration::{Scanner, merge_into, rig_from_fabscan, rig_from_horus, rig_to_fabscan, rig_to_horus};
use serde_json::Value;

const FABSCAN: &str = include_str!("../fixtures/fabscan_config.json");
const HORUS: &str = include_str!("../fixtures/horus_settings.json");

fn json(text: &str) -> Value {
    serde_json::from_str(text).unwrap()
}

/// The numbers a FabScanPi config's calibration holds, as they must come back from an export.
fn fabscan_numbers(v: &Value) -> Vec<(String, Value)> {
    let c = &v["calibration"];
    let mut out: Vec<(String, Value)> =
        ["camera_matrix", "distortion_vector", "platform_translation", "platform_rotation"]
            .iter()
            .map(|k| (k.to_string(), c[k].clone()))
            .collect();
    for (k, p) in c["laser_planes"].as_array().unwrap().iter().enumerate() {
        out.push((format!("laser_planes[{k}].normal"), p["normal"].clone()));
        out.push((format!("laser_planes[{k}].distance"), p["distance"].clone()));
    }
    for k in ["resolution", "rotate", "hflip", "vflip"] {
        out.push((format!("camera.{k}"), v["camera"][k].clone()));
    }
    for k in ["radius", "height"] {
        // FabScanPi writes whole millimetres as integers; the export writes numbers.
        out.push((format!("turntable.{k}"), Value::from(v["turntable"][k].as_f64().unwrap())));
    }
    out.push(("laser.numbers".into(), v["laser"]["numbers"].clone()));
    out.push(("laser.color".into(), v["laser"]["color"].clone()));
    out
}

fn assert_same_numbers(original: &str, exported: &str) {
    let (a, b) = (fabscan_numbers(&json(original)), fabscan_numbers(&json(exported)));
    for ((k, x), (_, y)) in a.iter().zip(&b) {
        assert_eq!(x, y, "{k} changed in the round trip");
    }
}

#[test]
fn a_fabscan_config_becomes_a_rig_and_exports_to_the_same_numbers() {
    let rig = rig_from_fabscan(FABSCAN).unwrap();
    // The camera is the turned image's: 1640×1232 transposed.
    assert_eq!((rig.camera.width, rig.camera.height), (1232, 1640));
    assert!(rig.image.transpose && rig.image.hflip && !rig.image.vflip);
    assert_eq!((rig.camera.fx, rig.camera.fy, rig.camera.cx, rig.camera.cy), (1250.5, 1251.75, 615.25, 820.0));
    assert_eq!(rig.camera.distortion.to_opencv(), [0.12, -0.2, 0.001, -0.002, 0.05]);
    assert_eq!(rig.lasers.len(), 2);
    assert_eq!(rig.lasers[0].plane.normal.into_inner(), rig::Vector3::new(0.8, 0.0, 0.6));
    assert_eq!(rig.lasers[1].plane.distance, -79.5);
    let axis = rig.turntable.unwrap();
    assert_eq!(axis.point, rig::Point3::new(-4.5, 40.25, 140.0));
    assert_eq!(axis.direction.into_inner(), rig::Vector3::new(0.0, -1.0, 0.0), "the platform's z, up");
    assert_eq!((rig.platter_radius_mm, rig.working_height_mm), (Some(70.0), Some(155.0)));
    let exported = rig_to_fabscan(&rig).unwrap();
    assert_same_numbers(FABSCAN, &exported);
    // And the rig itself round-trips through the export, and through its own TOML.
    assert_eq!(rig_from_fabscan(&exported).unwrap(), rig);
    let text = rig.to_toml_string();
    assert_eq!(rig::Rig::from_toml_str(&text).unwrap(), rig, "{text}");
}

#[test]
fn the_real_fabscanpi_config_round_trips_exactly() {
    let Some(path) = fixtures::data_file("fabscanpi-calibration/dummy.config.json") else { return };
    let text = std::fs::read_to_string(path).unwrap();
    let rig = rig_from_fabscan(&text).unwrap();
    assert_eq!((rig.camera.fx, rig.camera.fy, rig.camera.cx, rig.camera.cy), (1319.597, 1322.35, 625.54, 808.36));
    assert_eq!((rig.camera.width, rig.camera.height), (1232, 1640));
    assert_eq!(rig.lasers.len(), 1);
    assert_eq!(rig.lasers[0].plane.distance, 77.47936416348523);
    let exported = rig_to_fabscan(&rig).unwrap();
    assert_same_numbers(&text, &exported);
    // Digit for digit (JSON numbers are read correctly rounded, `float_roundtrip`).
    assert!(exported.contains("0.9999798704209543") && exported.contains("-0.9996893086175519"), "{exported}");
    assert_eq!(rig_from_fabscan(&exported).unwrap(), rig);
    let toml = rig.to_toml_string();
    assert_eq!(rig::Rig::from_toml_str(&toml).unwrap(), rig, "through the rig file too");
}

/// An export laid over the scanner's own file keeps what a rig does not hold (FabScanPi reads its
/// whole configuration from that one file: its turntable's steps, calibration board, folders) and
/// takes every number the rig does hold.
#[test]
fn an_export_into_the_scanners_own_file_keeps_the_rest() {
    let mut other = rig_from_horus(HORUS).unwrap();
    other.platter_radius_mm = Some(90.0);
    let mut own = json(FABSCAN);
    own["turntable"]["steps"] = 6400.into();
    own["calibration"]["pattern"] = serde_json::json!({ "rows": 8, "columns": 10, "square_size": 7 });
    own["folders"] = serde_json::json!({ "scans": "/fabscan/scans/" });
    own["laser"]["interleaved"] = "True".into();
    let merged = json(&merge_into(&own.to_string(), &rig_to_fabscan(&other).unwrap(), Scanner::Fabscan).unwrap());
    assert_eq!(merged["laser"]["interleaved"], "True", "how the scanner captures is its own");
    assert_eq!(merged["turntable"]["steps"], 6400, "kept");
    assert_eq!(merged["calibration"]["pattern"]["rows"], 8, "kept");
    assert_eq!(merged["folders"]["scans"], "/fabscan/scans/", "kept");
    assert_eq!(merged["turntable"]["radius"], 90.0, "the rig's");
    let back = rig_from_fabscan(&merged.to_string()).unwrap();
    assert_eq!((&back.camera, &back.lasers, back.turntable), (&other.camera, &other.lasers, other.turntable));
    // Horus' other categories stay too.
    let mut horus = json(HORUS);
    horus["profile_settings"] = serde_json::json!({ "laser_threshold_value": { "value": 50 } });
    let merged = json(&merge_into(&horus.to_string(), &rig_to_horus(&other).unwrap(), Scanner::Horus).unwrap());
    assert_eq!(merged["profile_settings"]["laser_threshold_value"]["value"], 50);
    let back = rig_from_horus(&merged.to_string()).unwrap();
    assert_eq!((&back.camera, &back.lasers, back.turntable), (&other.camera, &other.lasers, other.turntable));
    // A one-laser rig over a two-laser Horus file: no stale right-hand plane is left behind.
    let mut one = other.clone();
    one.lasers.truncate(1);
    let merged = merge_into(HORUS, &rig_to_horus(&one).unwrap(), Scanner::Horus).unwrap();
    assert!(json(&merged)["calibration_settings"].get("normal_right").is_none(), "{merged}");
    let planes = |r: &rig::Rig| r.lasers.iter().map(|l| l.plane).collect::<Vec<_>>();
    assert_eq!(planes(&rig_from_horus(&merged).unwrap()), planes(&one));
    // The other scanner's file, or not an object at all, is refused.
    let cases = [
        (HORUS, rig_to_fabscan(&other).unwrap(), Scanner::Fabscan),
        (FABSCAN, rig_to_horus(&other).unwrap(), Scanner::Horus),
    ];
    for (base, ours, scanner) in cases {
        let e = merge_into(base, &ours, scanner).unwrap_err().to_string();
        assert!(e.contains("not this scanner's file"), "{e}");
    }
    assert!(merge_into("[1, 2]", &rig_to_horus(&other).unwrap(), Scanner::Horus).is_err());
    assert!(merge_into("{", &rig_to_horus(&other).unwrap(), Scanner::Horus).is_err());
}

proptest::proptest! {
    /// Any laser rig with a turntable exports to either scanner's file and reads back the same.
    #[test]
    fn random_rigs_round_trip_through_both_files(
        f in 300.0f64..3000.0, cx in 0.45f64..0.55, cy in 0.45f64..0.55, d in proptest::array::uniform5(-0.5f64..0.5),
        n in proptest::array::uniform3(-1.0f64..1.0), dist in -300.0f64..300.0, lasers in 1usize..=2,
        point in proptest::array::uniform3(-200.0f64..400.0), tilt in -0.3f64..0.3, flags in proptest::array::uniform3(proptest::bool::ANY),
    ) {
        proptest::prop_assume!(rig::Vector3::from(n).norm() > 0.1);
        let image = rig::image::ImageTransform { transpose: flags[0], hflip: flags[1], vflip: flags[2] };
        let (w, h) = image.size(1280, 960);
        let camera = rig::PinholeCamera { width: w, height: h, fx: f, fy: f * 1.001, cx: cx * w as f64, cy: cy * h as f64, distortion: rig::Distortion::from_opencv(d) };
        let plane = rig::LaserPlane::new(rig::Vector3::from(n), dist).unwrap();
        let rig = rig::Rig {
            name: "r".into(),
            camera,
            projector: None,
            lasers: (0..lasers).map(|k| rig::Laser { name: ["left", "right"][k].into(), plane, colour: rig::LaserColour::Red }).collect(),
            turntable: Some(rig::TurntableAxis {
                // The platter in front of the camera, as on every scanner (`Rig::validate`).
                point: rig::Point3::new(point[0], point[1], point[2].abs().max(50.0)),
                direction: rig::UnitVector3::new_normalize(rig::Vector3::new(tilt, -1.0, 0.1)),
            }),
            platter_radius_mm: Some(70.0),
            working_height_mm: None,
            image,
            platform_rotation: None,
        };
        // Laser planes behind the camera, or through its centre, are no scanner's (`Rig::validate`).
        proptest::prop_assume!(rig.validate().is_ok());
        // The first export fixes the platform rotation; from then on every number stays.
        let once = rig_from_horus(&rig_to_horus(&rig).unwrap()).unwrap();
        // The axis is normalised on reading (rotations are built from it): equal to the last bits. (Compared
        // by difference: `angle` is an arccosine, which turns a last-bit change into 1e-8.)
        let (a, b) = (once.turntable.unwrap(), rig.turntable.unwrap());
        proptest::prop_assert_eq!(a.point, b.point);
        proptest::prop_assert!((a.direction.into_inner() - b.direction.into_inner()).norm() < 1e-12);
        proptest::prop_assert_eq!(&once.camera, &rig.camera);
        proptest::prop_assert_eq!(rig_from_horus(&rig_to_horus(&once).unwrap()).unwrap(), once.clone());
        let fab = rig_from_fabscan(&rig_to_fabscan(&once).unwrap()).unwrap();
        proptest::prop_assert_eq!(rig::Rig { name: once.name.clone(), platter_radius_mm: None, ..fab }, rig::Rig { platter_radius_mm: None, ..once });
    }
}

#[test]
fn a_horus_settings_file_imports_and_its_export_reads_back_identical() {
    let rig = rig_from_horus(HORUS).unwrap();
    // Horus' defaults: 1280×960 captured, turned on its side: 960 wide, 1280 high.
    assert_eq!((rig.camera.width, rig.camera.height), (960, 1280));
    assert_eq!((rig.camera.cx, rig.camera.cy), (480.0, 620.0));
    assert_eq!(rig.lasers.iter().map(|l| l.name.as_str()).collect::<Vec<_>>(), ["left", "right"]);
    assert_eq!(rig.lasers[0].plane.normal.into_inner(), rig::Vector3::new(0.866025404, 0.0, 0.5), "kept as written");
    let exported = rig_to_horus(&rig).unwrap();
    let back = rig_from_horus(&exported).unwrap();
    assert_eq!(back, rig);
    assert_eq!(rig_to_horus(&back).unwrap(), exported, "export → import → export is identical");
    let (a, b) = (json(HORUS), json(&exported));
    for key in a["calibration_settings"].as_object().unwrap().keys().filter(|k| *k != "estimated_size") {
        assert_eq!(a["calibration_settings"][key], b["calibration_settings"][key], "{key}");
    }
    // One scanner's rig exports as the other's and comes back the same.
    let via_fabscan = rig_from_fabscan(&rig_to_fabscan(&rig).unwrap()).unwrap();
    assert_eq!(rig::Rig { name: rig.name.clone(), ..via_fabscan }, rig);
}

#[test]
fn a_rig_of_our_own_exports_to_both_and_comes_back() {
    // A rig scanrig calibrated has no platform rotation of its own: the export makes one from the
    // axis, and from then on the numbers stay.
    let mut rig = rig_from_horus(HORUS).unwrap();
    rig.platform_rotation = None;
    let once = rig_from_horus(&rig_to_horus(&rig).unwrap()).unwrap();
    assert_eq!(once.turntable, rig.turntable);
    let r = once.platform_rotation.unwrap();
    let at_zero = rig.turntable.unwrap().object_from_camera_at_zero().rotation.to_rotation_matrix();
    assert!((r - at_zero.matrix().transpose()).norm() < 1e-12, "the platform frame is scanrig's object frame at 0°");
    assert_eq!(rig_from_horus(&rig_to_horus(&once).unwrap()).unwrap(), once);
    rig.turntable = None;
    assert!(rig_to_horus(&rig).unwrap_err().contains("[turntable]"));
    assert!(rig_to_fabscan(&rig).unwrap_err().contains("[turntable]"));
}

/// Replaces the JSON value at `path` (dotted, `[i]` for list entries) in `text`, or removes it.
fn edit(text: &str, path: &str, value: Option<Value>) -> String {
    let mut v = json(text);
    let mut keys: Vec<String> = Vec::new();
    for part in path.split('.') {
        match part.split_once('[') {
            Some((k, i)) => {
                keys.push(k.into());
                keys.push(format!("#{}", i.trim_end_matches(']')));
            }
            None => keys.push(part.into()),
        }
    }
    let (last, parents) = keys.split_last().unwrap();
    let mut node = &mut v;
    for k in parents {
        node = match k.strip_prefix('#') {
            Some(i) => &mut node[i.parse::<usize>().unwrap()],
            None => &mut node[k.as_str()],
        };
    }
    match (last.strip_prefix('#'), value) {
        (Some(i), Some(x)) => node[i.parse::<usize>().unwrap()] = x,
        (Some(i), None) => {
            node.as_array_mut().unwrap().remove(i.parse().unwrap());
        }
        (None, Some(x)) => node[last.as_str()] = x,
        (None, None) => {
            node.as_object_mut().unwrap().remove(last.as_str());
        }
    }
    serde_json::to_string(&v).unwrap()
}

#[test]
fn malformed_scanner_files_are_refused_naming_the_field() {
    use serde_json::json;
    let fab: Vec<(&str, String, &str)> = vec![
        ("not JSON", "{ \"calibration\": ".into(), "line 1"),
        ("no calibration", edit(FABSCAN, "calibration", None), "calibration"),
        ("two lasers, one plane", edit(FABSCAN, "calibration.laser_planes[1]", None), "laser.numbers"),
        (
            "a plane without a normal",
            edit(FABSCAN, "calibration.laser_planes[0].normal", None),
            "laser_planes[0].normal",
        ),
        ("a zero normal", edit(FABSCAN, "calibration.laser_planes[1].normal", Some(json!([0, 0, 0]))), "laser_planes"),
        (
            "a normal of two numbers",
            edit(FABSCAN, "calibration.laser_planes[0].normal", Some(json!([1, 0]))),
            "laser_planes[0].normal",
        ),
        (
            "a distance as text",
            edit(FABSCAN, "calibration.laser_planes[0].distance", Some(json!("80"))),
            "laser_planes[0].distance",
        ),
        (
            "skew in the camera",
            edit(FABSCAN, "calibration.camera_matrix[0]", Some(json!([1250.5, 2.0, 615.25]))),
            "calibration.camera_matrix",
        ),
        ("a 2-row camera matrix", edit(FABSCAN, "calibration.camera_matrix[2]", None), "calibration.camera_matrix"),
        (
            "size against the camera (no rotate)",
            edit(FABSCAN, "camera.rotate", Some(json!("False"))),
            "calibration.camera_matrix",
        ),
        ("a flag that is neither", edit(FABSCAN, "camera.hflip", Some(json!("maybe"))), "camera.hflip"),
        ("a zero width", edit(FABSCAN, "camera.resolution.width", Some(json!(0))), "camera.resolution.width"),
        ("no resolution", edit(FABSCAN, "camera.resolution", None), "camera.resolution.width"),
        (
            "four distortion terms",
            edit(FABSCAN, "calibration.distortion_vector", Some(json!([0.1, 0.0, 0.0, 0.0]))),
            "calibration.distortion_vector",
        ),
        (
            "a platform that is no rotation",
            edit(FABSCAN, "calibration.platform_rotation[0]", Some(json!([2.0, 0.0, 0.0]))),
            "calibration.platform_rotation",
        ),
        ("an unknown laser colour", edit(FABSCAN, "laser.color", Some(json!("IR"))), "laser.color"),
        (
            "a NaN-like focal length",
            edit(FABSCAN, "calibration.camera_matrix[0]", Some(json!([-5.0, 0.0, 615.25]))),
            "calibration.camera_matrix",
        ),
    ];
    for (what, text, field) in &fab {
        let e = rig_from_fabscan(text).expect_err(what).to_string();
        assert!(e.contains(field), "{what}: `{e}` does not name {field}");
    }
    let horus: Vec<(&str, String, &str)> = vec![
        ("no calibration settings", edit(HORUS, "calibration_settings", None), "not a Horus settings.json"),
        (
            "a setting without its value wrapper",
            edit(HORUS, "calibration_settings.camera_matrix", Some(json!([[1.0]]))),
            "calibration_settings.camera_matrix",
        ),
        (
            "a left normal without its distance",
            edit(HORUS, "calibration_settings.distance_left", None),
            "distance_left",
        ),
        (
            "an uncalibrated right laser",
            edit(HORUS, "calibration_settings.normal_right.value", Some(json!([0.0, 0.0, 0.0]))),
            "normal_right",
        ),
        (
            "a rotation that is a reflection",
            edit(
                HORUS,
                "calibration_settings.rotation_matrix.value",
                Some(json!([[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])),
            ),
            "rotation_matrix",
        ),
        (
            "a principal point outside the image",
            edit(HORUS, "calibration_settings.camera_width.value", Some(json!(400))),
            "camera_matrix",
        ),
    ];
    for (what, text, field) in &horus {
        let e = rig_from_horus(text).expect_err(what).to_string();
        assert!(e.contains(field), "{what}: `{e}` does not name {field}");
    }
    assert!(fab.len() + horus.len() >= 15);
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
    /// Any set of file names in a FabScanPi frame folder is either whole positions (each with every
    /// laser's frame; positions missing whole are named) or refused, never a panic; an accepted one
    /// lists every frame once.
    #[test]
    fn fabscan_frame_folders_are_whole_or_refused(
        names in proptest::collection::vec("(s|t)_[0-9]{1,4}\\.(jpg|png|txt)|x", 0..12), lasers in 1usize..3,
    ) {
        let d = tempfile::tempdir().unwrap();
        let dir = d.path().join("raw_laser_raw");
        std::fs::create_dir_all(&dir).unwrap();
        for n in &names {
            std::fs::write(dir.join(n), b"").unwrap();
        }
        if let Ok(f) = rig::fabscan_scan::find_frames(d.path(), lasers) {
            let all: Vec<&String> = f.files.iter().flatten().collect();
            proptest::prop_assert!(f.files.iter().all(|p| p.len() == lasers));
            let mut unique = all.clone();
            unique.dedup();
            proptest::prop_assert_eq!(unique.len(), all.len());
            // Any step: views inside one turn at angles in [0°, 360°), or refused.
            for step in [0.0, 3.6, 45.0, 400.0] {
                if let Ok((m, _)) = rig::fabscan_scan::manifest(&f, step, "frames", "t", d.path()) {
                    proptest::prop_assert!(m.views.iter().all(|v| (0.0..360.0).contains(&v.angle_deg)));
                    proptest::prop_assert!(m.views.len() <= f.positions.len());
                }
            }
        }
    }
}

#[test]
fn a_horus_point_cloud_reads_as_a_coloured_cloud() {
    // Horus writes binary little-endian PLY: float x, y, z and uchar red, green, blue (PROTOCOLS.md).
    let mut bytes = b"ply\nformat binary_little_endian 1.0\ncomment Generated by Horus\nelement vertex 2\n\
property float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
element face 0\nproperty list uchar int vertex_indices\nend_header\n"
        .to_vec();
    for (p, c) in [([1.5f32, -2.0, 30.25], [255u8, 10, 0]), ([0.0, 4.0, 8.0], [1, 2, 3])] {
        p.iter().for_each(|v| bytes.extend(v.to_le_bytes()));
        bytes.extend(c);
    }
    let cloud = rig::ply::cloud_from_ply(&rig::ply::parse(&bytes).unwrap()).unwrap();
    assert_eq!(cloud.positions, vec![rig::Point3::new(1.5, -2.0, 30.25), rig::Point3::new(0.0, 4.0, 8.0)]);
    assert_eq!(cloud.colors, Some(vec![[255, 10, 0], [1, 2, 3]]));
}
