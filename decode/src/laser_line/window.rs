//! Where in the image a laser line can be: per row, the columns whose camera ray meets the laser's
//! plane inside the working volume (the cylinder over the platter). Horus masks its frames to the
//! platform's cylinder and FabScanPi searches only one half of the image for the same reason: the
//! laser also lights the scanner's walls, the table and whatever stands behind, and in rows where that
//! light is the brightest a detector without a region takes it for the object.
//!
//! The plane meets the cylinder in a convex region and a camera row is a line in that plane, so each
//! row's columns form one interval.

use rayon::prelude::*;
use rig::math::{Point2, Point3, Real};
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
    let (w, h) = (camera.width as usize, camera.height as usize);
    let inside = |c: usize, r: usize| {
        camera
            .unproject(Point2::new(c as Real, r as Real))
            .and_then(|d| plane.intersect_ray(&Point3::origin(), &d))
            .is_some_and(|p| volume.contains(&p, margin_mm))
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
    }
}
