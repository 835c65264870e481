//! A board swept on the turntable, adjusted as one rigid motion: every view's board pose is the
//! same board-on-platter pose turned by the view's recorded angle about one axis,
//! `camera_from_board(θ) = camera_from_object(θ) · object_from_board`. Ten unknowns (the axis's
//! direction and position across it, and the board on the platter) are fitted to every corner of
//! every view by Levenberg–Marquardt, instead of six per view: per-view poses from 0.1 px corners
//! wobble by a few hundredths of a degree, which tilts laser planes fitted from them by as much.

use crate::camera_calib::CalibError;
use crate::least_squares;
use crate::turntable_axis::{board_pose, fit_axis_seen, lowest_corner, pose_from, seen};
use nalgebra::DVector;
use rig::math::{Isometry3, Point2, Point3, Real, Rotation3, Translation3, UnitVector3, Vector3};
use rig::{PinholeCamera, TurntableAxis};
use serde::Serialize;

/// One view of the sweep: the turntable angle it was taken at and the board's corners.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepView {
    /// Turntable angle (degrees, counter-clockwise seen from above, as the scan folder records it).
    pub angle_deg: Real,
    /// The board's inner corners (row-major): all of them, or those numbered `ids`.
    pub corners: Vec<Point2>,
    /// The corners' numbers on the board, for a board partly seen; empty: every corner, in order.
    pub ids: Vec<usize>,
}

impl SweepView {
    /// The numbers of this view's corners.
    fn numbers(&self, object: &[Point3]) -> Vec<usize> {
        if self.ids.is_empty() { (0..object.len()).collect() } else { self.ids.clone() }
    }
}

/// What [`fit_sweep`] found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepFit {
    /// The axis: platter centre and upward direction, camera frame.
    #[serde(skip)]
    pub axis: TurntableAxis,
    /// The board on the platter (object frame).
    #[serde(skip)]
    pub object_from_board: Isometry3,
    /// camera_from_board of every view.
    #[serde(skip)]
    pub poses: Vec<Isometry3>,
    /// RMS reprojection error over all corners (px).
    pub rms_px: Real,
    /// RMS per view (px), in the order of the views given.
    pub view_rms_px: Vec<Real>,
    /// Levenberg–Marquardt iterations.
    pub iterations: usize,
}

/// The largest disagreement (degrees) tolerated between the turn the board's poses show and the
/// turn the recorded angles say, before the sweep is called inconsistent.
const ANGLE_TOLERANCE_DEG: Real = 3.0;

