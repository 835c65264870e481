//! A distributed run's per-view parts: each view processed alone in its own scratch folder, packed,
//! and adopted into the scan's output folder, after which the scan stages find every view current
//! and the outputs are byte for byte those of one whole run.

use process::pipeline::parts::{adopt, pack};
use process::{ProcessParams, Stage, process_scan};
use rig::Method;
use sim::{Albedo, ScanOptions, Scene, SimConfig, simulate_scan};

#[test]
fn views_processed_apart_and_adopted_give_the_whole_run_s_files() {
    let mut cfg = SimConfig::builtin("structured-light").unwrap().with_camera_resolution(160, 128);
    cfg.scan.views = 4;
    let vase = sim::fluted_vase(120.0);
    let scene = Scene::on_turntable(&cfg, &vase, Albedo::Constant(0.8));
    let scan = fixtures::temp_dir("process-parts");
    let opts = ScanOptions { method: Method::StructuredLight, seed: 3, truth: false };
    simulate_scan(&cfg, &scene, Some(&vase), opts, &scan, |_, _| {}).unwrap();
    let params = ProcessParams { until: Stage::Fuse, ..Default::default() };

    let whole = scan.join("whole");
    process_scan(&scan, &whole, &params, |_, _, _| {}).unwrap();

    // Each view on its own "worker", packed; the packs adopted in another order than made.
    let mut packs = Vec::new();
    for v in [2, 0, 3, 1] {
        let scratch = scan.join(format!("scratch_{v}"));
        let alone = ProcessParams { views: Some(vec![v]), until: Stage::Denoise, ..params.clone() };
        let r = process_scan(&scan, &scratch, &alone, |_, _, _| {}).unwrap();
        assert_eq!(r.views.len(), 1, "view {v} alone");
        packs.push(pack(&scratch).unwrap());
    }
    let out = scan.join("adopted");
    let written = adopt(&scan, &out, &packs).unwrap();
    assert!(written >= 4 * 3, "{written} files");
    let report = process_scan(&scan, &out, &params, |_, _, _| {}).unwrap();
    assert!(report.views.iter().all(|v| v.reused), "every view reused: {:?}", report.views);
    for name in ["merged.ply", "registered.ply", "fused.ply"] {
        let (a, b) = (std::fs::read(whole.join(name)).unwrap(), std::fs::read(out.join(name)).unwrap());
        assert!(a == b, "{name} differs from the whole run's");
    }

    // A view the scan does not have, and a pack that names a file outside its folder, are refused.
    let none = ProcessParams { views: Some(vec![7]), ..params.clone() };
    let err = process_scan(&scan, &scan.join("x"), &none, |_, _, _| {}).unwrap_err().to_string();
    assert!(err.contains("has no complete view 7 (4 views"), "{err}");
    let evil = vec![vec![("../escaped.ply".to_string(), b"ply".to_vec())]];
    let err = adopt(&scan, &out, &evil).unwrap_err().to_string();
    assert!(err.contains("../escaped.ply") && err.contains("not a path inside"), "{err}");
    assert!(!scan.join("escaped.ply").exists());
}
