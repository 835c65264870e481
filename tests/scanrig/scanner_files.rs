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
