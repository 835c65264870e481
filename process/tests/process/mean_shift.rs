//! Mean-shift fusion on the real bunny with salt-and-pepper outliers (issue 8's acceptance 3, the
//! thesis's fig. 3.6 set-up).

use process::fuse::mean_shift::{MeanShiftParams, mean_shift};
use process::kd_tree::PointTree;
use process::normals::pca_normals;
use rig::PointCloud;
use rig::math::{Point3, Real, UnitQuaternion, Vector3};

use crate::surface;

#[test]
fn bunny_with_25k_outliers_is_cleaned_and_smoothed() {
    let (Some(aligned), Some(zipper)) = (
        fixtures::bunny_aligned_mm(|p| pca_normals(p, &PointTree::new(p), 10, |_| Vector3::z())),
        fixtures::data_file("stanford-bunny/reconstruction/bun_zipper.ply"),
    ) else {
        return;
    };
    let mut rng = fixtures::Rng::new(0x0f0f_1234);
    let mut uniform = move || rng.uniform();
    let (mut positions, mut normals) = (aligned.positions, aligned.normals.expect("normals"));
    let surface_points = positions.len();
    let (lo, hi) = positions.iter().fold((positions[0], positions[0]), |(lo, hi), p| (lo.inf(p), hi.sup(p)));
    for _ in 0..25_000 {
        positions.push(Point3::new(
            lo.x + (hi.x - lo.x) * uniform(),
            lo.y + (hi.y - lo.y) * uniform(),
            lo.z + (hi.z - lo.z) * uniform(),
        ));
        normals.push(Vector3::new(uniform() - 0.5, uniform() - 0.5, uniform() - 0.5).normalize());
    }
    // Normals perturbed by random angles up to 30°.
    for n in &mut normals {
        let axis = Vector3::new(uniform() - 0.5, uniform() - 0.5, uniform() - 0.5).normalize();
        *n = UnitQuaternion::from_scaled_axis(axis * (30f64.to_radians() * uniform())) * *n;
    }
    let cloud = PointCloud { positions, normals: Some(normals), ..Default::default() };
    let dist = surface::SurfaceDistance::new(&surface::zipper_mm(&zipper), 1.5);
    let start = std::time::Instant::now();
    let params = MeanShiftParams::default();
    let result = mean_shift(&cloud, &params);
    let seconds = start.elapsed().as_secs_f64();
    // Outliers: the added points farther than 1 mm from the surface. (Searched only that far: an
    // exact distance for a point tens of millimetres off walks hundreds of thousands of index cells,
    // and the 25 K outliers made this test take minutes.)
    let far: Vec<bool> = cloud
        .positions
        .iter()
        .enumerate()
        .map(|(i, p)| i >= surface_points && dist.distance_up_to(p, 1.0) > 1.0)
        .collect();
    let far_total = far.iter().filter(|&&f| f).count();
    let far_removed = (0..far.len()).filter(|&i| far[i] && !result.kept[i]).count();
    let removed = result.kept.iter().filter(|&&k| !k).count();
    let mut survivors: Vec<Real> =
        (0..far.len()).filter(|&i| far[i] && result.kept[i]).map(|i| dist.distance(&cloud.positions[i])).collect();
    survivors.sort_by(Real::total_cmp);
    if !survivors.is_empty() {
        let q = |f: Real| survivors[((survivors.len() - 1) as Real * f) as usize];
        eprintln!(
            "  surviving far outliers' input distance: min {:.2} p25 {:.2} median {:.2} p75 {:.2} max {:.2} mm",
            q(0.0),
            q(0.25),
            q(0.5),
            q(0.75),
            q(1.0)
        );
    }
    let removed_outliers = (surface_points..cloud.len()).filter(|&i| !result.kept[i]).count();
    // Beyond 1 mm only "beyond" counts: the median and p99 asserted below are far under it.
    let mut d: Vec<Real> = result.cloud.positions.iter().map(|p| dist.distance_up_to(p, 1.0)).collect();
    d.sort_by(Real::total_cmp);
    let (median, p99) = (d[d.len() / 2], d[d.len() * 99 / 100]);
    let r = &result.report;
    eprintln!(
        "mean shift: {} → {} points ({} strays, {} clusters, {} isolated) in {seconds:.1} s (kernels {:.1} s, shift {:.1} s, {:.1} iterations, {} at the limit);\n  far outliers removed {:.2} % ({far_removed}/{far_total}); removed that are outliers {:.2} % ({removed_outliers}/{removed}); kept median {median:.4} mm, p99 {p99:.4} mm",
        r.points_in,
        r.points_out,
        r.strays,
        r.clusters,
        r.outliers_removed,
        r.seconds_kernels,
        r.seconds_shift,
        r.mean_iterations,
        r.hit_iteration_limit,
        100.0 * far_removed as Real / far_total as Real,
        100.0 * removed_outliers as Real / removed.max(1) as Real
    );
    // Issue 8's acceptance 3. The strays are caught by the normalised kernel density at their start;
    // the density of converged representatives (section 3.3.1) is the backstop for outlier groups.
    assert!(
        removed_outliers as Real >= 0.98 * removed as Real,
        "of removed points, outliers: {removed_outliers}/{removed}"
    );
    assert!(far_removed as Real >= 0.99 * far_total as Real, "far outliers removed: {far_removed}/{far_total}");
    assert!(median <= 0.03, "kept median {median} mm");
    assert!(p99 <= 0.2, "kept p99 {p99} mm");
}
