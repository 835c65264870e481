//! A laser's plane from its line on a chessboard: every laser pixel on the board is where the
//! camera ray through it meets the board's plane (known from the board pose of the lit frame taken
//! at the same position); the points of views with the board at different angles span the laser
//! plane, fitted robustly (RANSAC, then least squares on the inliers) as Horus and FabScan do.
//!
//! Laser pixels are found by the caller (`process::triangulate::laser_line` in `scanrig calibrate`); this module
//! only needs them, and [`BoardRegion`] to keep those on the printed board.

use crate::camera_calib::CalibError;
use rig::math::{Isometry3, Matrix3, Point2, Point3, Real, UnitVector3, Vector3};
use rig::{LaserPlane, PinholeCamera};
use serde::Serialize;

/// One laser frame: where the board was (camera_from_board) and the laser pixels seen on it.
#[derive(Debug, Clone, PartialEq)]
pub struct LaserView {
    /// camera_from_board of the lit frame at the same position.
    pub pose: Isometry3,
    /// Sub-pixel laser centres (distorted pixels).
    pub pixels: Vec<Point2>,
}

/// What [`fit_laser_plane`] found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LaserFit {
    /// The plane, camera frame, `n·X = d` with `d ≥ 0`.
    #[serde(skip)]
    pub plane: LaserPlane,
    /// RMS distance of the inliers from the plane (mm): the spread the issue asks to report.
    pub rms_mm: Real,
    /// Largest inlier distance (mm).
    pub max_mm: Real,
    /// Points triangulated on the boards.
    pub points: usize,
    /// Points within the tolerance of the plane.
    pub inliers: usize,
    /// Views that contributed points.
    pub views: usize,
}

/// The image region of the printed board: the quadrilateral of its four outer inner corners. Laser
/// pixels outside it may be on the platter or the background, not on the board's plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoardRegion {
    quad: [Point2; 4],
}

impl BoardRegion {
    /// The region of `corners` (row-major, `cols × rows`, as [`crate::find_corners`] returns them).
    pub fn new(corners: &[Point2], cols: usize, rows: usize) -> Option<BoardRegion> {
        if cols < 2 || rows < 2 || corners.len() != cols * rows {
            return None;
        }
        let at = |i: usize, j: usize| corners[j * cols + i];
        Some(BoardRegion { quad: [at(0, 0), at(cols - 1, 0), at(cols - 1, rows - 1), at(0, rows - 1)] })
    }

    /// Whether `p` is inside (the quadrilateral is convex for any view of a plane).
    pub fn contains(&self, p: Point2) -> bool {
        let mut sign = 0.0;
        for k in 0..4 {
            let (a, b) = (self.quad[k], self.quad[(k + 1) % 4]);
            let c = (b - a).perp(&(p - a));
            if c * sign < 0.0 {
                return false;
            }
            if c != 0.0 {
                sign = c;
            }
        }
        true
    }

    /// The rows of the image the region spans, clamped to `height`.
    pub fn rows(&self, height: u32) -> std::ops::Range<usize> {
        let lo = self.quad.iter().map(|p| p.y).fold(Real::INFINITY, Real::min).floor().max(0.0) as usize;
        let hi = self.quad.iter().map(|p| p.y).fold(Real::NEG_INFINITY, Real::max).ceil().max(0.0) as usize;
        lo.min(height as usize)..(hi + 1).min(height as usize)
    }
}

