//! Issue 22: colour through the whole pipeline. The simulator's object has a procedural colour (its
//! truth, `sim::colour`), each view a texture frame; every point gets its colour from that frame, fusion
//! averages it with the weights it averages positions with, and the mesh's vertices take it from the
//! cloud. Checked against the truth — the colour a noiseless texture frame records of the point — for a
//! structured-light and a laser scan, and present in the files users open.

use process::{ProcessParams, Stage, process_scan};
use rig::Method;
use rig::math::Real;
use sim::{Albedo, ScanOptions, Scene, SimConfig, simulate_scan};

/// Per point, the largest of its three channels' errors against the truth, in 8-bit levels; the
/// median and 95th percentile of those.
fn colour_error(cloud: &rig::PointCloud, cfg: &SimConfig) -> (Real, Real, usize) {
    let colors = cloud.colors.as_ref().expect("the cloud has colours");
    // The object only: the platter (below z = 1 mm) has no tint and another albedo.
    let mut errors: Vec<Real> = cloud
        .positions
        .iter()
        .zip(colors)
        .filter(|(p, _)| p.z > 1.0)
        .map(|(p, c)| {
            let truth = sim::colour::texture_rgb(cfg, cfg.scene.object_albedo, p);
            (0..3).map(|k| (c[k] as Real - truth[k]).abs()).fold(0.0, Real::max)
        })
        .collect();
    errors.sort_by(Real::total_cmp);
    let at = |q: Real| errors[((errors.len() - 1) as Real * q) as usize];
    (at(0.5), at(0.95), errors.len())
}

fn scan_and_process(cfg: &SimConfig, method: Method, name: &str, until: Stage) -> fixtures::TempDir {
    let vase = sim::fluted_vase(cfg.scene.object_size_mm);
    let scene = Scene::on_turntable(cfg, &vase, Albedo::Constant(cfg.scene.object_albedo));
    let dir = fixtures::temp_dir(name);
    simulate_scan(cfg, &scene, None, ScanOptions { method, seed: 3, truth: false }, &dir, |_, _| {}).unwrap();
    let params = ProcessParams { until, ..Default::default() };
    process_scan(&dir, &dir.join("processed"), &params, |_, _, _| {}).unwrap();
    dir
}

#[test]
fn structured_light_points_fused_points_and_mesh_carry_the_object_s_colour() {
    let mut cfg = SimConfig::builtin("structured-light").unwrap().with_camera_resolution(320, 256);
    cfg.scan.views = 8;
    let dir = scan_and_process(&cfg, Method::StructuredLight, "colour-sl", Stage::Reconstruct);
    let p = dir.join("processed");
    // Each view's points, straight from its texture frame (camera frame: placed by the merge).
    let merged = rig::ply::read_cloud(&p.join("merged.ply")).unwrap();
    let (m50, m95, n) = colour_error(&merged, &cfg);
    let fused = rig::ply::read_cloud(&p.join("fused.ply")).unwrap();
    let (f50, f95, nf) = colour_error(&fused, &cfg);
    let mesh = rig::ply::read_mesh(&p.join("mesh.ply")).unwrap();
    let as_cloud = rig::PointCloud { colors: mesh.colors.clone(), ..rig::PointCloud::from_positions(mesh.vertices) };
    let (v50, v95, nv) = colour_error(&as_cloud, &cfg);
    eprintln!(
        "colour (structured light): merged {n} points median {m50:.2} p95 {m95:.2} levels; fused {nf} median \
         {f50:.2} p95 {f95:.2}; mesh {nv} vertices median {v50:.2} p95 {v95:.2}"
    );
    assert!(m50 <= 3.0 && f50 <= 3.0, "median error: merged {m50}, fused {f50}");
    assert!(v50 <= 3.0, "mesh median {v50}");
    // In the GLB web viewers load, too.
    let glb = rig::glb::read(&p.join("mesh.glb")).unwrap();
    assert_eq!(glb.colors.as_ref().map(Vec::len), Some(glb.vertices.len()));
}

#[test]
fn laser_points_carry_the_object_s_colour() {
    let mut cfg = SimConfig::builtin("laser").unwrap().with_camera_resolution(320, 240);
    cfg.scan.views = 36;
    let dir = scan_and_process(&cfg, Method::Laser, "colour-laser", Stage::Reconstruct);
    let p = dir.join("processed");
    let merged = rig::ply::read_cloud(&p.join("merged.ply")).unwrap();
    let (m50, m95, n) = colour_error(&merged, &cfg);
    let fused = rig::ply::read_cloud(&p.join("fused.ply")).unwrap();
    let (f50, f95, nf) = colour_error(&fused, &cfg);
    let mesh = rig::glb::read(&p.join("mesh.glb")).unwrap();
    let as_cloud = rig::PointCloud { colors: mesh.colors.clone(), ..rig::PointCloud::from_positions(mesh.vertices) };
    let (v50, v95, nv) = colour_error(&as_cloud, &cfg);
    eprintln!(
        "colour (laser): merged {n} points median {m50:.2} p95 {m95:.2} levels; fused {nf} median {f50:.2} p95 \
         {f95:.2}; mesh.glb {nv} vertices median {v50:.2} p95 {v95:.2}"
    );
    assert!(m50 <= 3.0 && f50 <= 3.0 && v50 <= 3.0, "median error: merged {m50}, fused {f50}, mesh {v50}");
    assert!(rig::ply::read_mesh(&p.join("mesh.ply")).unwrap().colors.is_some());
}
