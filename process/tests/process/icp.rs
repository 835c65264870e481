//! ICP on the real Stanford bunny scans (issue 8's acceptance 1): from `bun.conf` poses perturbed by
//! 5–15° about the moving scan's centroid and 5–10 mm, 100 seeded trials per pair.

use process::kd_tree::PointTree;
use process::normals::pca_normals;
use process::register::icp::{IcpParams, IcpTarget, icp};
use rig::math::{Isometry3, Point3, Real, Translation3, UnitQuaternion, Vector3};
use std::collections::HashMap;

/// A scan in millimetres, in its own frame, with normals toward its sensor (+z) and boundary flags.
struct Scan {
    points: Vec<Point3>,
    normals: Vec<Vector3>,
    boundary: Vec<bool>,
}

fn load(name: &str) -> Option<Scan> {
    let (points, boundary) = fixtures::bunny_scan_mm(name)?;
    let normals = pca_normals(&points, &PointTree::new(&points), 10, |_| Vector3::z());
    Some(Scan { points, normals, boundary })
}

use fixtures::Rng;

/// Median nearest-neighbour distance over moving points within 2 mm of the target (the data README's
/// pairwise statistic).
fn median_nn(moving: &[Point3], pose: &Isometry3, target: &PointTree) -> Real {
    let mut d: Vec<Real> = moving.iter().map(|p| target.nearest(&(pose * p)).1.sqrt()).filter(|&d| d <= 2.0).collect();
    d.sort_by(Real::total_cmp);
    d[d.len() / 2]
}