/// Whether the lit frame is even across `half` pixels either side of `px` along its row: a stripe
/// straddling a square's edge has one flank on black print and one on white, which drags its
/// centre toward the white by up to a pixel, so such pixels are left out of the fit.
pub fn on_even_print(lit: &rig::image::Image8, px: Point2, half: usize) -> bool {
    let (w, h) = (lit.width as usize, lit.height as usize);
    let (c, r) = (px.x.round(), px.y.round());
    if c < 0.0 || r < 0.0 || c as usize >= w || r as usize >= h {
        return false;
    }
    let (c, r) = (c as usize, r as usize);
    let row = &lit.data[r * w + c.saturating_sub(half)..r * w + (c + half + 1).min(w)];
    let (lo, hi) = row.iter().fold((u8::MAX, 0u8), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    // Print contrast is several-fold; sensor noise and shading are a few grey levels.
    (hi as Real) <= 1.3 * lo as Real + 8.0
}

/// Where the camera rays through `pixels` meet the board plane of `pose` (camera frame). Pixels whose
/// ray misses the plane ahead of the camera are skipped.
pub fn board_points(camera: &PinholeCamera, pose: &Isometry3, pixels: &[Point2]) -> Vec<Point3> {
    let n = pose.rotation * Vector3::z();
    let d = n.dot(&pose.translation.vector);
    pixels
        .iter()
        .filter_map(|&px| {
            let q = camera.pixel_to_normalized(px)?;
            let ray = Vector3::new(q.x, q.y, 1.0);
            let denom = n.dot(&ray);
            if denom.abs() < 1e-9 {
                return None;
            }
            let t = d / denom;
            (t > 0.0).then(|| Point3::from(ray * t))
        })
        .collect()
}

/// The least-squares plane through `pts` (the smallest principal direction of their scatter): unit
/// normal, the centroid, and the two larger eigenvalues of the scatter over the count.
fn principal_plane(pts: &[Point3]) -> (Vector3, Vector3, [Real; 2]) {
    let c = pts.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / pts.len() as Real;
    let mut m = Matrix3::zeros();
    for p in pts {
        let d = p.coords - c;
        m += d * d.transpose();
    }
    m /= pts.len() as Real;
    let eig = m.symmetric_eigen();
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let n = eig.eigenvectors.column(order[0]).into_owned();
    (n, c, [eig.eigenvalues[order[1]], eig.eigenvalues[order[2]]])
}

/// Fits the laser plane to the laser points of all `views`: RANSAC with `tolerance_mm` (Horus and
/// FabScan use the same two-step fit), then least squares on the inliers, twice. Fails when fewer than
/// two views contributed, or the points lie on one line (the board never turned).
pub fn fit_laser_plane(
    camera: &PinholeCamera,
    views: &[LaserView],
    tolerance_mm: Real,
) -> Result<LaserFit, CalibError> {
    let per_view: Vec<Vec<Point3>> = views.iter().map(|v| board_points(camera, &v.pose, &v.pixels)).collect();
    let used = per_view.iter().filter(|p| p.len() >= 10).count();
    if used < 2 {
        return Err(CalibError::TooFewViews(format!(
            "the laser line was found on the board in {used} view(s); at least 2 at different board angles are needed"
        )));
    }
    let pts: Vec<Point3> = per_view.into_iter().filter(|p| p.len() >= 10).flatten().collect();
    let (_, _, spread) = principal_plane(&pts);
    // A single line (or boards all at one angle) leaves the middle eigenvalue near zero.
    if spread[0] < 1e-4 * spread[1] || spread[0] < 0.25 {
        return Err(CalibError::Degenerate(
            "the laser points lie on one line: the board did not turn between the laser views".into(),
        ));
    }
    // Seeded: the same input gives the same plane.
    let mut rng = rig::split_mix::SplitMix(0x5eed);
    let (mut best, mut best_count) = (None, 0usize);
    for _ in 0..300 {
        let (a, b, c) = (pts[rng.below(pts.len())], pts[rng.below(pts.len())], pts[rng.below(pts.len())]);
        let n = (b - a).cross(&(c - a));
        if n.norm() < 1e-6 {
            continue;
        }
        let n = n.normalize();
        let d = n.dot(&a.coords);
        let count = pts.iter().filter(|p| (n.dot(&p.coords) - d).abs() <= tolerance_mm).count();
        if count > best_count {
            (best, best_count) = (Some((n, d)), count);
        }
    }
    let (mut n, mut d) = best.ok_or_else(|| CalibError::Degenerate("no three laser points span a plane".into()))?;
    let mut inliers: Vec<Point3> = Vec::new();
    for _ in 0..2 {
        inliers = pts.iter().copied().filter(|p| (n.dot(&p.coords) - d).abs() <= tolerance_mm).collect();
        if inliers.len() < 3 {
            return Err(CalibError::Degenerate("too few laser points near any plane".into()));
        }
        let (nn, c, _) = principal_plane(&inliers);
        (n, d) = (nn, nn.dot(&c));
    }
    if d < 0.0 {
        (n, d) = (-n, -d);
    }
    let dist: Vec<Real> = inliers.iter().map(|p| (n.dot(&p.coords) - d).abs()).collect();
    Ok(LaserFit {
        plane: LaserPlane { normal: UnitVector3::new_normalize(n), distance: d },
        rms_mm: (dist.iter().map(|x| x * x).sum::<Real>() / dist.len() as Real).sqrt(),
        max_mm: dist.iter().copied().fold(0.0, Real::max),
        points: pts.len(),
        inliers: inliers.len(),
        views: used,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::math::{Translation3, UnitQuaternion};

    fn camera() -> PinholeCamera {
        PinholeCamera {
            width: 640,
            height: 480,
            fx: 600.0,
            fy: 600.0,
            cx: 320.0,
            cy: 240.0,
            distortion: rig::Distortion::from_opencv([0.0; 5]),
        }
    }

    /// Pixels of the line where `plane` meets the board at `pose`.
    fn line_pixels(cam: &PinholeCamera, pose: &Isometry3, plane: &LaserPlane) -> Vec<Point2> {
        // Points on both planes: march along the intersection line.
        let nb = pose.rotation * Vector3::z();
        let db = nb.dot(&pose.translation.vector);
        let dir = plane.normal.cross(&nb).normalize();
        // The point of both planes nearest the board origin, then along their common line.
        let t = pose.translation.vector;
        let g = nalgebra::Matrix2::new(1.0, plane.normal.dot(&nb), plane.normal.dot(&nb), 1.0);
        let rhs = nalgebra::Vector2::new(plane.distance - plane.normal.dot(&t), db - nb.dot(&t));
        let ab = g.try_inverse().unwrap() * rhs;
        let p0 = t + plane.normal.into_inner() * ab.x + nb * ab.y;
        (-40..=40).filter_map(|k| cam.project(&Point3::from(p0 + dir * k as Real))).collect()
    }

    #[test]
    fn boards_at_several_angles_give_the_plane_back() {
        let cam = camera();
        let truth = LaserPlane::new(Vector3::new(0.8, -0.05, 0.6), 120.0).unwrap();
        let views: Vec<LaserView> = [-30.0f64, -10.0, 15.0, 35.0]
            .iter()
            .map(|&deg| {
                let pose = Isometry3::from_parts(
                    Translation3::new(-50.0 + deg, -40.0, 320.0),
                    UnitQuaternion::from_euler_angles(0.0, deg.to_radians(), 0.0),
                );
                LaserView { pose, pixels: line_pixels(&cam, &pose, &truth) }
            })
            .collect();
        let fit = fit_laser_plane(&cam, &views, 0.5).unwrap();
        assert!(fit.plane.normal.angle(&truth.normal).to_degrees() < 1e-6, "{:?}", fit.plane);
        assert!((fit.plane.distance - truth.distance).abs() < 1e-6);
        assert_eq!(fit.views, 4);
        // One view alone is a line, not a plane.
        assert!(matches!(fit_laser_plane(&cam, &views[..1], 0.5), Err(CalibError::TooFewViews(_))));
        let same: Vec<LaserView> = vec![views[0].clone(), views[0].clone()];
        assert!(matches!(fit_laser_plane(&cam, &same, 0.5), Err(CalibError::Degenerate(_))));
    }

    #[test]
    fn the_region_holds_the_board_and_not_beyond() {
        let corners: Vec<Point2> = (0..3)
            .flat_map(|j| (0..4).map(move |i| Point2::new(100.0 + 10.0 * i as Real, 50.0 + 10.0 * j as Real)))
            .collect();
        let r = BoardRegion::new(&corners, 4, 3).unwrap();
        assert!(r.contains(Point2::new(115.0, 60.0)));
        assert!(!r.contains(Point2::new(135.0, 60.0)) && !r.contains(Point2::new(115.0, 75.0)));
        assert_eq!(r.rows(480), 50..71);
        assert!(BoardRegion::new(&corners, 3, 3).is_none());
    }
}
