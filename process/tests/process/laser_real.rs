//! Issue 20's acceptance on the `realistic` laser rig: an enclosure whose back wall and floor catch
//! both lasers, ambient light, a glossy object, lens blur, colour JPEG frames with a red laser and no
//! laser-off frame — what real captures look like and the clean simulator never shows.

use process::mesh_distance::MeshDistance;
use process::{ProcessParams, process_scan};
use rig::Method;
use rig::math::{Point2, Real};
use rig::scan_folder::Manifest;
use sim::{Albedo, ScanOptions, Scene, SimConfig, simulate_scan};

/// A simulated laser scan of the vase, processed as `scanrig process` runs it up to the mesh
/// (remeshing is not what these tests check).
struct Simulated {
    vase: rig::TriMesh,
    diag: Real,
    scene: Scene,
    scan: fixtures::TempDir,
    out: std::path::PathBuf,
}

/// A simulated laser scan of the vase into a new temporary folder (with per-view truth if `truth`).
fn simulate(cfg: &SimConfig, name: &str, seed: u64, truth: bool) -> (rig::TriMesh, Scene, fixtures::TempDir) {
    let vase = sim::fluted_vase(cfg.scene.object_size_mm);
    let scene = Scene::on_turntable(cfg, &vase, Albedo::Constant(cfg.scene.object_albedo));
    let scan = fixtures::temp_dir(name);
    let opts = ScanOptions { method: Method::Laser, seed, truth };
    simulate_scan(cfg, &scene, Some(&vase), opts, &scan, |_, _| {}).unwrap();
    (vase, scene, scan)
}

fn simulate_and_mesh(cfg: &SimConfig, name: &str, seed: u64, truth: bool) -> Simulated {
    let (vase, scene, scan) = simulate(cfg, name, seed, truth);
    let diag = vase.bounding_box().unwrap().diagonal();
    let out = scan.join("processed");
    let params = ProcessParams { until: process::Stage::Reconstruct, ..Default::default() };
    process_scan(&scan, &out, &params, |_, _, _| {}).unwrap();
    Simulated { vase, diag, scene, scan, out }
}

/// The mesh's vertices against the true surface (mm): median and 95th percentile, above the
/// platter's top 3 mm (the base the data never saw is closed by reconstruction, issue 22).
fn mesh_to_truth(out: &std::path::Path, truth: &rig::TriMesh) -> (Real, Real) {
    let mesh = rig::ply::read_mesh(&out.join("mesh.ply")).unwrap().triangulate();
    let index = MeshDistance::new(truth, 2.0);
    let mut d: Vec<Real> = mesh.vertices.iter().filter(|v| v.z > 3.0).map(|v| index.distance_up_to(v, 50.0)).collect();
    assert!(d.len() > 1000, "{} mesh vertices above the base", d.len());
    (percentile(&mut d, 0.5), percentile(&mut d, 0.95))
}

fn percentile(v: &mut [Real], q: Real) -> Real {
    v.sort_by(|a, b| a.total_cmp(b));
    v[((v.len() - 1) as Real * q).round() as usize]
}