/// Fits the sweep (see the module notes). `object` are the board corners (board frame, mm);
/// `corner_height_mm` is how far the lowest inner corners stand above the platter (as for
/// [`crate::fit_axis`]), which fixes the axis point's height.
pub fn fit_sweep(
    camera: &PinholeCamera,
    object: &[Point3],
    views: &[SweepView],
    corner_height_mm: Real,
) -> Result<SweepFit, CalibError> {
    let ids: Vec<Vec<usize>> = views.iter().map(|v| v.numbers(object)).collect();
    let objects: Vec<Vec<Point3>> = ids.iter().map(|i| seen(object, i)).collect();
    if views.iter().zip(&objects).any(|(v, o)| v.corners.len() != o.len()) {
        return Err(CalibError::Degenerate("a view's corners and their numbers differ in count".into()));
    }
    let seen_views: Vec<(&[usize], &[Point2])> =
        ids.iter().zip(views).map(|(i, v)| (i.as_slice(), v.corners.as_slice())).collect();
    let start = fit_axis_seen(camera, object, &seen_views, corner_height_mm)?;
    let poses: Vec<Option<Isometry3>> =
        objects.iter().zip(views).map(|(o, v)| board_pose(camera, o, &v.corners)).collect();
    let (first, p0) = poses.iter().enumerate().find_map(|(k, p)| p.map(|p| (k, p))).expect("fit_axis found poses");
    // The recorded angles must turn the board as its poses do, in size and sense.
    let axis0 = start.axis;
    for (k, p) in poses.iter().enumerate() {
        let Some(p) = p else { continue };
        let rel = (p.rotation * p0.rotation.inverse()).scaled_axis();
        let seen = rel.dot(&axis0.direction).to_degrees();
        let said = views[k].angle_deg - views[first].angle_deg;
        // The pose's turn is within ±180°; recorded angles may cross 360°.
        let off = (seen - said + 180.0).rem_euclid(360.0) - 180.0;
        if off.abs() > ANGLE_TOLERANCE_DEG {
            return Err(CalibError::Degenerate(format!(
                "view {k}: the board turned {seen:.1}° from view {first} but the recorded angles differ by {said:.1}° \
                 (a turntable turning the other way, or angles not matching the frames)"
            )));
        }
    }
    let e1 =
        axis0.direction.cross(&if axis0.direction.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() }).normalize();
    let e2 = axis0.direction.cross(&e1);
    let b0 = axis0.object_from_camera(views[first].angle_deg) * p0;
    let axis_of = |x: &[Real]| {
        let tilt = Rotation3::from_scaled_axis(e1 * x[0] + e2 * x[1]);
        TurntableAxis {
            point: axis0.point + e1 * x[2] + e2 * x[3],
            direction: UnitVector3::new_normalize(tilt * axis0.direction.into_inner()),
        }
    };
    let mut x0 = DVector::zeros(10);
    x0.fixed_rows_mut::<3>(4).copy_from(&b0.rotation.scaled_axis());
    x0.fixed_rows_mut::<3>(7).copy_from(&b0.translation.vector);
    // Every view enters the adjustment, even one whose own pose did not converge.
    let used: Vec<usize> = (0..views.len()).collect();
    let residuals = |x: &DVector<Real>| -> Vec<Real> {
        let axis = axis_of(x.as_slice());
        let b = pose_from(&x.as_slice()[4..10]);
        used.iter()
            .flat_map(|&k| {
                let pose = axis.camera_from_object(views[k].angle_deg) * b;
                objects[k].iter().zip(&views[k].corners).flat_map(move |(o, c)| {
                    let p = camera.project(&(pose * o)).unwrap_or(Point2::new(1e6, 1e6));
                    [p.x - c.x, p.y - c.y]
                })
            })
            .collect()
    };
    let m = least_squares::minimize(x0, 100, residuals);
    let mut axis = axis_of(m.x.as_slice());
    let mut b = pose_from(&m.x.as_slice()[4..10]);
    // Slide the axis point to the platter plane; the object frame's origin moves with it.
    let up = axis.direction.into_inner();
    let h = used
        .iter()
        .map(|&k| lowest_corner(&(axis.camera_from_object(views[k].angle_deg) * b), object, &up, &axis.point))
        .sum::<Real>()
        / used.len() as Real
        - corner_height_mm;
    axis.point += axis.direction.into_inner() * h;
    b = Translation3::new(0.0, 0.0, -h) * b;
    // Each view's share of the residuals: two per corner it saw.
    let mut at = 0;
    let view_rms_px: Vec<Real> = used
        .iter()
        .map(|&k| {
            let n = objects[k].len();
            let r = &m.residuals[at..at + 2 * n];
            at += 2 * n;
            (r.iter().map(|v| v * v).sum::<Real>() / n.max(1) as Real).sqrt()
        })
        .collect();
    let corners_used: usize = used.iter().map(|&k| objects[k].len()).sum();
    let rms_px = (m.residuals.iter().map(|v| v * v).sum::<Real>() / corners_used.max(1) as Real).sqrt();
    let poses = views.iter().map(|v| axis.camera_from_object(v.angle_deg) * b).collect();
    Ok(SweepFit { axis, object_from_board: b, poses, rms_px, view_rms_px, iterations: m.iterations })
}
