//! Reconstruction speed and memory on the 10 aligned bunny scans (issue 9's benchmark): the global FFT
//! method and AdFFT at 256³ and 512³, median of 3 runs each; peak resident memory after each (runs
//! ordered by ascending peak, so each reading is that run's peak, input cloud included).
//!
//! `cargo bench -p process --bench reconstruct` — skips with a message where ../shared/data is absent.

use process::kd_tree::PointTree;
use process::normals::pca_normals;
use process::reconstruct::adfft::{AdFftParams, reconstruct_adfft};
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
    // Ascending peak memory, so each reading is that run's peak: global 256³, AdFFT 256³ and 512³,
    // then global 512³.
    for (method, depth) in [("global FFT", 8), ("AdFFT", 8), ("AdFFT", 9), ("global FFT", 9)] {
        let mut runs: Vec<(f64, String)> = (0..3)
            .map(|_| {
                let t = Instant::now();
                let detail = if method == "AdFFT" {
                    let (mesh, r) =
                        reconstruct_adfft(&cloud, &AdFftParams { depth, ..Default::default() }).expect("reconstructs");
                    std::hint::black_box(mesh);
                    format!(
                        "octree {:.2} s, solve + blend + extract {:.2} s; {} patches, ≤ {} in memory; {} triangles",
                        r.seconds_octree,
                        r.seconds_extract,
                        r.leaves(),
                        r.peak_active_leaves,
                        r.triangles
                    )
                } else {
                    let (mesh, r) =
                        reconstruct_fft(&cloud, &FftParams { depth, ..Default::default() }).expect("reconstructs");
                    std::hint::black_box(mesh);
                    format!(
                        "splat {:.2}, fft {:.2}, extract {:.2} s; grids {:.0} MiB; {} triangles",
                        r.seconds_splat,
                        r.seconds_fft,
                        r.seconds_extract,
                        mib(grid_bytes(depth)),
                        r.triangles
                    )
                };
                (t.elapsed().as_secs_f64(), detail)
            })
            .collect();
        runs.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (s, detail) = &runs[1];
        println!(
            "{method} {}³: {s:.2} s (median of 3; {detail}); peak RSS {:.0} MiB",
            1 << depth,
            mib(rig::memory::peak_resident_bytes().unwrap_or(0))
        );
    }
}
