//! Reconstruction speed and memory on the 10 aligned bunny scans (issue 9's benchmark): the global FFT
//! method at 256³ and 512³, median of 3 runs each; peak resident memory after each (sizes ascend, so
//! each reading is that size's peak, input cloud included).
//!
//! `cargo bench -p process --bench reconstruct` — skips with a message where ../shared/data is absent.

use process::normals::{PointTree, pca_normals};
use process::reconstruct::global_fft::{FftParams, grid_bytes, reconstruct_fft};
use rig::math::Vector3;
use std::time::Instant;

fn main() {
    let Some(cloud) = fixtures::bunny_aligned_mm(|p| pca_normals(p, &PointTree::new(p), 10, |_| Vector3::z())) else {
        return;
    };
    let mib = |b: u64| b as f64 / (1 << 20) as f64;
    let before = rig::memory::peak_resident_bytes().unwrap_or(0);
    println!(
        "{} points, {} rayon threads; peak RSS with the input loaded {:.0} MiB",
        cloud.len(),
        rayon::current_num_threads(),
        mib(before)
    );
    for depth in [8, 9] {
        let params = FftParams { depth, ..Default::default() };
        let mut runs: Vec<(f64, process::reconstruct::global_fft::FftReport)> = (0..3)
            .map(|_| {
                let t = Instant::now();
                let (mesh, report) = reconstruct_fft(&cloud, &params).expect("reconstructs");
                std::hint::black_box(mesh);
                (t.elapsed().as_secs_f64(), report)
            })
            .collect();
        runs.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (s, r) = &runs[1];
        println!(
            "global FFT {}³: {s:.2} s (median of 3; splat {:.2}, fft {:.2}, extract {:.2}), {} triangles; grids {:.0} MiB, peak RSS {:.0} MiB",
            r.n,
            r.seconds_splat,
            r.seconds_fft,
            r.seconds_extract,
            r.triangles,
            mib(grid_bytes(depth)),
            mib(rig::memory::peak_resident_bytes().unwrap_or(0))
        );
    }
}