#[test]
fn realistic_laser_frames_give_the_object_and_never_the_wall() {
    let cfg = SimConfig::builtin("realistic").unwrap();
    assert!(!cfg.frames.laser_off && cfg.frames.colour && cfg.frames.jpeg_quality > 0);
    let Simulated { vase, diag, scene, scan, out } = simulate_and_mesh(&cfg, "process-laser-realistic", 5, true);
    assert!(scene.has_enclosure());
    let m = Manifest::read(&scan).unwrap();
    assert!(m.views[0].frames.iter().all(|f| f.file.ends_with(".jpg") && f.pattern != rig::Pattern::LaserOff));
    let (median_mesh, p95_mesh) = mesh_to_truth(&out, &vase);

    // Line centres against the truth crossings on the object, row by row.
    let (w, h) = (cfg.rig.camera.width as usize, cfg.rig.camera.height as usize);
    let (mut rows, mut found, mut px_errors, mut estimated) = (0usize, 0usize, Vec::new(), true);
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    for v in 0..m.views.len() {
        let t = |f: &str| rig::npy::read(&scan.join(format!("truth/view_{v:03}/{f}"))).unwrap();
        let part = t("part.npy").to_f64();
        for k in 0..cfg.rig.lasers.len() {
            let centres = t(&format!("laser{k}_centres.npy")).to_f64();
            let grid = rig::ply::read_sparse_view(&out.join(format!("views/view_{v:03}_laser{k}.ply")))
                .unwrap()
                .to_range_grid();
            estimated &= report["views"][v]["lasers"][k]["report"]["line"]["estimated_background"] == true;
            for r in 0..h {
                // Crossings on the object only: the wall's, floor's and platter's lines are not wanted.
                let truth: Vec<Real> = centres[r * 4..r * 4 + 4]
                    .iter()
                    .copied()
                    .filter(|c| c.is_finite() && part[r * w + (c.round() as usize).min(w - 1)] == 1.0)
                    .collect();
                let cell = (0..w).find(|&c| grid.valid[r * w + c]);
                if truth.is_empty() {
                    continue;
                }
                rows += 1;
                let Some(c) = cell else { continue };
                found += 1;
                let col = cfg.rig.camera.project(&grid.points[r * w + c]).map(|p: Point2| p.x).unwrap();
                let err = truth.iter().map(|t| (t - col).abs()).fold(Real::INFINITY, Real::min);
                px_errors.push(err);
            }
        }
    }
    assert!(estimated, "every laser frame was processed without a laser-off frame");

    // The frames do show the wall's line: searched without the working volume, a view's rows above
    // the object give points on the wall, outside the volume; with it, none.
    let rig = rig::Rig::read(&scan.join("rig.toml")).unwrap();
    let volume = rig.working_volume().expect("the simulated rig knows its working volume");
    let frame = rig::image::read_image(&scan.join(&m.views[0].frames[0].file)).unwrap();
    let laser = &rig.lasers[0];
    let lp = process::triangulate::laser_line::LaserParams::default();
    let windows = process::triangulate::laser_line::working_volume_windows(&rig.camera, &laser.plane, &volume, 5.0);
    let outside = |win: Option<&process::triangulate::laser_line::RowWindows>| {
        let bg = process::triangulate::laser_line::Background::Estimated;
        let (peaks, _) =
            process::triangulate::laser_line::extract_line(&frame, bg, laser.colour, win, &lp, |_, _| true);
        let line = process::triangulate::laser_line::triangulate_line(&peaks, &rig.camera, &laser.plane);
        line.points.iter().filter(|p| !volume.contains(p, 5.0)).count()
    };
    let (unbounded, bounded) = (outside(None), outside(Some(&windows)));
    eprintln!("view 0, laser 0: {unbounded} points outside the working volume without it, {bounded} with it");
    assert!(unbounded > 50 && bounded == 0, "{unbounded} without, {bounded} with the working volume");
    let frac = found as Real / rows as Real;
    let (median_px, p99_px) = (percentile(&mut px_errors, 0.5), percentile(&mut px_errors, 0.99));

    // Every processed point against the true surface.
    let merged = rig::ply::read_cloud(&out.join("merged.ply")).unwrap();
    let truth = MeshDistance::new(&vase, 2.0);
    let mut d: Vec<Real> = merged.positions.iter().map(|p| truth.distance_up_to(p, 0.05 * diag)).collect();
    let near = d.iter().filter(|&&x| x <= 5e-3 * diag).count() as Real / d.len() as Real;
    let median = percentile(&mut d, 0.5);
    eprintln!(
        "realistic laser: a point in {:.2} % of {rows} object rows; centre error median {median_px:.3} px, p99 \
         {p99_px:.3} px; {} points, {:.3} % within 0.5 % of the diagonal, median {median:.4} mm = {:.4} % of it",
        100.0 * frac,
        merged.positions.len(),
        100.0 * near,
        100.0 * median / diag
    );
    eprintln!(
        "realistic laser mesh: median {:.4} % and p95 {:.4} % of the diagonal from the truth",
        100.0 * median_mesh / diag,
        100.0 * p95_mesh / diag
    );
    assert!(frac >= 0.95, "a point in {frac} of the object's lit rows");
    // Issue 20: median ≤ 0.1 %, p95 ≤ 0.5 % (the open top and base capped flat, normals across lines).
    assert!(median_mesh <= 1e-3 * diag && p95_mesh <= 5e-3 * diag, "mesh {median_mesh} / {p95_mesh} mm");
    assert!(median_px <= 0.1 && p99_px <= 0.5, "centre errors median {median_px} px, p99 {p99_px} px");
    assert!(near >= 0.99, "{near} of the points within 0.5 % of the diagonal of the truth");
    assert!(median <= 5e-4 * diag, "median error {median} mm");
}

