//! Where a processed scan's heavy stages spend their time, each run alone on the inputs the pipeline
//! saved: `cargo run --release -p process --example stage_profile -- PROCESSED` (a `processed/`
//! folder, the demo's for the figures in BENCHMARKS.md). Prints registration's, fusion's and
//! reconstruction's own timings and peak memory, with the points in and out.

use process::pipeline::memory::take_peak_mb;
use process::pipeline::stages::{self, FuseParams, ReconstructParams};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = std::path::PathBuf::from(args.first().ok_or("give a processed folder")?);
    let opt = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned();
    let registered = rig::ply::read_cloud(&dir.join("registered.ply"))?;
    let mut params = FuseParams::default();
    if let Some(s) = opt("--kernel-spacing") {
        params.mean_shift.kernel_spacing = s.parse()?;
    }
    let _ = take_peak_mb();
    let t = Instant::now();
    let points_in = registered.len();
    let (fused, r) = stages::fuse(registered, &params)?;
    println!(
        "fuse: {:.2} s (kernels {:.2}, shift {:.2}, cluster {:.2}), peak {:.0} MB, {} → {} points",
        t.elapsed().as_secs_f64(),
        r.mean_shift.seconds_kernels,
        r.mean_shift.seconds_shift,
        r.mean_shift.seconds_cluster,
        take_peak_mb().unwrap_or(f64::NAN),
        points_in,
        fused.cloud.len()
    );
    if let Some(truth) = opt("--truth") {
        // The fused points against the true surface, above the platter's 3 mm.
        let truth = rig::read_mesh(std::path::Path::new(&truth))?.triangulate();
        let diag = truth.bounding_box().ok_or("empty truth")?.diagonal();
        let index = process::mesh_distance::MeshDistance::new(&truth, 2.0);
        let mut d: Vec<f64> = fused.cloud.positions.iter().filter(|p| p.z > 3.0).map(|p| index.distance(p)).collect();
        d.sort_by(f64::total_cmp);
        let pct = |q: f64| 100.0 * d[((d.len() - 1) as f64 * q) as usize] / diag;
        println!(
            "fused vs truth: median {:.4} %, p95 {:.4} %, p99 {:.4} % of the diagonal",
            pct(0.5),
            pct(0.95),
            pct(0.99)
        );
    }
    if opt("--fuse-only").is_some() {
        return Ok(());
    }
    let closed = rig::ply::read_cloud(&dir.join("closed.ply"))?;
    let _ = take_peak_mb();
    let t = Instant::now();
    let (mesh, rr) = stages::reconstruct(&closed, &ReconstructParams::default())?;
    println!(
        "reconstruct: {:.2} s ({rr:?}), peak {:.0} MB, {} points → {} triangles",
        t.elapsed().as_secs_f64(),
        take_peak_mb().unwrap_or(f64::NAN),
        closed.len(),
        mesh.faces.len()
    );
    Ok(())
}
