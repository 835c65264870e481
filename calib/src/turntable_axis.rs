//! The turntable axis from a board standing on the platter, swept through angles: every corner
//! turns on a circle about the axis. The direction is the rotation axis between the board's poses;
//! each corner's circle (a least-squares circle in the plane across that direction) has its centre
//! on the axis; the platter centre is where the axis meets the plane the board stands on.

use crate::camera_calib::CalibError;
use crate::homography::homography;
use crate::least_squares;
use crate::zhang;
use nalgebra::DVector;
use rig::math::{Isometry3, Matrix3, Point2, Point3, Real, Vector3};
use rig::{PinholeCamera, TurntableAxis};
use serde::Serialize;

/// What [`fit_axis`] found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AxisFit {
    /// The axis: platter centre and upward direction, camera frame.
    #[serde(skip)]
    pub axis: TurntableAxis,
    /// RMS distance of the corners from their fitted circles (mm).
    pub circle_rms_mm: Real,
    /// Views used.
    pub views: usize,
}

/// The board pose (camera_from_board) from its corners: the homography of the undistorted rays to
/// start, then Levenberg–Marquardt on the reprojection error (the homography alone is biased in
/// depth by the pixel noise it does not weigh).
pub fn board_pose(camera: &PinholeCamera, object: &[Point3], corners: &[Point2]) -> Option<Isometry3> {
    let plane: Vec<Point2> = object.iter().map(|p| Point2::new(p.x, p.y)).collect();
    let rays: Vec<Point2> = corners.iter().map(|p| camera.pixel_to_normalized(*p)).collect::<Option<_>>()?;
    let start = zhang::pose(&Matrix3::identity(), &homography(&plane, &rays)?)?;
    Some(refine_pose(camera, object, corners, start))
}

/// How far the platter turned between two frames of a board standing on it, about the rig's axis
/// (degrees, counter-clockwise seen from above as the turntable counts): the rotation from the
/// board's pose in the first frame to its pose in the second, projected on the axis' direction.
/// `None` when either pose cannot be found. The turntable check of `scanrig serve` compares it with
/// the turn it asked for: a wrong sign is a motor wired backwards, a wrong size the steps per degree.
pub fn measured_turn(
    camera: &PinholeCamera,
    axis: &rig::TurntableAxis,
    object: &[Point3],
    before: &[Point2],
    after: &[Point2],
) -> Option<Real> {
    let (p0, p1) = (board_pose(camera, object, before)?, board_pose(camera, object, after)?);
    // camera_from_object(θ) = O₀⁻¹·Rz(θ): the board's motion in the camera frame is a turn by θ
    // about the axis direction (rig::turntable).
    Some((p1 * p0.inverse()).rotation.scaled_axis().dot(&axis.direction).to_degrees())
}

fn refine_pose(camera: &PinholeCamera, object: &[Point3], corners: &[Point2], start: Isometry3) -> Isometry3 {
    let mut x0 = DVector::zeros(6);
    x0.fixed_rows_mut::<3>(0).copy_from(&start.rotation.scaled_axis());
    x0.fixed_rows_mut::<3>(3).copy_from(&start.translation.vector);
    let m = least_squares::minimize(x0, 50, |x| {
        let pose = pose_from(x.as_slice());
        object
            .iter()
            .zip(corners)
            .flat_map(|(o, c)| {
                let p = camera.project(&(pose * o)).unwrap_or(Point2::new(1e6, 1e6));
                [p.x - c.x, p.y - c.y]
            })
            .collect()
    });
    pose_from(m.x.as_slice())
}

/// A pose from a rotation vector then a translation.
pub(crate) fn pose_from(x: &[Real]) -> Isometry3 {
    Isometry3::from_parts(
        rig::math::Translation3::new(x[3], x[4], x[5]),
        rig::math::Rotation3::from_scaled_axis(Vector3::new(x[0], x[1], x[2])).into(),
    )
}

/// Fits the axis from full-board corners in each view of a sweep. `object` are the board corners
/// (board frame, mm); `corner_height_mm` is how far the lowest inner corners stand above the
/// platter (Horus and FabScan call it the pattern's origin distance), which places the axis point
/// on the platter.
pub fn fit_axis(
    camera: &PinholeCamera,
    object: &[Point3],
    views: &[Vec<Point2>],
    corner_height_mm: Real,
) -> Result<AxisFit, CalibError> {
    let all: Vec<usize> = (0..object.len()).collect();
    let views: Vec<(&[usize], &[Point2])> = views.iter().map(|c| (all.as_slice(), c.as_slice())).collect();
    fit_axis_seen(camera, object, &views, corner_height_mm)
}

