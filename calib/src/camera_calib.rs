//! Camera intrinsics from views of a planar target: Zhang's closed form ([`crate::zhang`]) to start,
//! then Levenberg–Marquardt over fx, fy, cx, cy, the five OpenCV distortion terms and every view's
//! pose, minimising reprojection error as OpenCV's `calibrateCamera` does. Its RMS is OpenCV's: the
//! root of the summed squared pixel distances over the number of points.

use crate::homography::homography;
use crate::zhang;
use nalgebra::{DMatrix, DVector};
use rig::math::{Isometry3, Point2, Point3, Real, Rotation3, Translation3, Vector3};
use rig::{Distortion, PinholeCamera};
use serde::Serialize;

/// One view of the target: its points in the target frame (z = 0) and where they were seen.
#[derive(Debug, Clone, PartialEq)]
pub struct View {
    /// Target-frame points (mm), z = 0.
    pub object: Vec<Point3>,
    /// Their pixels.
    pub image: Vec<Point2>,
}

/// What to hold fixed, as OpenCV's `CALIB_FIX_ASPECT_RATIO`, `CALIB_FIX_PRINCIPAL_POINT`,
/// `CALIB_ZERO_TANGENT_DIST` and `CALIB_FIX_K3`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct CameraOptions {
    /// Keep fy / fx at the initial estimate's ratio.
    pub fix_aspect_ratio: bool,
    /// Keep the principal point at the image centre.
    pub fix_principal_point: bool,
    /// Keep p1 = p2 = 0.
    pub zero_tangential: bool,
    /// Keep k3 = 0.
    pub fix_k3: bool,
}

/// The result of [`calibrate_camera`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CameraCalibration {
    /// The camera.
    #[serde(skip)]
    pub camera: PinholeCamera,
    /// camera_from_target per view.
    #[serde(skip)]
    pub poses: Vec<Isometry3>,
    /// RMS reprojection error over all points (px).
    pub rms: Real,
    /// RMS per view (px).
    pub view_rms: Vec<Real>,
    /// Views whose RMS is more than three times the median and above 0.5 px.
    pub outlier_views: Vec<usize>,
    /// Levenberg–Marquardt iterations taken.
    pub iterations: usize,
}

/// Why calibration failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CalibError {
    /// Fewer usable views than the method needs.
    #[error("{0}")]
    TooFewViews(String),
    /// The views do not determine the unknowns.
    #[error("{0}")]
    Degenerate(String),
}

/// Parameter layout: 9 intrinsics, then 6 per view (rotation vector, translation).
const NI: usize = 9;

fn camera_of(x: &[Real], width: u32, height: u32) -> PinholeCamera {
    PinholeCamera {
        width,
        height,
        fx: x[0],
        fy: x[1],
        cx: x[2],
        cy: x[3],
        distortion: Distortion::from_opencv([x[4], x[5], x[6], x[7], x[8]]),
    }
}

fn pose_of(x: &[Real], v: usize) -> Isometry3 {
    let p = &x[NI + 6 * v..NI + 6 * v + 6];
    Isometry3::from_parts(
        Translation3::new(p[3], p[4], p[5]),
        Rotation3::from_scaled_axis(Vector3::new(p[0], p[1], p[2])).into(),
    )
}

/// View `v`'s residuals (projected − seen, x then y per point) into `out`.
fn view_residuals(x: &[Real], views: &[View], v: usize, width: u32, height: u32, out: &mut [Real]) {
    let cam = camera_of(x, width, height);
    let pose = pose_of(x, v);
    for (k, (o, seen)) in views[v].object.iter().zip(&views[v].image).enumerate() {
        let p = cam.project(&(pose * o)).unwrap_or(Point2::new(1e6, 1e6));
        out[2 * k] = p.x - seen.x;
        out[2 * k + 1] = p.y - seen.y;
    }
}