#[test]
fn bunny_pairs_register_from_perturbed_poses() {
    let Some(poses) = fixtures::bunny_poses_mm() else { return };
    // (moving, fixed, the README's median NN distance after alignment, mm)
    let pairs = [
        ("bun045", "bun000", 0.315),
        ("bun315", "bun000", 0.344),
        ("bun090", "bun045", 0.331),
        ("bun180", "bun090", 0.488),
        ("bun270", "bun180", 0.458),
        ("bun315", "bun270", 0.347),
    ];
    // 50 seeded starts a pair measure the 95 % bar (48 of 50) as 100 did, in half the time (issue 38).
    let trials = 50;
    let params = IcpParams::default();
    let mut scans: HashMap<&str, Scan> = HashMap::new();
    for name in ["bun000", "bun045", "bun090", "bun180", "bun270", "bun315"] {
        let Some(s) = load(name) else { return };
        scans.insert(name, s);
    }
    let mut failures = Vec::new();
    for (moving_name, fixed_name, readme_median) in pairs {
        let (m, f) = (&scans[moving_name], &scans[fixed_name]);
        let (pm, pf) = (poses[moving_name], poses[fixed_name]);
        let fixed_aligned: Vec<Point3> = f.points.iter().map(|p| pf * p).collect();
        let fixed_tree = PointTree::new(&fixed_aligned);
        let target = IcpTarget::new(
            fixed_aligned.clone(),
            f.normals.iter().map(|n| pf.rotation * n).collect(),
            Some(f.boundary.clone()),
        );
        let centroid = m.points.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / m.points.len() as Real;
        let c_true = pm * Point3::from(centroid);
        let (mut ok, mut stat, mut iterations) = (0, None, 0);
        let start = std::time::Instant::now();
        // The trials are independent: run side by side, then counted in trial order.
        use rayon::prelude::*;
        let results: Vec<Option<(Isometry3, usize)>> = (0..trials)
            .into_par_iter()
            .map(|trial| {
                let mut rng = Rng::new(0x5eed_0000 + trial as u64 * 7919 + moving_name.len() as u64);
                let angle = (5.0 + 10.0 * rng.uniform()).to_radians();
                let rot = UnitQuaternion::from_scaled_axis(rng.direction() * angle);
                let shift = rng.direction() * (5.0 + 5.0 * rng.uniform());
                // Rotate about the aligned centroid, then shift: the perturbed start.
                let perturb = Isometry3::from_parts(Translation3::from(c_true.coords + shift), rot)
                    * Translation3::from(-c_true.coords);
                let initial = perturb * pm;
                icp(&m.points, &m.normals, &target, &initial, &params).ok().map(|(est, r)| (est, r.iterations))
            })
            .collect();
        for (est, its) in results.into_iter().flatten() {
            iterations += its;
            let rot_err = (est.rotation.inverse() * pm.rotation).angle().to_degrees();
            let shift_err = (est * Point3::from(centroid) - c_true).norm();
            if rot_err < 1.0 && shift_err < 1.0 {
                ok += 1;
                if stat.is_none() {
                    stat = Some(median_nn(&m.points, &est, &fixed_tree));
                }
            }
        }
        let rate = ok as Real / trials as Real;
        let stat = stat.unwrap_or(Real::NAN);
        eprintln!(
            "{moving_name} → {fixed_name}: {ok}/{trials} succeed ({:.1} ms, {:.0} iterations each); median NN after {stat:.3} mm vs README {readme_median} ({:.2}×)",
            start.elapsed().as_secs_f64() * 1e3 / trials as Real,
            iterations as Real / trials as Real,
            stat / readme_median
        );
        if rate < 0.95 || stat.is_nan() || stat > 1.1 * readme_median {
            failures
                .push(format!("{moving_name} → {fixed_name}: {rate:.2} success, NN ratio {:.2}", stat / readme_median));
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

#[test]
fn all_ten_bunny_scans_refine_to_bun_conf_from_perturbed_starts() {
    let Some(poses) = fixtures::bunny_poses_mm() else { return };
    let mut views = Vec::new();
    for name in fixtures::BUNNY_SCANS {
        let Some(s) = load(name) else { return };
        views.push(process::register::multiview::View { points: s.points, normals: s.normals, boundary: s.boundary });
    }
    let truth: Vec<Isometry3> = fixtures::BUNNY_SCANS.iter().map(|n| poses[*n]).collect();
    for seed in [0xb0b0_2026u64, 17, 4242] {
        refine_from(&views, &truth, seed);
    }
}

fn refine_from(views: &[process::register::multiview::View], truth: &[Isometry3], seed: u64) {
    let mut rng = Rng::new(seed);
    // bun000 is the anchor (bun.conf's identity); every other scan starts 5–15° and 5–10 mm off.
    let initial: Vec<Isometry3> = truth
        .iter()
        .zip(views)
        .enumerate()
        .map(|(k, (t, v))| {
            if k == 0 {
                return *t;
            }
            let c = v.points.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / v.points.len() as Real;
            let c = t * Point3::from(c);
            let rot = UnitQuaternion::from_scaled_axis(rng.direction() * (5.0 + 10.0 * rng.uniform()).to_radians());
            let shift = rng.direction() * (5.0 + 5.0 * rng.uniform());
            Isometry3::from_parts(Translation3::from(c.coords + shift), rot) * Translation3::from(-c.coords) * t
        })
        .collect();
    // Around the turntable from bun000 both ways, then the scans from above and below.
    let names = fixtures::BUNNY_SCANS;
    let order: Vec<usize> = ["bun045", "bun315", "bun090", "bun270", "bun180", "chin", "top3", "top2", "ear_back"]
        .iter()
        .map(|n| names.iter().position(|m| m == n).unwrap())
        .collect();
    let (est, report) =
        process::register::multiview::refine_views(views, &initial, Some(&order), &Default::default()).unwrap();
    let mut worst: (Real, Real) = (0.0, 0.0);
    for (k, name) in fixtures::BUNNY_SCANS.iter().enumerate() {
        let c = views[k].points.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / views[k].points.len() as Real;
        let rot = (est[k].rotation.inverse() * truth[k].rotation).angle().to_degrees();
        let shift = (est[k] * Point3::from(c) - truth[k] * Point3::from(c)).norm();
        eprintln!("seed {seed}: {name}: {rot:.3}° {shift:.3} mm from bun.conf");
        worst = (worst.0.max(rot), worst.1.max(shift));
    }
    eprintln!(
        "seed {seed}: worst {:.3}° {:.3} mm; per-round largest change {:?}°",
        worst.0, worst.1, report.max_rotation_change_deg
    );
    assert!(worst.0 < 0.5 && worst.1 < 0.5, "worst {worst:?}");
    // Real scans, the chin and the top ones seeing little of the rest among them: none is taken for
    // a view the turntable did not turn for (the misfit check's thresholds were set on a simulated
    // scan).
    let fits: Vec<String> = report.views.iter().map(|r| format!("{:.2}/{:.3}", r.fitness, r.inlier_rmse)).collect();
    eprintln!("seed {seed}: share on the others / RMS per scan: {fits:?}");
    assert!(report.misfits().is_empty(), "{:?}", report.misfits());
}
