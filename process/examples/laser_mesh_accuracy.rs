//! Mesh accuracy of a simulated laser scan against the simulator's truth, over several noise seeds:
//! `cargo run --release -p process --example laser_mesh_accuracy -- [CONFIG] [SEEDS] [VIEWS]`
//! (defaults `laser 1,2,3 36`). Prints, per seed, the mesh's vertices against the true surface
//! (median and 95th percentile, above the platter's top 3 mm, as issue 20's tests measure) and the
//! true surface against the mesh (its vertices, the same percentiles), as % of the object's diagonal.
//!
//! `-- --folder SCAN` measures a scan folder `scanrig sim` (or `demo`) wrote and `process` processed,
//! any method: the same figures, the RMS above the bottom 3 mm, and the base — whether the mesh is
//! closed, how far its lowest vertices lie from the platter plane (z = 0), and the largest error in
//! the bottom 3 mm (issue 22's flat base).

use process::mesh_distance::MeshDistance;
use process::{ProcessParams, process_scan};
use rig::Method;
use rig::math::Real;
use sim::{Albedo, ScanOptions, Scene, SimConfig, simulate_scan};

fn percentile(v: &mut [Real], q: Real) -> Real {
    v.sort_by(|a, b| a.total_cmp(b));
    v[((v.len() - 1) as Real * q).round() as usize]
}

/// Median and 95th percentile, in % of `diag`, of the mesh against the truth and back.
fn accuracy(mesh: &rig::TriMesh, truth: &rig::TriMesh, diag: Real) -> [Real; 4] {
    let truth_index = MeshDistance::new(truth, 2.0);
    let mut to_truth: Vec<Real> =
        mesh.vertices.iter().filter(|v| v.z > 3.0).map(|v| truth_index.distance_up_to(v, 50.0)).collect();
    let mesh_index = MeshDistance::new(mesh, 2.0);
    let mut from_truth: Vec<Real> =
        truth.vertices.iter().filter(|v| v.z > 3.0).map(|v| mesh_index.distance_up_to(v, 50.0)).collect();
    let pct = |v: &mut Vec<Real>, q| 100.0 * percentile(v, q) / diag;
    [pct(&mut to_truth, 0.5), pct(&mut to_truth, 0.95), pct(&mut from_truth, 0.5), pct(&mut from_truth, 0.95)]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("--folder") {
        // A scan folder `scanrig sim` wrote (with truth/) and `scanrig process` processed.
        let scan = std::path::Path::new(args.get(1).ok_or("--folder takes a scan folder")?);
        let truth = rig::ply::read_mesh(&scan.join("truth/object.ply"))?.triangulate();
        let mesh = rig::ply::read_mesh(&scan.join("processed/mesh.ply"))?.triangulate();
        let diag = truth.bounding_box().ok_or("empty truth")?.diagonal();
        let a = accuracy(&mesh, &truth, diag);
        println!(
            "{}: mesh→truth median {:.4} % p95 {:.4} %; truth→mesh median {:.4} % p95 {:.4} %",
            scan.display(),
            a[0],
            a[1],
            a[2],
            a[3]
        );
        let index = MeshDistance::new(&truth, 2.0);
        let (mut sum, mut n, mut worst_low) = (0.0, 0usize, 0.0f64);
        for v in &mesh.vertices {
            let d = index.distance_up_to(v, 50.0);
            if v.z > 3.0 {
                sum += d * d;
                n += 1;
            } else {
                worst_low = worst_low.max(d);
            }
        }
        let low = mesh.vertices.iter().map(|v| v.z).fold(Real::INFINITY, Real::min);
        // The base: vertices within 0.5 mm of the platter plane, and how far from it they lie.
        let base_off = mesh.vertices.iter().filter(|v| v.z < 0.5).map(|v| v.z.abs()).fold(0.0, Real::max);
        let t = rig::topology::topology(&mesh);
        println!(
            "  above 3 mm: RMS {:.4} % of the diagonal ({:.4} mm); bottom 3 mm: largest error {:.3} mm; lowest vertex              z = {:.4} mm, base vertices within {:.4} mm of z = 0; {}",
            100.0 * (sum / n.max(1) as Real).sqrt() / diag,
            (sum / n.max(1) as Real).sqrt(),
            worst_low,
            low,
            base_off,
            match t.genus() {
                Some(g) => format!("closed 2-manifold, genus {g}"),
                None => format!("NOT closed: {t:?}"),
            }
        );
        return Ok(());
    }
    let config = args.first().map_or("laser", String::as_str);
    let seeds: Vec<u64> =
        args.get(1).map_or("1,2,3", String::as_str).split(',').map(str::parse).collect::<Result<_, _>>()?;
    let views: u32 = args.get(2).map_or(Ok(36), |v| v.parse())?;
    let mut cfg = SimConfig::builtin(config).ok_or_else(|| format!("no built-in config `{config}`"))?;
    cfg.scan.views = views;
    let vase = sim::fluted_vase(cfg.scene.object_size_mm);
    let diag = vase.bounding_box().ok_or("empty vase")?.diagonal();
    let scene = Scene::on_turntable(&cfg, &vase, Albedo::Constant(cfg.scene.object_albedo));
    for seed in seeds {
        let dir = tempfile::tempdir()?;
        let scan = dir.path().join("scan");
        simulate_scan(&cfg, &scene, None, ScanOptions { method: Method::Laser, seed, truth: false }, &scan, |_, _| {})?;
        let out = scan.join("processed");
        let params = ProcessParams { until: process::Stage::Reconstruct, ..Default::default() };
        process_scan(&scan, &out, &params, |_, _, _| {})?;
        let mesh = rig::ply::read_mesh(&out.join("mesh.ply"))?.triangulate();
        let a = accuracy(&mesh, &vase, diag);
        println!(
            "{config} seed {seed}: mesh→truth median {:.4} % p95 {:.4} %; truth→mesh median {:.4} % p95 {:.4} %",
            a[0], a[1], a[2], a[3]
        );
        if std::env::var_os("KEEP").is_some() {
            let kept = std::path::PathBuf::from(format!("/tmp/laser-{config}-{seed}"));
            let _ = std::fs::remove_dir_all(&kept);
            std::fs::rename(&scan, &kept)?;
        }
    }
    Ok(())
}
