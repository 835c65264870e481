//! Issue 19: inputs users get wrong are refused with a message naming what is wrong, or handled; no
//! panic, no wrong result with exit code 0.

use std::process::{Command, Output};

fn scanrig(args: &[&dyn AsRef<std::ffi::OsStr>]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_scanrig"));
    cmd.env("RUST_BACKTRACE", "1");
    for a in args {
        cmd.arg(a);
    }
    cmd.output().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// No panic message or backtrace reached the user.
fn no_panic(o: &Output) {
    let err = stderr(o);
    assert!(!err.contains("panicked") && !err.contains("stack backtrace"), "{err}");
}

#[test]
fn a_rig_of_another_camera_size_is_named_not_a_panic() {
    let d = fixtures::temp_dir("bad-rig-size");
    let scan = d.join("scan");
    let o = scanrig(&[&"sim", &"--views", &"1", &"--resolution", &"320x256", &"--no-truth", &"--out", &scan]);
    assert!(o.status.success(), "{}", stderr(&o));
    let rig_path = scan.join("rig.toml");
    for (w, h) in [(640u32, 512u32), (4_294_967_295, 4_294_967_295)] {
        let mut rig = rig::Rig::read(&rig_path).unwrap();
        rig.camera.width = w;
        rig.camera.height = h;
        rig.write(&rig_path).unwrap();
        let o = scanrig(&[&"process", &scan, &"--until", &"triangulate"]);
        assert!(!o.status.success());
        no_panic(&o);
        let want = format!("the frames are 320×256 pixels but the rig's camera is {w}×{h}");
        assert!(stderr(&o).contains(&want), "{}", stderr(&o));
    }
}

#[test]
fn a_corrupt_cached_projector_map_is_made_again() {
    let d = fixtures::temp_dir("bad-cached-map");
    let scan = d.join("scan");
    let o = scanrig(&[&"sim", &"--views", &"1", &"--resolution", &"320x256", &"--no-truth", &"--out", &scan]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = scanrig(&[&"process", &scan, &"--until", &"triangulate"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let grid = rig::ply::read_range_grid(&scan.join("processed/views/view_000.ply")).unwrap();
    // Values far out of range where the map was decoded: the record's hash no longer matches, so the
    // map is decoded again rather than trusted.
    let path = scan.join("processed/decode/view_000.npy");
    let mut map = rig::npy::read(&path).unwrap();
    if let rig::npy::NpyData::F64(v) = &mut map.data {
        v.iter_mut().filter(|x| x.is_finite()).for_each(|x| *x = -1e30);
    }
    rig::npy::write(&path, &map).unwrap();
    let o = scanrig(&[&"process", &scan, &"--until", &"triangulate", &"--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    no_panic(&o);
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let why = report["views"][0]["decode"]["reason"].as_str().unwrap_or_default();
    assert!(why.contains("changed since it was written"), "{report}");
    let again = rig::ply::read_range_grid(&scan.join("processed/views/view_000.ply")).unwrap();
    assert_eq!(again.valid_count(), grid.valid_count());
}
