//! 03 — Denoise a noisy range grid with the non-local filter (thesis ch. 4) and with the bilateral
//! baseline, and compare both with the truth.
//!
//! `cargo run --release --example 03_denoise`

use process::denoise::{DenoiseParams, Similarity, denoise};
use rig::math::{Isometry3, Point3};
use rig::{RangeGrid, Sensor};
use sim::{Albedo, Mount, Part, PartKind, Scene, SimConfig};

fn main() {
    let cfg = SimConfig::builtin("structured-light").expect("a built-in config").with_camera_resolution(640, 480);
    // The vase held in front of the camera, seen exactly (truth), then with noise along the normals.
    let vase = sim::fluted_vase(120.0);
    let pose = Isometry3::new(rig::Vector3::new(0.0, 60.0, 380.0), rig::Vector3::new(-1.9, 0.0, 0.0));
    let part = Part {
        kind: PartKind::Object,
        surface: Box::new(sim::MeshSurface::new(&vase)),
        pose,
        mount: Mount::Fixed,
        albedo: Albedo::Constant(0.8),
    };
    let g = sim::view_geometry(
        &Scene { parts: vec![part] },
        &cfg,
        &sim::pixel_rays(&cfg.rig.camera),
        &Isometry3::identity(),
    );
    let mut noisy = RangeGrid::empty(g.width, g.height, Sensor::Center(Point3::origin()));
    let mut rng = fixtures::Lcg::new(12345);
    for i in 0..g.kind.len() {
        if g.kind[i] != 0 {
            let u = rng.uniform() - 0.5;
            noisy.points[i] = g.point[i] + g.normal[i] * (0.8 * u);
            noisy.valid[i] = true;
        }
    }
    let rms = |grid: &RangeGrid| {
        let d: Vec<f64> = (0..grid.points.len())
            .filter(|&i| grid.valid[i])
            .map(|i| (grid.points[i] - g.point[i]).dot(&g.normal[i]).powi(2))
            .collect();
        (d.iter().sum::<f64>() / d.len() as f64).sqrt()
    };
    let (non_local, report) = denoise(&noisy, &DenoiseParams::default()).unwrap();
    let (bilateral, _) =
        denoise(&noisy, &DenoiseParams { similarity: Similarity::Bilateral, ..Default::default() }).unwrap();
    println!(
        "{} points, bandwidths d {:.3} mm s {:.3} mm: RMS to truth raw {:.4} mm, bilateral {:.4} mm, non-local {:.4} mm ({:.2} s)",
        report.points,
        report.d[0],
        report.s[0],
        rms(&noisy),
        rms(&bilateral),
        rms(&non_local),
        report.seconds
    );
    assert!(rms(&non_local) < rms(&bilateral) && rms(&bilateral) < rms(&noisy));
}