/// Calibrates a `width × height` camera from target views (see the module notes).
pub fn calibrate_camera(
    views: &[View],
    width: u32,
    height: u32,
    opts: CameraOptions,
) -> Result<CameraCalibration, CalibError> {
    let usable: Vec<&View> = views.iter().filter(|v| v.object.len() >= 4 && v.object.len() == v.image.len()).collect();
    if usable.len() < 3 {
        return Err(CalibError::TooFewViews(format!("{} views with a board; at least 3 are needed", usable.len())));
    }
    let views: Vec<View> = usable.into_iter().cloned().collect();
    let hs: Vec<_> = views
        .iter()
        .map(|v| {
            let plane: Vec<Point2> = v.object.iter().map(|p| Point2::new(p.x, p.y)).collect();
            homography(&plane, &v.image)
        })
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| CalibError::Degenerate("a view's points are collinear".into()))?;
    let mut k = zhang::intrinsics(&hs).map_err(CalibError::Degenerate)?;
    let centre = ((width as Real - 1.0) / 2.0, (height as Real - 1.0) / 2.0);
    if opts.fix_principal_point {
        k[(0, 2)] = centre.0;
        k[(1, 2)] = centre.1;
    }
    // Zhang's estimate wanders with strong distortion: a principal point off the image is discarded.
    if !(0.0..width as Real).contains(&k[(0, 2)]) || !(0.0..height as Real).contains(&k[(1, 2)]) {
        k[(0, 2)] = centre.0;
        k[(1, 2)] = centre.1;
    }
    let mut x = vec![k[(0, 0)], k[(1, 1)], k[(0, 2)], k[(1, 2)], 0.0, 0.0, 0.0, 0.0, 0.0];
    for h in &hs {
        let p = zhang::pose(&k, h).ok_or_else(|| CalibError::Degenerate("a view's pose is undefined".into()))?;
        x.extend(p.rotation.scaled_axis().iter());
        x.extend(p.translation.vector.iter());
    }
    let aspect = x[1] / x[0];
    let mut free: Vec<usize> = vec![0];
    if !opts.fix_aspect_ratio {
        free.push(1);
    }
    if !opts.fix_principal_point {
        free.extend([2, 3]);
    }
    free.extend([4, 5]);
    if !opts.zero_tangential {
        free.extend([6, 7]);
    }
    if !opts.fix_k3 {
        free.push(8);
    }
    free.extend(NI..x.len());
    let tie = |x: &mut [Real]| {
        if opts.fix_aspect_ratio {
            x[1] = x[0] * aspect;
        }
    };

    let offsets: Vec<usize> = views
        .iter()
        .scan(0, |acc, v| {
            let o = *acc;
            *acc += 2 * v.object.len();
            Some(o)
        })
        .collect();
    let rows = offsets.last().map_or(0, |&o| o) + 2 * views.last().map_or(0, |v| v.object.len());
    let residuals = |x: &[Real]| -> DVector<Real> {
        let mut r = DVector::zeros(rows);
        for v in 0..views.len() {
            let n = 2 * views[v].object.len();
            view_residuals(x, &views, v, width, height, &mut r.as_mut_slice()[offsets[v]..offsets[v] + n]);
        }
        r
    };
    let cost = |r: &DVector<Real>| r.norm_squared();

    let mut r = residuals(&x);
    let mut c = cost(&r);
    let mut mu = 1e-3;
    let mut iterations = 0;
    for it in 0..200 {
        iterations = it + 1;
        // Forward-difference Jacobian; a pose parameter only moves its own view's residuals.
        let mut jac = DMatrix::<Real>::zeros(rows, free.len());
        for (col, &p) in free.iter().enumerate() {
            let h = 1e-7 * x[p].abs().max(1.0);
            let mut xp = x.clone();
            xp[p] += h;
            tie(&mut xp);
            if p < NI {
                let rp = residuals(&xp);
                jac.set_column(col, &((rp - &r) / h));
            } else {
                let v = (p - NI) / 6;
                let n = 2 * views[v].object.len();
                let mut out = vec![0.0; n];
                view_residuals(&xp, &views, v, width, height, &mut out);
                for i in 0..n {
                    jac[(offsets[v] + i, col)] = (out[i] - r[offsets[v] + i]) / h;
                }
            }
        }
        let jtj = jac.transpose() * &jac;
        let jtr = jac.transpose() * &r;
        let mut improved = false;
        for _ in 0..12 {
            let mut a = jtj.clone();
            for i in 0..a.nrows() {
                a[(i, i)] += mu * jtj[(i, i)].max(1e-12);
            }
            let Some(chol) = a.cholesky() else {
                mu *= 10.0;
                continue;
            };
            let step = chol.solve(&(-&jtr));
            let mut xn = x.clone();
            for (col, &p) in free.iter().enumerate() {
                xn[p] += step[col];
            }
            tie(&mut xn);
            let rn = residuals(&xn);
            let cn = cost(&rn);
            if cn < c {
                let gain = (c - cn) / c.max(1e-300);
                x = xn;
                r = rn;
                c = cn;
                mu = (mu / 3.0).max(1e-12);
                improved = true;
                if gain < 1e-12 {
                    return Ok(finish(&x, &views, width, height, &r, &offsets, iterations));
                }
                break;
            }
            mu *= 4.0;
        }
        if !improved {
            break;
        }
    }
    Ok(finish(&x, &views, width, height, &r, &offsets, iterations))
}

