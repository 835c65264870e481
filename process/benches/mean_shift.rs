//! Mean-shift fusion speed and memory (issue 8's benchmark).
//!
//! 1. The thesis's fig. 3.6 set: the 10 aligned bunny scans (362,272 points) plus 25,000 outliers
//!    uniform in the bounding box, normals perturbed by up to 30°: median of 3 runs.
//! 2. Scaling: noisy spheres whose radius grows with √N, so the sampling density (and with it each
//!    kernel's work) stays fixed while N goes from 200 K to 2 M, plus 6.5 % outliers in the bounding
//!    box; time per point at each size against the 200 K run, and the process's peak resident memory
//!    after each (sizes ascend, so each reading is that size's peak).
//!
//! `cargo bench -p process --bench mean_shift` — part 1 skips with a message where ../shared/data is absent.

use process::fuse::mean_shift::{MeanShiftParams, mean_shift};
use process::kd_tree::PointTree;
use process::normals::pca_normals;
use rig::PointCloud;
use rig::math::{Point3, Real, UnitQuaternion, Vector3};
use std::time::Instant;

use fixtures::Rng;

fn add_outliers(positions: &mut Vec<Point3>, normals: &mut Vec<Vector3>, count: usize, rng: &mut Rng) {
    let (lo, hi) = positions.iter().fold((positions[0], positions[0]), |(lo, hi), p| (lo.inf(p), hi.sup(p)));
    for _ in 0..count {
        let t = Vector3::new(rng.uniform(), rng.uniform(), rng.uniform());
        positions.push(lo + (hi - lo).component_mul(&t));
        normals.push(rng.direction());
    }
}

fn perturb_normals(normals: &mut [Vector3], rng: &mut Rng) {
    for n in normals {
        let axis = rng.direction();
        *n = UnitQuaternion::from_scaled_axis(axis * (30f64.to_radians() * rng.uniform())) * *n;
    }
}

/// Peak resident memory of this process so far, in MiB (Linux; None elsewhere).
fn peak_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

fn bunny(rng: &mut Rng) -> Option<PointCloud> {
    let mut cloud = fixtures::bunny_aligned_mm(|p| pca_normals(p, &PointTree::new(p), 10, |_| Vector3::z()))?;
    add_outliers(&mut cloud.positions, cloud.normals.as_mut()?, 25_000, rng);
    perturb_normals(cloud.normals.as_mut()?, rng);
    Some(cloud)
}

/// A sphere sampled at about 6 points per mm² (the bunny set's density) with 0.05 mm normal noise.
fn sphere(n: usize, rng: &mut Rng) -> PointCloud {
    let radius = (n as Real / 6.0 / (4.0 * std::f64::consts::PI)).sqrt();
    let (mut positions, mut normals) = (Vec::with_capacity(n * 107 / 100), Vec::with_capacity(n * 107 / 100));
    for _ in 0..n {
        let d = rng.direction();
        positions.push(Point3::from(d * (radius + 0.05 * rng.gaussian())));
        normals.push(d);
    }
    add_outliers(&mut positions, &mut normals, n * 65 / 1000, rng);
    perturb_normals(&mut normals, rng);
    PointCloud { positions, normals: Some(normals), ..Default::default() }
}

fn main() {
    let params = MeanShiftParams::default();
    let mut rng = Rng::new(0x5eed_0001);
    println!("{} rayon threads; k = {}", rayon::current_num_threads(), params.k);
    match bunny(&mut rng) {
        None => println!("bunny set skipped: ../shared/data/stanford-bunny not found"),
        Some(cloud) => {
            let mut runs: Vec<(f64, process::fuse::mean_shift::MeanShiftReport)> = (0..3)
                .map(|_| {
                    let t = Instant::now();
                    let r = mean_shift(&cloud, &params);
                    (t.elapsed().as_secs_f64(), r.report)
                })
                .collect();
            runs.sort_by(|a, b| a.0.total_cmp(&b.0));
            let (s, r) = &runs[1];
            println!(
                "bunny + 25 K outliers, {} points: {s:.2} s (median of 3; kernels {:.2} s, shift {:.2} s, cluster {:.2} s) → {} points; peak RSS {:.0} MiB",
                r.points_in,
                r.seconds_kernels,
                r.seconds_shift,
                r.seconds_cluster,
                r.points_out,
                peak_mib().unwrap_or(f64::NAN)
            );
        }
    }
    let mut base = None;
    for n in [200_000, 500_000, 1_000_000, 2_000_000] {
        let cloud = sphere(n, &mut rng);
        let t = Instant::now();
        let r = mean_shift(&cloud, &params);
        let s = t.elapsed().as_secs_f64();
        let per_point = s / cloud.len() as f64;
        let base = *base.get_or_insert(per_point);
        println!(
            "sphere {:>9} points: {s:6.2} s, {:.2} µs/point = {:.2} × the 200 K run's per-point time; {} out; peak RSS {:.0} MiB",
            cloud.len(),
            per_point * 1e6,
            per_point / base,
            r.report.points_out,
            peak_mib().unwrap_or(f64::NAN)
        );
        drop(r);
    }
}
