//! The projector, calibrated as an inverse camera (Moreno & Taubin, "Simple, accurate, and robust
//! projector-camera calibration", 2012): the board's corners are found in the camera; the decoded
//! structured light around each corner gives a local homography from camera pixels to projector
//! pixels, which carries the corner into the projector's image; the projector is then calibrated
//! from those corners like a camera, and finally the camera–projector extrinsics are refined
//! jointly with every board pose over both devices' reprojection errors (OpenCV's
//! `stereoCalibrate` with the camera's intrinsics fixed).
//!
//! A local homography instead of the decoded value at the corner pixel: a corner sits between black
//! and white squares, where decoding is weakest, and the homography averages hundreds of decoded
//! pixels, so projector corners come out to a fraction of a projector pixel.

use crate::camera_calib::{CalibError, CameraOptions, View, calibrate_camera};
use crate::homography::homography;
use crate::least_squares;
use crate::turntable_axis::{board_pose, pose_from};
use decode::ProjectorMap;
use nalgebra::DVector;
use rig::math::{Isometry3, Matrix3, Point2, Point3, Real, Vector3};
use rig::{Distortion, PinholeCamera};
use serde::Serialize;

/// The projector pixel of each camera `corner`, by a homography fitted to the decoded pixels within
/// `half_window` pixels of it (camera → projector). `None` where fewer than a quarter of the window's
/// pixels decoded, or the fit is poor (its RMS over a projector pixel).
pub fn projector_corners(corners: &[Point2], decoded: &ProjectorMap, half_window: usize) -> Vec<Option<Point2>> {
    let (w, h) = (decoded.width as isize, decoded.height as isize);
    let r = half_window as isize;
    corners
        .iter()
        .map(|c| {
            let (cx, cy) = (c.x.round() as isize, c.y.round() as isize);
            let (mut cam, mut proj) = (Vec::new(), Vec::new());
            for y in (cy - r).max(0)..=(cy + r).min(h - 1) {
                for x in (cx - r).max(0)..=(cx + r).min(w - 1) {
                    let i = (y * w + x) as usize;
                    let (u, v) = (decoded.u[i], decoded.v[i]);
                    if u.is_finite() && v.is_finite() {
                        cam.push(Point2::new(x as Real - c.x, y as Real - c.y));
                        proj.push(Point2::new(u, v));
                    }
                }
            }
            let window = ((2 * r + 1) * (2 * r + 1)) as usize;
            if cam.len() * 4 < window {
                return None;
            }
            // Fit, drop decoding slips (over two projector pixels off), fit again.
            let mut hm = homography(&cam, &proj)?;
            for _ in 0..2 {
                let keep: Vec<usize> =
                    (0..cam.len()).filter(|&k| (apply(&hm, &cam[k]) - proj[k]).norm() <= 2.0).collect();
                if keep.len() * 4 < window {
                    return None;
                }
                let (c2, p2): (Vec<Point2>, Vec<Point2>) = keep.iter().map(|&k| (cam[k], proj[k])).unzip();
                hm = homography(&c2, &p2)?;
                let rms = (c2.iter().zip(&p2).map(|(a, b)| (apply(&hm, a) - b).norm_squared()).sum::<Real>()
                    / c2.len() as Real)
                    .sqrt();
                if rms > 1.0 {
                    return None;
                }
            }
            // The corner is the window's origin.
            Some(apply(&hm, &Point2::origin()))
        })
        .collect()
}

fn apply(m: &Matrix3, p: &Point2) -> Point2 {
    let v = m * Vector3::new(p.x, p.y, 1.0);
    Point2::new(v.x / v.z, v.y / v.z)
}

/// One board pose seen by both devices.
#[derive(Debug, Clone, PartialEq)]
pub struct StereoView {
    /// Board corners (board frame, mm).
    pub object: Vec<Point3>,
    /// Their camera pixels.
    pub camera: Vec<Point2>,
    /// Their projector pixels, where the local homography gave one.
    pub projector: Vec<Option<Point2>>,
}

/// What [`calibrate_projector`] found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProjectorCalibration {
    /// The projector's lens.
    #[serde(skip)]
    pub lens: PinholeCamera,
    /// Camera frame → projector frame.
    #[serde(skip)]
    pub from_camera: Isometry3,
    /// RMS of the projector-only calibration (projector px).
    pub projector_rms: Real,
    /// RMS over both devices after the joint refinement (px).
    pub stereo_rms: Real,
    /// RMS of the camera's residuals in the joint refinement (camera px).
    pub stereo_camera_rms: Real,
    /// RMS of the projector's residuals in the joint refinement (projector px).
    pub stereo_projector_rms: Real,
    /// Views used.
    pub views: usize,
    /// Corners carried into the projector, and corners skipped (too little decoded around them).
    pub corners_used: usize,
    /// See `corners_used`.
    pub corners_skipped: usize,
}

