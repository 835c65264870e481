//! The Rust side of the Python bindings' overhead benchmark (python/bench/overhead.py): the ICP bench
//! pair (bun045 → bun000, perturbed by 10° and 7.5 mm) and the mean-shift bench's 387 K points (the
//! 10 aligned bunny scans plus 25 K outliers), each timed as one Python call does the work — ICP
//! with its target's tree built in the call (fastest of 41), fusion (fastest of 5) as `scanrig.fuse(..., kernel_spacing=0)` — and
//! written (float64 PLY, exact) to `DIR` for the Python side to time on the same inputs.
//!
//! `cargo run --release -p process --example binding_reference -- DIR`

use process::kd_tree::PointTree;
use process::normals::pca_normals;
use process::pipeline::stages::{self, FuseParams};
use process::register::icp::{IcpParams, IcpTarget, icp};
use rig::math::{Point3, Vector3};
use rig::ply::{Precision, WriteOptions};
use std::time::Instant;

/// (fastest, median) of repeated timings: the fastest is the run least disturbed by the machine, so
/// the overhead is compared on it; the median is printed beside it.
fn stats(mut v: Vec<f64>) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    (v[0], v[v.len() / 2])
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::path::PathBuf::from(std::env::args().nth(1).ok_or("give an output folder")?);
    std::fs::create_dir_all(&dir)?;
    let exact = WriteOptions { precision: Precision::F64, ..Default::default() };
    let (Some(poses), Some((mp, _)), Some((fp, _))) =
        (fixtures::bunny_poses_mm(), fixtures::bunny_scan_mm("bun045"), fixtures::bunny_scan_mm("bun000"))
    else {
        println!("SKIPPED: ../shared/data/stanford-bunny not found");
        return Ok(());
    };
    // ICP: the bench's pair and start.
    let (pm, pf) = (poses["bun045"], poses["bun000"]);
    let mn = pca_normals(&mp, &PointTree::new(&mp), 10, |_| Vector3::z());
    let fixed: Vec<Point3> = fp.iter().map(|p| pf * p).collect();
    let fnorm: Vec<Vector3> =
        pca_normals(&fp, &PointTree::new(&fp), 10, |_| Vector3::z()).iter().map(|n| pf.rotation * n).collect();
    let start = fixtures::icp_bench_start(&mp, &pm);
    let moving = rig::PointCloud { positions: mp.clone(), normals: Some(mn.clone()), ..Default::default() };
    let target = rig::PointCloud { positions: fixed.clone(), normals: Some(fnorm.clone()), ..Default::default() };
    rig::write_cloud(&dir.join("icp_moving.ply"), &moving, &exact)?;
    rig::write_cloud(&dir.join("icp_target.ply"), &target, &exact)?;
    let m = start.to_homogeneous();
    let rows: Vec<String> =
        (0..4).map(|i| (0..4).map(|j| format!("{:e}", m[(i, j)])).collect::<Vec<_>>().join(" ")).collect();
    std::fs::write(dir.join("icp_initial.txt"), rows.join("\n"))?;
    let icp_ms = stats(
        (0..41)
            .map(|_| {
                let t = Instant::now();
                let target = IcpTarget::new(fixed.clone(), fnorm.clone(), None);
                std::hint::black_box(icp(&mp, &mn, &target, &start, &IcpParams::default()).unwrap());
                t.elapsed().as_secs_f64() * 1e3
            })
            .collect(),
    );
    // Fusion: the mean-shift bench's set (its outliers and perturbed normals come from its own seed;
    // here the scans' normals as they are, outliers without normals' perturbation).
    let mut cloud = fixtures::bunny_aligned_mm(|p| pca_normals(p, &PointTree::new(p), 10, |_| Vector3::z()))
        .ok_or("bunny scans")?;
    let mut rng = fixtures::Rng::new(0x5eed_0001);
    let (lo, hi) =
        cloud.positions.iter().fold((cloud.positions[0], cloud.positions[0]), |(lo, hi), p| (lo.inf(p), hi.sup(p)));
    for _ in 0..25_000 {
        let t = Vector3::new(rng.uniform(), rng.uniform(), rng.uniform());
        cloud.positions.push(lo + (hi - lo).component_mul(&t));
        cloud.normals.as_mut().ok_or("normals")?.push(rng.direction());
    }
    rig::write_cloud(&dir.join("fuse_input.ply"), &cloud, &exact)?;
    let mut params = FuseParams::default();
    params.mean_shift.kernel_spacing = 0.0;
    let fuse_s = stats(
        (0..5)
            .map(|_| {
                let input = cloud.clone();
                let t = Instant::now();
                std::hint::black_box(stages::fuse(input, &params).unwrap());
                t.elapsed().as_secs_f64()
            })
            .collect(),
    );
    println!(
        "{{\"icp_ms\": [{:.3}, {:.3}], \"fuse_s\": [{:.4}, {:.4}], \"fuse_points\": {}}}",
        icp_ms.0,
        icp_ms.1,
        fuse_s.0,
        fuse_s.1,
        cloud.len()
    );
    Ok(())
}
