//! The turntable axis and the pose of each view.
//!
//! # Conventions
//! The axis is a point on the platter centre and a unit direction pointing up out of the platter, both in
//! the camera frame. The object frame has its origin at that point and z along the axis; its y axis is
//! the horizontal direction from the camera toward the axis, and x = y × z, so at θ = 0 the object's x
//! runs to the camera's right. Positive θ turns the platter counter-clockwise seen from above. A view
//! captured at angle θ maps camera points into the object frame by undoing that rotation.

use crate::math::{Isometry3, Matrix3, Point3, Real, Rotation3, UnitVector3, Vector3};

/// The turntable's rotation axis in the camera frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TurntableAxis {
    /// The platter centre (mm, camera frame).
    pub point: Point3,
    /// The unit axis direction, pointing up out of the platter.
    pub direction: UnitVector3,
}

impl TurntableAxis {
    /// The object frame at θ = 0: maps camera coordinates to object coordinates.
    pub fn object_from_camera_at_zero(&self) -> Isometry3 {
        let [x, y, z] = self.axes_at_zero();
        // Rows are the object axes expressed in the camera frame: X_obj = B·(X_cam − point).
        let b = Matrix3::from_rows(&[x.transpose(), y.transpose(), z.transpose()]);
        let rot = Rotation3::from_matrix_unchecked(b);
        Isometry3::from_parts((rot * -self.point.coords).into(), rot.into())
    }

    /// The object frame's x, y and z axes at θ = 0 in the camera frame (z is `direction`, bit for bit).
    pub fn axes_at_zero(&self) -> [Vector3; 3] {
        let z = self.direction.into_inner();
        let toward = self.point.coords - z * z.dot(&self.point.coords);
        // A camera on the axis has no "toward": any horizontal direction will do.
        let y = if toward.norm() > 1e-9 * (1.0 + self.point.coords.norm()) {
            toward.normalize()
        } else {
            let helper = if z.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
            (helper - z * z.dot(&helper)).normalize()
        };
        let x = y.cross(&z);
        [x, y, z]
    }

    /// Maps camera points of the view captured at `theta_deg` into the object frame.
    ///
    /// ```
    /// use rig::{TurntableAxis, Point3, UnitVector3, Vector3};
    /// // Platter 400 mm in front of the camera, axis pointing up (−y in the camera frame).
    /// let axis = TurntableAxis {
    ///     point: Point3::new(0.0, 0.0, 400.0),
    ///     direction: UnitVector3::new_normalize(Vector3::new(0.0, -1.0, 0.0)),
    /// };
    /// // The platter centre is the object origin at every angle.
    /// let o = axis.object_from_camera(37.0) * Point3::new(0.0, 0.0, 400.0);
    /// assert!(o.coords.norm() < 1e-12);
    /// ```
    pub fn object_from_camera(&self, theta_deg: Real) -> Isometry3 {
        let undo = Rotation3::from_axis_angle(&Vector3::z_axis(), -theta_deg.to_radians());
        Isometry3::from_parts(nalgebra::Translation3::identity(), undo.into()) * self.object_from_camera_at_zero()
    }

    /// Maps object points into the camera frame of the view at `theta_deg`.
    pub fn camera_from_object(&self, theta_deg: Real) -> Isometry3 {
        self.object_from_camera(theta_deg).inverse()
    }
}

/// The working volume of a turntable scanner: the upright cylinder over the platter that an object
/// on it can fill (Horus' and FabScanPi's region of interest). Light seen outside it — the laser on
/// the scanner's back wall, the table, a reflection — cannot be the object.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorkingVolume {
    /// The turntable's axis; the platter top is at its point.
    pub axis: TurntableAxis,
    /// The cylinder's radius (mm): the platter's.
    pub radius_mm: Real,
    /// Its height above the platter (mm); infinite where unknown.
    pub height_mm: Real,
}

impl WorkingVolume {
    /// How far below the platter top a point still counts as inside (mm): the platter's own surface,
    /// where the line crosses it, and the calibration's error in the axis point.
    pub const BELOW_MM: Real = 3.0;

    /// Whether a camera-frame point lies in the volume (radius and height grown by `margin_mm`).
    pub fn contains(&self, p: &Point3, margin_mm: Real) -> bool {
        let rel = p - self.axis.point;
        let h = rel.dot(&self.axis.direction);
        let radial = (rel - self.axis.direction.into_inner() * h).norm();
        radial <= self.radius_mm + margin_mm && h >= -Self::BELOW_MM - margin_mm && h <= self.height_mm + margin_mm
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tilted_axis() -> TurntableAxis {
        TurntableAxis {
            point: Point3::new(12.0, 40.0, 380.0),
            direction: UnitVector3::new_normalize(Vector3::new(0.05, -1.0, -0.3)),
        }
    }

    #[test]
    fn the_working_volume_is_the_cylinder_over_the_platter() {
        let axis = TurntableAxis {
            point: Point3::new(0.0, 50.0, 300.0),
            direction: UnitVector3::new_normalize(Vector3::new(0.0, -1.0, 0.0)),
        };
        let v = WorkingVolume { axis, radius_mm: 100.0, height_mm: 150.0 };
        assert!(v.contains(&Point3::new(0.0, 0.0, 300.0), 0.0));
        assert!(v.contains(&Point3::new(99.0, 49.0, 300.0), 0.0));
        // Beside, above and below the cylinder.
        assert!(!v.contains(&Point3::new(0.0, 0.0, 420.0), 0.0));
        assert!(v.contains(&Point3::new(0.0, 0.0, 420.0), 25.0));
        assert!(!v.contains(&Point3::new(0.0, -110.0, 300.0), 0.0));
        assert!(!v.contains(&Point3::new(0.0, 60.0, 300.0), 0.0));
    }

    #[test]
    fn rotating_the_platter_is_undone_by_the_view_pose() {
        let axis = tilted_axis();
        // A point fixed on the object, seen at θ = 0, then after the platter turned by 30°.
        let p_obj = Point3::new(20.0, -15.0, 33.0);
        let at_zero = axis.camera_from_object(0.0) * p_obj;
        let turned = Rotation3::from_axis_angle(&axis.direction, 30f64.to_radians());
        let at_30 = axis.point + turned * (at_zero - axis.point);
        let back = axis.object_from_camera(30.0) * at_30;
        assert!((back - p_obj).norm() < 1e-9);
    }

    #[test]
    fn object_x_runs_to_the_camera_right_at_zero() {
        let axis = TurntableAxis {
            point: Point3::new(0.0, 0.0, 400.0),
            direction: UnitVector3::new_normalize(Vector3::new(0.0, -1.0, 0.0)),
        };
        let iso = axis.object_from_camera_at_zero();
        let x_cam = iso.rotation.inverse() * Vector3::x();
        assert!((x_cam - Vector3::x()).norm() < 1e-12);
        let y_cam = iso.rotation.inverse() * Vector3::y();
        assert!((y_cam - Vector3::z()).norm() < 1e-12, "object y points away from the camera");
    }
}