/// Calibrates a `width × height` projector and its pose against `camera` (already calibrated) from
/// board views seen by both (see the module notes). Views with fewer than eight projector corners are
/// left out.
pub fn calibrate_projector(
    camera: &PinholeCamera,
    views: &[StereoView],
    width: u32,
    height: u32,
    opts: CameraOptions,
) -> Result<ProjectorCalibration, CalibError> {
    let (mut used, mut skipped) = (0, 0);
    let mut kept: Vec<(&StereoView, View)> = Vec::new();
    for v in views {
        let pairs: Vec<(Point3, Point2)> =
            v.object.iter().zip(&v.projector).filter_map(|(o, p)| p.map(|p| (*o, p))).collect();
        skipped += v.object.len() - pairs.len();
        if pairs.len() < 8 {
            skipped += pairs.len();
            continue;
        }
        used += pairs.len();
        let (object, image) = pairs.into_iter().unzip();
        kept.push((v, View { object, image }));
    }
    if kept.len() < 3 {
        return Err(CalibError::TooFewViews(format!(
            "{} views have the board's corners in the projector's decoded light; at least 3 are needed",
            kept.len()
        )));
    }
    let proj_views: Vec<View> = kept.iter().map(|(_, v)| v.clone()).collect();
    let own = calibrate_camera(&proj_views, width, height, opts)?;

    // Start: camera poses from the camera's corners, extrinsics as the mean of
    // projector_from_board · board_from_camera over the views.
    let cam_poses: Vec<Isometry3> = kept
        .iter()
        .map(|(v, _)| board_pose(camera, &v.object, &v.camera))
        .collect::<Option<_>>()
        .ok_or_else(|| CalibError::Degenerate("a board pose in the camera is undefined".into()))?;
    let rels: Vec<Isometry3> = own.poses.iter().zip(&cam_poses).map(|(p, c)| p * c.inverse()).collect();
    let r0 = rels[0].rotation;
    let mean_rot =
        rels.iter().fold(Vector3::zeros(), |a, r| a + (r.rotation * r0.inverse()).scaled_axis()) / rels.len() as Real;
    let rot = rig::math::UnitQuaternion::from_scaled_axis(mean_rot) * r0;
    let trans = rels.iter().fold(Vector3::zeros(), |a, r| a + r.translation.vector) / rels.len() as Real;

    // Joint refinement: extrinsics (6), the projector's free lens terms (fx, fy unless the aspect
    // ratio is fixed, cx cy unless the principal point is, k1 k2), then 6 per board pose.
    let lens0 = own.camera;
    let d0 = lens0.distortion.to_opencv();
    let aspect = lens0.fy / lens0.fx;
    let mut lens_free = vec![lens0.fx];
    if !opts.fix_aspect_ratio {
        lens_free.push(lens0.fy);
    }
    if !opts.fix_principal_point {
        lens_free.extend([lens0.cx, lens0.cy]);
    }
    lens_free.extend([d0[0], d0[1]]);
    let nl = lens_free.len();
    let mut x0 = Vec::with_capacity(6 + nl + 6 * kept.len());
    x0.extend(rot.scaled_axis().iter());
    x0.extend(trans.iter());
    x0.extend(lens_free);
    for p in &cam_poses {
        x0.extend(p.rotation.scaled_axis().iter());
        x0.extend(p.translation.vector.iter());
    }
    let lens_of = |x: &[Real]| {
        let mut l = x[6..6 + nl].iter().copied();
        let fx = l.next().expect("fx");
        let fy = if opts.fix_aspect_ratio { fx * aspect } else { l.next().expect("fy") };
        let (cx, cy) = if opts.fix_principal_point {
            (lens0.cx, lens0.cy)
        } else {
            (l.next().expect("cx"), l.next().expect("cy"))
        };
        let (k1, k2) = (l.next().expect("k1"), l.next().expect("k2"));
        PinholeCamera {
            width,
            height,
            fx,
            fy,
            cx,
            cy,
            distortion: Distortion::from_opencv([k1, k2, d0[2], d0[3], d0[4]]),
        }
    };
    let ncam: usize = kept.iter().map(|(v, _)| v.object.len()).sum();
    let residuals = |x: &DVector<Real>| -> Vec<Real> {
        let x = x.as_slice();
        let ext = pose_from(&x[0..6]);
        let lens = lens_of(x);
        let mut r = Vec::with_capacity(2 * (ncam + used));
        for (k, (v, pv)) in kept.iter().enumerate() {
            let pose = pose_from(&x[6 + nl + 6 * k..12 + nl + 6 * k]);
            for (o, c) in v.object.iter().zip(&v.camera) {
                let p = camera.project(&(pose * o)).unwrap_or(Point2::new(1e6, 1e6));
                r.extend([p.x - c.x, p.y - c.y]);
            }
            for (o, c) in pv.object.iter().zip(&pv.image) {
                let p = lens.project(&(ext * (pose * o))).unwrap_or(Point2::new(1e6, 1e6));
                r.extend([p.x - c.x, p.y - c.y]);
            }
        }
        r
    };
    let m = least_squares::minimize(DVector::from_vec(x0), 100, residuals);
    let x = m.x.as_slice();
    let (mut sc, mut sp, mut nc) = (0.0, 0.0, 0usize);
    let mut at = 0;
    for (v, pv) in &kept {
        let n = 2 * v.object.len();
        sc += m.residuals[at..at + n].iter().map(|e| e * e).sum::<Real>();
        nc += v.object.len();
        at += n;
        let np = 2 * pv.object.len();
        sp += m.residuals[at..at + np].iter().map(|e| e * e).sum::<Real>();
        at += np;
    }
    Ok(ProjectorCalibration {
        lens: lens_of(x),
        from_camera: pose_from(&x[0..6]),
        projector_rms: own.rms,
        stereo_rms: ((sc + sp) / (nc + used) as Real).sqrt(),
        stereo_camera_rms: (sc / nc as Real).sqrt(),
        stereo_projector_rms: (sp / used as Real).sqrt(),
        views: kept.len(),
        corners_used: used,
        corners_skipped: skipped,
    })
}