/// [`fit_axis`] from the corners each view saw: `(numbers, pixels)` per view, the numbers indexing
/// `object` (a board partly seen, its corners identified). Each view's pose comes from its own
/// corners; every corner of the board then turns on its circle, seen or not.
pub fn fit_axis_seen(
    camera: &PinholeCamera,
    object: &[Point3],
    views: &[(&[usize], &[Point2])],
    corner_height_mm: Real,
) -> Result<AxisFit, CalibError> {
    let poses: Vec<Isometry3> = views.iter().filter_map(|(ids, c)| board_pose(camera, &seen(object, ids), c)).collect();
    if poses.len() < 3 {
        return Err(CalibError::TooFewViews(format!("{} views with a board pose; at least 3 are needed", poses.len())));
    }
    // Direction: the rotation axis from the first pose to each other one, weighted by the angle.
    let r0 = poses[0].rotation;
    let mut dir = Vector3::zeros();
    for p in &poses[1..] {
        let rel = p.rotation * r0.inverse();
        let axis = rel.scaled_axis();
        let sign = if dir.dot(&axis) < 0.0 { -1.0 } else { 1.0 };
        dir += axis * sign;
    }
    if dir.norm() < 1e-3 {
        return Err(CalibError::Degenerate("the board did not turn between views".into()));
    }
    let mut a = dir.normalize();
    // Up, out of the platter: the board's −y (its rows run down the standing board).
    let up = r0 * -Vector3::y();
    if a.dot(&up) < 0.0 {
        a = -a;
    }
    // A frame across the axis.
    let e1 = a.cross(&if a.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() }).normalize();
    let e2 = a.cross(&e1);
    let mut centres = Vec::new();
    let (mut sq, mut n) = (0.0, 0usize);
    for x in object {
        let pts: Vec<Point3> = poses.iter().map(|p| p * x).collect();
        let uv: Vec<(Real, Real)> = pts.iter().map(|p| (p.coords.dot(&e1), p.coords.dot(&e2))).collect();
        let Some((cu, cv, r)) = circle(&uv) else { continue };
        let spread = uv.iter().map(|&(u, v)| ((u - cu).powi(2) + (v - cv).powi(2)).sqrt()).fold(0.0, Real::max);
        if r < 1.0 || spread < 1e-9 {
            continue; // a corner near the axis hardly moves: its circle says little
        }
        let h = pts.iter().map(|p| p.coords.dot(&a)).sum::<Real>() / pts.len() as Real;
        for (&(u, v), p) in uv.iter().zip(&pts) {
            let radial = ((u - cu).powi(2) + (v - cv).powi(2)).sqrt() - r;
            let along = p.coords.dot(&a) - h;
            sq += radial * radial + along * along;
            n += 1;
        }
        centres.push((e1 * cu + e2 * cv + a * h, r));
    }
    if centres.len() < 2 {
        return Err(CalibError::Degenerate("no corner turned on a measurable circle".into()));
    }
    // The centres lie on the axis; weight by radius (wider circles pin their centres better).
    let wsum: Real = centres.iter().map(|c| c.1).sum();
    let m = centres.iter().fold(Vector3::zeros(), |acc, (c, r)| acc + c * *r) / wsum;
    // The platter plane's height along the axis, averaged over the views.
    let t = poses.iter().map(|p| lowest_corner(p, object, &a, &Point3::from(m))).sum::<Real>() / poses.len() as Real;
    let point = Point3::from(m + a * (t - corner_height_mm));
    Ok(AxisFit {
        axis: TurntableAxis { point, direction: rig::math::UnitVector3::new_normalize(a) },
        circle_rms_mm: (sq / n.max(1) as Real).sqrt(),
        views: poses.len(),
    })
}

/// The corners of `object` numbered `ids`.
pub(crate) fn seen(object: &[Point3], ids: &[usize]) -> Vec<Point3> {
    ids.iter().filter_map(|&i| object.get(i).copied()).collect()
}

/// How high the lowest corner of `object` at `pose` stands along `up` above `origin`.
pub(crate) fn lowest_corner(pose: &Isometry3, object: &[Point3], up: &Vector3, origin: &Point3) -> Real {
    object.iter().map(|o| up.dot(&(pose * o - origin))).fold(Real::INFINITY, Real::min)
}

/// The least-squares circle (Kåsa) through 2-D points: centre and radius.
fn circle(p: &[(Real, Real)]) -> Option<(Real, Real, Real)> {
    if p.len() < 3 {
        return None;
    }
    // x² + y² + D x + E y + F = 0.
    let mut ata = Matrix3::zeros();
    let mut atb = Vector3::zeros();
    for &(x, y) in p {
        let row = Vector3::new(x, y, 1.0);
        ata += row * row.transpose();
        atb -= row * (x * x + y * y);
    }
    let s = ata.try_inverse()? * atb;
    let (cx, cy) = (-s.x / 2.0, -s.y / 2.0);
    let r2 = cx * cx + cy * cy - s.z;
    (r2 > 0.0).then(|| (cx, cy, r2.sqrt()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_on_a_circle_give_it_back() {
        let pts: Vec<(Real, Real)> =
            (0..7).map(|k| (k as Real * 0.3).sin_cos()).map(|(s, c)| (3.0 + 5.0 * c, -2.0 + 5.0 * s)).collect();
        let (cx, cy, r) = circle(&pts).unwrap();
        assert!((cx - 3.0).abs() < 1e-9 && (cy + 2.0).abs() < 1e-9 && (r - 5.0).abs() < 1e-9);
    }
}