/// The README's laser example — `scanrig sim --config laser`, then `scanrig process` — gives the
/// object (it used to give a 130 mm box, exit 0), and a scan too sparse to mesh fails saying what to
/// change.
#[test]
fn the_readme_laser_example_meshes_the_object_and_a_sparse_scan_says_take_more_views() {
    let cfg = SimConfig::builtin("laser").unwrap();
    assert_eq!(cfg.scan.views, 36);
    // `_scan` holds the folder until the test ends.
    let Simulated { vase, diag, scene, scan: _scan, out } = simulate_and_mesh(&cfg, "process-laser-readme", 1, false);
    let params = ProcessParams { until: process::Stage::Reconstruct, ..Default::default() };
    let (median, p95) = mesh_to_truth(&out, &vase);
    eprintln!(
        "README laser example: mesh median {:.4} % and p95 {:.4} % of the diagonal from the truth",
        100.0 * median / diag,
        100.0 * p95 / diag
    );
    // Issue 20: median ≤ 0.1 %, p95 ≤ 0.5 %. The top, which the lasers below it never light, and the
    // base on the platter are capped flat (`closing`); the PCA normals reach past the line two lasers
    // share. The reconstruction's level is χ's area-weighted mean, the areas measured across lines.
    // (Seeds 1–3 and the CLI's own run: `cargo run -p process --example laser_mesh_accuracy`.)
    assert!(median <= 1e-3 * diag, "mesh median {median} mm from the truth");
    assert!(p95 <= 5e-3 * diag, "mesh p95 {p95} mm from the truth");
    // Issue 37: its 36 lines 10° apart leave the surface between them unmeasured, and the mesh ribbed
    // along them (up to 0.8 mm off the truth): the report says so rather than "every check passed".
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    let spacing = &report["merge"]["report"]["volume"]["spacing"];
    let gap = spacing["largest_gap_deg"].as_f64().unwrap();
    assert!((gap - 10.0).abs() < 1.0, "lines {gap}° apart: {spacing}");
    let warnings: Vec<&str> = report["warnings"].as_array().unwrap().iter().filter_map(|w| w.as_str()).collect();
    assert!(
        warnings.iter().any(|w| w.contains("10.0° apart") && w.contains("ribs") && w.contains("--views")),
        "{warnings:?}"
    );

    // Six views: lines 60° apart.
    let sparse_cfg = SimConfig { scan: sim::config::ScanConfig { views: 6, ..cfg.scan.clone() }, ..cfg };
    let sparse = fixtures::temp_dir("process-laser-sparse");
    simulate_scan(
        &sparse_cfg,
        &scene,
        None,
        ScanOptions { method: Method::Laser, seed: 1, truth: false },
        &sparse,
        |_, _| {},
    )
    .unwrap();
    let err = process_scan(&sparse, &sparse.join("processed"), &params, |_, _, _| {}).unwrap_err();
    let msg = format!("{err}");
    eprintln!("6 views: {msg}");
    assert!(msg.contains("take more views"), "{msg}");
    assert!(!sparse.join("processed/mesh.ply").exists(), "no mesh is written");
}

/// A rig whose laser plane misses the working volume is refused by name (a plane typed wrong, or
/// another scanner's rig), not searched in silence; a view that lost a laser's frame is reported.
#[test]
fn a_laser_plane_outside_the_working_volume_is_refused_and_a_lost_frame_reported() {
    let mut cfg = SimConfig::builtin("laser").unwrap().with_camera_resolution(320, 240);
    cfg.scan.views = 4;
    let (_, _, scan) = simulate(&cfg, "process-laser-wrong-plane", 3, false);
    let good = rig::Rig::read(&scan.join("rig.toml")).unwrap();
    let mut wrong = good.clone();
    // Its distance typed with the wrong sign and far: the plane still crosses the camera's view (a plane
    // no ray of the image meets is refused when the rig is read, `Rig::validate`), 1.9 m away.
    wrong.lasers[1].plane = rig::LaserPlane::new(wrong.lasers[1].plane.normal.into_inner(), -900.0).unwrap();
    wrong.write(&scan.join("rig.toml")).unwrap();
    let params = ProcessParams { until: process::Stage::Merge, ..Default::default() };
    let err = process_scan(&scan, &scan.join("processed"), &params, |_, _, _| {}).unwrap_err().to_string();
    assert!(err.contains("laser `right`") && err.contains("working volume") && err.contains("--force"), "{err}");
    let forced = ProcessParams { force: true, ..params.clone() };
    let report = process_scan(&scan, &scan.join("processed"), &forced, |_, _, _| {}).unwrap();
    assert!(report.warnings.iter().any(|w| w.contains("searched in the whole image")), "{:?}", report.warnings);

    // The right rig again, and view 2 without laser 1's frame.
    good.write(&scan.join("rig.toml")).unwrap();
    let mut m = Manifest::read(&scan).unwrap();
    m.views[2].frames.retain(|f| f.pattern != rig::Pattern::Laser { index: 1 });
    m.write(&scan).unwrap();
    let report = process_scan(&scan, &scan.join("processed2"), &params, |_, _, _| {}).unwrap();
    assert!(
        report.warnings.iter().any(|w| w.contains("laser 1 (`right`) has no frame in 1 of 4 views (2)")),
        "{:?}",
        report.warnings
    );
}

