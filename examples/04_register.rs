//! 04 — Register two real scans (the Stanford bunny's bun045 onto bun000) from a start 10° and 7.5 mm
//! off, by point-to-plane ICP (thesis ch. 2.2), and measure the result against the scanner's own
//! alignment (`bun.conf`).
//!
//! `cargo run --release --example 04_register` (needs `../shared/data`; says so and stops without it)

use process::kd_tree::PointTree;
use process::normals::pca_normals;
use process::register::icp::{IcpParams, IcpTarget, icp};
use rig::math::{Point3, Vector3};

fn main() {
    let (Some(poses), Some((moving, _)), Some((fixed, boundary))) =
        (fixtures::bunny_poses_mm(), fixtures::bunny_scan_mm("bun045"), fixtures::bunny_scan_mm("bun000"))
    else {
        println!("SKIPPED: the Stanford bunny is not in ../shared/data");
        return;
    };
    let (truth, fixed_pose) = (poses["bun045"], poses["bun000"]);
    // Normals from each scan's own neighbours; the target in the common frame bun.conf gives.
    let normals = |p: &[Point3]| pca_normals(p, &PointTree::new(p), 10, |_| Vector3::z());
    let target_points: Vec<Point3> = fixed.iter().map(|p| fixed_pose * p).collect();
    let target_normals = normals(&fixed).iter().map(|n| fixed_pose.rotation * n).collect();
    let target = IcpTarget::new(target_points, target_normals, Some(boundary));
    let start = fixtures::icp_bench_start(&moving, &truth);
    let (found, report) = icp(&moving, &normals(&moving), &target, &start, &IcpParams::default()).unwrap();
    let angle = |a: &rig::Isometry3| (a.rotation.inverse() * truth.rotation).angle().to_degrees();
    let shift = |a: &rig::Isometry3| (a.translation.vector - truth.translation.vector).norm();
    println!(
        "bun045 onto bun000: start {:.2}° / {:.2} mm from bun.conf, registered {:.3}° / {:.3} mm ({} iterations, fitness {:.2})",
        angle(&start),
        shift(&start),
        angle(&found),
        shift(&found),
        report.iterations,
        report.fitness
    );
    assert!(angle(&found) < 0.5 && shift(&found) < 1.0, "ICP did not come back to the scanner's alignment");
}
