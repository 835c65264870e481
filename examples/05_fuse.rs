//! 05 — Fuse a noisy, outlier-ridden sampling of a sphere by mean shift (thesis ch. 3) and measure
//! how far the points lie from the sphere before and after.
//!
//! `cargo run --release --example 05_fuse`

use process::pipeline::stages::{FuseParams, fuse};
use rig::PointCloud;
use rig::math::Point3;

fn main() {
    let radius = 40.0;
    let mut rng = fixtures::Rng::new(5);
    let mut positions = Vec::new();
    // Three overlapping "views" of the same surface, each with 0.3 mm of noise along the normal.
    for _ in 0..3 {
        for _ in 0..30_000 {
            let n = rng.direction();
            positions.push(Point3::from(n * (radius + 0.3 * rng.gaussian())));
        }
    }
    // 1 % stray points scattered around it.
    for _ in 0..900 {
        positions.push(Point3::from(rng.direction() * radius * (1.2 + rng.uniform())));
    }
    let off = |c: &PointCloud| {
        let d: Vec<f64> = c.positions.iter().map(|p| (p.coords.norm() - radius).abs()).collect();
        (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt()
    };
    let cloud = PointCloud::from_positions(positions);
    let before = off(&cloud);
    let (fused, report) = fuse(cloud, &FuseParams::default()).unwrap();
    let after = off(&fused.cloud);
    println!(
        "{} points in, {} out ({} removed as outliers): RMS distance to the sphere {before:.3} mm before, {after:.3} mm after",
        report.mean_shift.points_in,
        fused.cloud.len(),
        report.points_removed
    );
    assert!(after < 0.5 * before, "fusion did not bring the points onto the surface");
}