/// Colour frames of a red laser read with the rig saying blue give nearly no line: said, naming the
/// rig field, not left as empty views.
#[test]
fn a_wrong_laser_colour_is_said() {
    let mut cfg = SimConfig::builtin("realistic").unwrap().with_camera_resolution(320, 240);
    cfg.scan.views = 3;
    let (_, _, scan) = simulate(&cfg, "process-laser-wrong-colour", 4, false);
    let params = ProcessParams { until: process::Stage::Triangulate, ..Default::default() };
    let right = process_scan(&scan, &scan.join("processed"), &params, |_, _, _| {}).unwrap();
    assert!(!right.warnings.iter().any(|w| w.contains("nearly none")), "{:?}", right.warnings);
    let mut rig = rig::Rig::read(&scan.join("rig.toml")).unwrap();
    rig.lasers[0].colour = rig::LaserColour::Blue;
    rig.write(&scan.join("rig.toml")).unwrap();
    let wrong = process_scan(&scan, &scan.join("processed"), &params, |_, _, _| {}).unwrap();
    assert!(
        wrong.warnings.iter().any(|w| w.contains("laser 0 (`left`, colour Blue)") && w.contains("`colour`")),
        "{:?}",
        wrong.warnings
    );
}

/// A laser scan is registered laser against laser: on the simulator's calibrated rig the two lasers'
/// clouds agree (a correction within the noise, no warning); with one plane off by 0.5 mm — the
/// Horus users' "two objects, one inside the other" — the gap is measured and said, naming the
/// lasers, and the correction is reported.
#[test]
fn two_lasers_are_registered_and_a_plane_that_is_off_is_said() {
    let mut cfg = SimConfig::builtin("laser").unwrap().with_camera_resolution(640, 480);
    cfg.scan.views = 36;
    let (_, _, scan) = simulate(&cfg, "process-laser-register", 6, false);
    let params = ProcessParams { until: process::Stage::Register, ..Default::default() };
    let good = process_scan(&scan, &scan.join("processed"), &params, |_, _, _| {}).unwrap();
    let lr = good.register.as_ref().expect("a laser scan is registered").report.lasers.clone().unwrap();
    let a = lr.lasers[0];
    eprintln!("calibrated rig: noise {:.4} mm, {a:?}", lr.noise_mm);
    assert_eq!(lr.lasers.len(), 1, "two lasers: one aligned with the other");
    assert!(lr.noise_mm > 0.001 && lr.noise_mm < 0.05, "the simulated lines' noise {}", lr.noise_mm);
    assert!(a.overlap > 0.8, "{a:?}");
    assert!(a.rotation_deg < 0.1 && a.shift_mm < 0.1, "a calibrated rig needs no correction: {a:?}");
    assert!(!a.disagrees(lr.noise_mm), "{a:?} with noise {}", lr.noise_mm);
    assert!(!good.warnings.iter().any(|w| w.contains("disagree")), "{:?}", good.warnings);
    assert!(scan.join("processed/registered.ply").is_file() && scan.join("processed/registered.poses.json").is_file());

    // Laser 1's plane 0.5 mm off in the rig the scan is processed with.
    let mut rig = rig::Rig::read(&scan.join("rig.toml")).unwrap();
    let plane = rig.lasers[1].plane;
    rig.lasers[1].plane = rig::LaserPlane::new(plane.normal.into_inner(), plane.distance + 0.5).unwrap();
    rig.write(&scan.join("rig.toml")).unwrap();
    let off = process_scan(&scan, &scan.join("processed"), &params, |_, _, _| {}).unwrap();
    let lr = off.register.as_ref().unwrap().report.lasers.clone().unwrap();
    let a = lr.lasers[0];
    eprintln!("laser 1 0.5 mm off: {a:?}; warnings {:?}", off.warnings);
    assert_eq!((lr.reference, a.laser), (0, 1));
    assert!(a.gap_before_mm > 0.2 && a.gap_after_mm <= a.gap_before_mm, "{a:?}");
    assert!(a.disagrees(lr.noise_mm));
    assert!(
        off.warnings.iter().any(|w| w.contains("laser 1 and laser 0 disagree") && w.contains("calibrate laser")),
        "{:?}",
        off.warnings
    );
}
