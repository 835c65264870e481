//! Views run several at once: the same files and report as one at a time whatever the pool — a
//! pool of one thread that the caller itself runs on (the Python bindings' case) included — with
//! progress on the calling thread, and the error of the lowest failing view.

use process::{ProcessParams, Stage, process_scan};
use rig::Method;
use sim::{Albedo, ScanOptions, Scene, SimConfig, simulate_scan};
use std::path::{Path, PathBuf};

fn scan(name: &str, views: u32) -> fixtures::TempDir {
    let mut cfg = SimConfig::builtin("structured-light").unwrap().with_camera_resolution(160, 128);
    cfg.scan.views = views;
    let vase = sim::fluted_vase(120.0);
    let scene = Scene::on_turntable(&cfg, &vase, Albedo::Constant(0.8));
    let scan = fixtures::temp_dir(name);
    let opts = ScanOptions { method: Method::StructuredLight, seed: 5, truth: false };
    simulate_scan(&cfg, &scene, Some(&vase), opts, &scan, |_, _| {}).unwrap();
    scan
}

/// Processes `scan` into `out` on a pool of `threads` (`None`: the global pool, from this thread);
/// returns the progress calls.
fn run(scan: &Path, out: &Path, params: &ProcessParams, threads: Option<usize>) -> Vec<(usize, usize)> {
    let mut calls = Vec::new();
    let mut go = || {
        let caller = std::thread::current().id();
        process_scan(scan, out, params, |_, done, total| {
            assert_eq!(std::thread::current().id(), caller, "progress is called on the calling thread");
            calls.push((done, total));
        })
        .unwrap()
    };
    let report = match threads {
        Some(n) => rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap().install(go),
        None => go(),
    };
    assert_eq!(report.views.iter().map(|v| v.view).collect::<Vec<_>>(), (0..6).collect::<Vec<_>>());
    assert!(report.views_seconds.is_some());
    // The phase's peak covers every view's own (each view's section read and reset the mark).
    if let Some(phase) = report.views_peak_mb {
        let views = report.views.iter().filter_map(|v| v.denoise.as_ref().and_then(|s| s.peak_mb));
        views.for_each(|p| assert!(p <= phase, "a view peaked at {p} MB, the phase at {phase}"));
    }
    calls
}

#[test]
fn views_at_once_write_what_one_at_a_time_writes_on_any_pool() {
    let scan = scan("views-at-once", 6);
    let params = ProcessParams { until: Stage::Denoise, ..Default::default() };
    let outs: Vec<PathBuf> = ["one", "three", "global"].iter().map(|n| scan.join(n)).collect();
    for (out, threads) in outs.iter().zip([Some(1), Some(3), None]) {
        let calls = run(&scan, out, &params, threads);
        assert_eq!(calls.len(), 6, "{threads:?}: {calls:?}");
        assert_eq!(calls.last(), Some(&(6, 6)), "{threads:?}");
    }
    for v in 0..6 {
        for name in [format!("views/view_{v:03}.ply"), format!("denoised/view_{v:03}.ply")] {
            let one = std::fs::read(outs[0].join(&name)).unwrap();
            for out in &outs[1..] {
                assert!(std::fs::read(out.join(&name)).unwrap() == one, "{name} in {}", out.display());
            }
        }
    }
}

#[test]
fn the_lowest_failing_view_is_the_one_named() {
    let scan = scan("views-at-once-fail", 6);
    for v in [2, 4] {
        std::fs::write(scan.join(format!("frames/view_{v:03}/00_white.png")), b"not a png").unwrap();
    }
    let out = scan.join("out");
    let params = ProcessParams { until: Stage::Denoise, ..Default::default() };
    let err = process_scan(&scan, &out, &params, |_, _, _| {}).unwrap_err().to_string();
    assert!(err.contains("view_002") && !err.contains("view_004"), "{err}");
    // The views before it finished and were kept.
    assert!(out.join("denoised/view_000.ply").is_file() && out.join("denoised/view_001.ply").is_file());
}