fn finish(
    x: &[Real],
    views: &[View],
    width: u32,
    height: u32,
    r: &DVector<Real>,
    offsets: &[usize],
    iterations: usize,
) -> CameraCalibration {
    let points: usize = views.iter().map(|v| v.object.len()).sum();
    let rms = (r.norm_squared() / points as Real).sqrt();
    let view_rms: Vec<Real> = views
        .iter()
        .zip(offsets)
        .map(|(v, &o)| {
            let n = v.object.len();
            (r.rows(o, 2 * n).norm_squared() / n as Real).sqrt()
        })
        .collect();
    let mut sorted = view_rms.clone();
    sorted.sort_by(|a, b| a.total_cmp(b));
    let median = sorted[sorted.len() / 2];
    let outlier_views = (0..views.len()).filter(|&v| view_rms[v] > 3.0 * median && view_rms[v] > 0.5).collect();
    CameraCalibration {
        camera: camera_of(x, width, height),
        poses: (0..views.len()).map(|v| pose_of(x, v)).collect(),
        rms,
        view_rms,
        outlier_views,
        iterations,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Synthetic views of a 9 × 6 board under a known camera, with or without pixel noise.
    fn synthetic(cam: &PinholeCamera, noise: Real) -> Vec<View> {
        let object: Vec<Point3> =
            (0..6).flat_map(|j| (0..9).map(move |i| Point3::new(i as Real * 20.0, j as Real * 20.0, 0.0))).collect();
        let mut state = 12345u64;
        let mut rand = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as Real / (1u64 << 53) as Real - 0.5
        };
        (0..12)
            .map(|v| {
                let a = v as Real * 0.5;
                let rot = Rotation3::from_euler_angles(0.35 * a.sin(), 0.4 * a.cos(), 0.2 * a);
                let pose = Isometry3::from_parts(
                    Translation3::new(-80.0 + 10.0 * a.cos(), -50.0, 450.0 + 30.0 * a.sin()),
                    rot.into(),
                );
                let image = object
                    .iter()
                    .map(|o| {
                        let p = cam.project(&(pose * o)).unwrap();
                        Point2::new(p.x + noise * rand(), p.y + noise * rand())
                    })
                    .collect();
                View { object: object.clone(), image }
            })
            .collect()
    }

    fn camera() -> PinholeCamera {
        PinholeCamera {
            width: 1280,
            height: 1024,
            fx: 1400.0,
            fy: 1395.0,
            cx: 652.0,
            cy: 498.0,
            distortion: Distortion::from_opencv([-0.12, 0.08, 0.001, -0.0015, 0.0]),
        }
    }

    #[test]
    fn exact_views_give_the_camera_back() {
        let cam = camera();
        let c = calibrate_camera(&synthetic(&cam, 0.0), 1280, 1024, CameraOptions::default()).unwrap();
        assert!(c.rms < 1e-4, "rms {}", c.rms);
        assert!((c.camera.fx - cam.fx).abs() < 1e-3 && (c.camera.fy - cam.fy).abs() < 1e-3);
        assert!((c.camera.cx - cam.cx).abs() < 1e-3 && (c.camera.cy - cam.cy).abs() < 1e-3);
        assert!((c.camera.distortion.k1 - cam.distortion.k1).abs() < 1e-5);
    }

    #[test]
    fn noisy_views_land_within_tolerance_and_options_hold() {
        let cam = camera();
        let views = synthetic(&cam, 0.3);
        let c = calibrate_camera(&views, 1280, 1024, CameraOptions::default()).unwrap();
        assert!(c.rms < 0.2, "rms {}", c.rms);
        assert!((c.camera.fx / cam.fx - 1.0).abs() < 2e-3, "fx {}", c.camera.fx);
        let fixed =
            CameraOptions { fix_principal_point: true, zero_tangential: true, fix_k3: true, ..Default::default() };
        let c = calibrate_camera(&views, 1280, 1024, fixed).unwrap();
        assert_eq!((c.camera.cx, c.camera.cy), (639.5, 511.5));
        assert_eq!((c.camera.distortion.p1, c.camera.distortion.p2, c.camera.distortion.k3), (0.0, 0.0, 0.0));
    }

    #[test]
    fn too_few_or_parallel_views_are_refused() {
        let cam = camera();
        let views = synthetic(&cam, 0.0);
        assert!(matches!(
            calibrate_camera(&views[..2], 1280, 1024, CameraOptions::default()),
            Err(CalibError::TooFewViews(_))
        ));
        // The same board pose three times over: parallel boards.
        let same = vec![views[0].clone(), views[0].clone(), views[0].clone()];
        let e = calibrate_camera(&same, 1280, 1024, CameraOptions::default()).unwrap_err();
        assert!(e.to_string().contains("parallel") || e.to_string().contains("degenerate"), "{e}");
    }
}
