//! ICP speed on the real bunny: bun045 → bun000 from bun.conf perturbed by 10° and 7.5 mm, median of 15
//! registrations (target tree built once, as the pipeline does), plus the target set-up.
//!
//! `cargo bench -p process --bench icp` — skips with a message where ../shared/data is absent.

use process::kd_tree::PointTree;
use process::normals::pca_normals;
use process::register::icp::{IcpParams, IcpTarget, icp};
use rig::math::{Point3, Vector3};
use std::time::Instant;

fn main() {
    let (Some(poses), Some((mp, _)), Some((fp, fb))) =
        (fixtures::bunny_poses_mm(), fixtures::bunny_scan_mm("bun045"), fixtures::bunny_scan_mm("bun000"))
    else {
        return;
    };
    let (pm, pf) = (poses["bun045"], poses["bun000"]);
    let mn = pca_normals(&mp, &PointTree::new(&mp), 10, |_| Vector3::z());
    let t0 = Instant::now();
    let fixed: Vec<Point3> = fp.iter().map(|p| pf * p).collect();
    let fnorm = pca_normals(&fp, &PointTree::new(&fp), 10, |_| Vector3::z()).iter().map(|n| pf.rotation * n).collect();
    let target = IcpTarget::new(fixed, fnorm, Some(fb));
    let setup = t0.elapsed().as_secs_f64() * 1e3;
    let start = fixtures::icp_bench_start(&mp, &pm);
    let mut times: Vec<f64> = (0..15)
        .map(|_| {
            let s = Instant::now();
            let r = icp(&mp, &mn, &target, &start, &IcpParams::default()).unwrap();
            std::hint::black_box(r);
            s.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    times.sort_by(f64::total_cmp);
    let (est, report) = icp(&mp, &mn, &target, &start, &IcpParams::default()).unwrap();
    let err = (est.rotation.inverse() * pm.rotation).angle().to_degrees();
    println!(
        "bun045 → bun000: {:.1} ms per registration (median of 15; {} iterations, fitness {:.2}, rotation error {err:.3}°)",
        times[7], report.iterations, report.fitness
    );
    println!(
        "target set-up (normals + k-d tree, once per target): {setup:.1} ms; {} rayon threads",
        rayon::current_num_threads()
    );
}
