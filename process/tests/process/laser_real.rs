//! Issue 20's acceptance on the `realistic` laser rig: an enclosure whose back wall and floor catch
//! both lasers, ambient light, a glossy object, lens blur, colour JPEG frames with a red laser and no
//! laser-off frame — what real captures look like and the clean simulator never shows.

use process::mesh_distance::MeshDistance;
use process::{ProcessParams, process_scan};
use rig::Method;
use rig::math::{Point2, Real};
use rig::scan_folder::Manifest;
use sim::{Albedo, ScanOptions, Scene, SimConfig, simulate_scan};

fn percentile(v: &mut [Real], q: Real) -> Real {
    v.sort_by(|a, b| a.total_cmp(b));
    v[((v.len() - 1) as Real * q).round() as usize]
}

#[test]
fn realistic_laser_frames_give_the_object_and_never_the_wall() {
    let cfg = SimConfig::builtin("realistic").unwrap();
    assert!(!cfg.frames.laser_off && cfg.frames.colour && cfg.frames.jpeg_quality > 0);
    let vase = sim::fluted_vase(cfg.scene.object_size_mm);
    let diag = vase.bounding_box().unwrap().diagonal();
    let scene = Scene::on_turntable(&cfg, &vase, Albedo::Constant(cfg.scene.object_albedo));
    assert!(scene.has_enclosure());
    let scan = fixtures::temp_dir("process-laser-realistic");
    simulate_scan(
        &cfg,
        &scene,
        Some(&vase),
        ScanOptions { method: Method::Laser, seed: 5, truth: true },
        &scan,
        |_, _| {},
    )
    .unwrap();
    let m = Manifest::read(&scan).unwrap();
    assert!(m.views[0].frames.iter().all(|f| f.file.ends_with(".jpg") && f.pattern != rig::Pattern::LaserOff));
    let out = scan.join("processed");
    let params = ProcessParams { until: process::Stage::Merge, ..Default::default() };
    process_scan(&scan, &out, &params, |_, _, _| {}).unwrap();

    // Line centres against the truth crossings on the object, row by row.
    let (w, h) = (cfg.rig.camera.width as usize, cfg.rig.camera.height as usize);
    let (mut rows, mut found, mut px_errors, mut estimated) = (0usize, 0usize, Vec::new(), true);
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    for v in 0..m.views.len() {
        let t = |f: &str| rig::npy::read(&scan.join(format!("truth/view_{v:03}/{f}"))).unwrap();
        let part = t("part.npy").to_f64();
        for k in 0..cfg.rig.lasers.len() {
            let centres = t(&format!("laser{k}_centres.npy")).to_f64();
            let grid = rig::ply::read_range_grid(&out.join(format!("views/view_{v:03}_laser{k}.ply"))).unwrap();
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
    let lp = process::laser_line::LaserParams::default();
    let windows = process::laser_line::working_volume_windows(&rig.camera, &laser.plane, &volume, 5.0);
    let outside = |win: Option<&process::laser_line::RowWindows>| {
        let bg = process::laser_line::Background::Estimated;
        let (peaks, _) = process::laser_line::extract_line(&frame, bg, laser.colour, win, &lp, |_, _| true);
        let grid = process::laser_line::triangulate_line(&peaks, &rig.camera, &laser.plane);
        grid.points.iter().zip(&grid.valid).filter(|(p, ok)| **ok && !volume.contains(p, 5.0)).count()
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
    assert!(frac >= 0.95, "a point in {frac} of the object's lit rows");
    assert!(median_px <= 0.1 && p99_px <= 0.5, "centre errors median {median_px} px, p99 {p99_px} px");
    assert!(near >= 0.99, "{near} of the points within 0.5 % of the diagonal of the truth");
    assert!(median <= 5e-4 * diag, "median error {median} mm");
}
