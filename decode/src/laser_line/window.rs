//! Where in the image a laser line can be: per row, the columns whose camera ray meets the laser's
//! plane inside the working volume (the cylinder over the platter). Horus masks its frames to the
//! platform's cylinder and FabScanPi searches only one half of the image for the same reason: the
//! laser also lights the scanner's walls, the table and whatever stands behind, and in rows where that
//! light is the brightest a detector without a region takes it for the object.
//!
//! The plane meets the cylinder in a convex region and a camera row is a line in that plane, so each
//! row's columns form one interval.
//!
//! [`lit_side_windows`] narrows that to the half of the plane's chord across the platter that is on
//! the camera's side of the axis. Why, from the geometry alone: the camera sees a lit point only where
//! the surface faces both the camera and the laser, so the laser shines from the camera's side; an
//! object standing over the platter's centre then stops the sheet before the axis, and the half
//! beyond it — hidden behind the object from the camera, or empty above it — can hold no line of the
//! object. Light seen there (a second laser's line, a reflection off the housing, FabScanPi's stray
//! line in the upper left of every frame) would triangulate on this plane inside the volume, as a
//! ring the mesh closes into a lid. FabScanPi searches one half of its image for the same reason; the
//! half here is the rig's own, per row, and a little past the axis (a hollow, an object off centre).

use rayon::prelude::*;
use rig::math::{Point2, Point3, Real, Vector3};
use rig::{LaserPlane, PinholeCamera, WorkingVolume};

/// Per image row, the inclusive column interval where the line may lie (`None`: nowhere).
#[derive(Debug, Clone, PartialEq)]
pub struct RowWindows {
    /// One entry per row.
    pub rows: Vec<Option<(usize, usize)>>,
}

impl RowWindows {
    /// The window of row `r`.
    pub fn row(&self, r: usize) -> Option<(usize, usize)> {
        self.rows.get(r).copied().flatten()
    }

    /// Whether sub-pixel column `col` of row `r` lies inside (half a pixel of slack either side).
    pub fn contains(&self, r: usize, col: Real) -> bool {
        self.row(r).is_some_and(|(lo, hi)| col >= lo as Real - 0.5 && col <= hi as Real + 0.5)
    }

    /// Rows with a window.
    pub fn rows_open(&self) -> usize {
        self.rows.iter().filter(|r| r.is_some()).count()
    }
}

/// The windows of a laser's line in a camera's frames: every pixel whose ray meets `plane` within
/// `volume` grown by `margin_mm` (the calibration's error, and a line's own width on the volume's edge).
pub fn working_volume_windows(
    camera: &PinholeCamera,
    plane: &LaserPlane,
    volume: &WorkingVolume,
    margin_mm: Real,
) -> RowWindows {
    windows_where(camera, plane, |p| volume.contains(p, margin_mm))
}

/// In the laser plane, the horizontal direction from the turntable axis toward the camera (unit), or
/// `None` where neither half of the plane's chord is nearer the camera (a plane facing it squarely, a
/// level plane): then there is no side to prefer.
pub fn toward_camera(plane: &LaserPlane, volume: &WorkingVolume) -> Option<Vector3> {
    let up = volume.axis.direction.into_inner();
    let along = plane.normal.cross(&up);
    if along.norm() < 1e-6 {
        return None;
    }
    let along = along.normalize();
    let to_camera = -volume.axis.point.coords;
    let s = along.dot(&to_camera);
    // Under a tenth of the distance, the two ends of the chord are about as far from the camera.
    (s.abs() > 0.1 * to_camera.norm()).then(|| along * s.signum())
}

/// [`working_volume_windows`] on the camera's side of the axis only (see the module doc): points of
/// the plane more than `past_axis_mm` beyond the axis, away from the camera, are not searched. Where
/// the plane has no side nearer the camera ([`toward_camera`]) this is the whole volume's windows.
pub fn lit_side_windows(
    camera: &PinholeCamera,
    plane: &LaserPlane,
    volume: &WorkingVolume,
    margin_mm: Real,
    past_axis_mm: Real,
) -> RowWindows {
    let Some(toward) = toward_camera(plane, volume) else {
        return working_volume_windows(camera, plane, volume, margin_mm);
    };
    windows_where(camera, plane, |p| {
        volume.contains(p, margin_mm) && (p - volume.axis.point).dot(&toward) >= -past_axis_mm
    })
}

/// Per row, the columns whose ray meets `plane` at a point `keep` takes (one interval: `keep` is
/// convex in the plane).
fn windows_where(camera: &PinholeCamera, plane: &LaserPlane, keep: impl Fn(&Point3) -> bool + Sync) -> RowWindows {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let inside = |c: usize, r: usize| {
        camera
            .unproject(Point2::new(c as Real, r as Real))
            .and_then(|d| plane.intersect_ray(&Point3::origin(), &d))
            .is_some_and(|p| keep(&p))
    };
    let rows = (0..h)
        .into_par_iter()
        .map(|r| {
            let lo = (0..w).find(|&c| inside(c, r))?;
            let hi = (lo..w).rev().find(|&c| inside(c, r))?;
            Some((lo, hi))
        })
        .collect();
    RowWindows { rows }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::TurntableAxis;
    use rig::math::{UnitVector3, Vector3};

    #[test]
    fn a_plane_through_the_axis_gives_a_band_around_the_axis_image() {
        // A camera 300 mm from an upright axis (−y up), a vertical laser plane through the axis at 30°.
        let camera = PinholeCamera::ideal(320, 240, 400.0);
        let axis = TurntableAxis {
            point: Point3::new(0.0, 40.0, 300.0),
            direction: UnitVector3::new_normalize(Vector3::new(0.0, -1.0, 0.0)),
        };
        let n = Vector3::new(30f64.to_radians().cos(), 0.0, -30f64.to_radians().sin());
        let plane = LaserPlane::from_point_normal(&axis.point, n).unwrap();
        let volume = WorkingVolume { axis, radius_mm: 50.0, height_mm: 80.0 };
        let win = working_volume_windows(&camera, &plane, &volume, 0.0);
        // The axis projects to column 159.5; the plane's chord through the cylinder spans ±50 mm.
        let (lo, hi) = win.row(120).unwrap();
        assert!(lo < 160 && hi > 160 && hi - lo < 200, "{lo}..{hi}");
        // Rows below the platter (y > 40 mm at 300 mm: row > 173) and far above the top see nothing.
        assert!(win.row(235).is_none());
        assert!(win.row(0).is_none() || win.rows_open() < 240);
        // The camera's side: the plane turned 30° about the axis runs from near-left to far-right (x
        // grows with z), so its half nearer the camera images left of the axis.
        let near = lit_side_windows(&camera, &plane, &volume, 0.0, 0.0);
        let (nlo, nhi) = near.row(120).unwrap();
        assert!(nlo == lo && (157..=161).contains(&nhi), "{nlo}..{nhi} of {lo}..{hi}");
        let toward = toward_camera(&plane, &volume).unwrap();
        assert!(toward.z < 0.0 && toward.x < 0.0, "{toward:?}");
        // 10 mm past the axis along the plane is 5 mm across at about 309 mm: some 6 px more.
        let (_, wide) = lit_side_windows(&camera, &plane, &volume, 0.0, 10.0).row(120).unwrap();
        assert!(wide > nhi + 3 && wide < nhi + 12, "{wide} vs {nhi}");
        // A plane facing the camera squarely has no nearer side.
        let facing = LaserPlane::from_point_normal(&axis.point, Vector3::new(0.0, 0.0, 1.0)).unwrap();
        assert!(toward_camera(&facing, &volume).is_none());
    }
}
