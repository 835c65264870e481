//! Simulator throughput: frames per second of a structured-light scan of a ~100 K-triangle mesh at
//! 640 × 480 and 1280 × 1024, PNG encoding and writing included (everything `scanrig sim` does).
//!
//! `cargo bench -p sim --bench render` — prints one line per case with the median of 3 runs.

use rig::Method;
use sim::{Albedo, ScanOptions, Scene, SimConfig, simulate_scan};

fn main() {
    let base = SimConfig::builtin("structured-light").unwrap();
    // 250 × 200 side vertices: 100,000 side triangles + 400 cap triangles.
    let mesh = sim::fluted_vase_tessellated(120.0, 250, 200);
    let out = std::env::temp_dir().join(format!("sim-bench-{}", std::process::id()));
    println!("mesh: {} triangles; {} rayon threads", mesh.faces.len(), rayon::current_num_threads());
    for (w, h) in [(640, 480), (1280, 1024)] {
        let mut cfg = base.clone().with_camera_resolution(w, h);
        cfg.scan.views = 4;
        let scene = Scene::on_turntable(&cfg, &mesh, Albedo::Constant(0.8));
        let mut runs = Vec::new();
        for _ in 0..3 {
            let _ = std::fs::remove_dir_all(&out);
            let opts = ScanOptions { method: Method::StructuredLight, seed: 1, truth: false };
            runs.push(simulate_scan(&cfg, &scene, None, opts, &out, |_, _| {}).unwrap());
        }
        runs.sort_by(|a, b| a.frames_per_second.total_cmp(&b.frames_per_second));
        let r = &runs[1];
        println!(
            "{w}x{h}: {:.1} frames/s (median of 3; {} frames in {:.2} s, ray casting {:.2} s = {:.0} ms/view)",
            r.frames_per_second,
            r.frames_written,
            r.total_seconds,
            r.geometry_seconds,
            1000.0 * r.geometry_seconds / r.views_rendered as f64
        );
    }
    let _ = std::fs::remove_dir_all(&out);
}
