//! A line laser's light plane.
//!
//! # Conventions
//! The plane is `n·X = d` in the camera frame with `|n| = 1` and `d` in mm.

use crate::math::{Point3, Real, UnitVector3, Vector3};

/// A laser light plane in the camera frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaserPlane {
    /// Unit normal.
    pub normal: UnitVector3,
    /// Signed distance of the plane from the camera centre along `normal` (mm).
    pub distance: Real,
}

impl LaserPlane {
    /// The plane `n·X = d`; `n` need not be unit length (both sides are scaled by 1/|n|).
    /// `None` when `n` is zero or not finite.
    pub fn new(n: Vector3, d: Real) -> Option<Self> {
        let len = n.norm();
        (len > 0.0 && len.is_finite() && d.is_finite())
            .then(|| LaserPlane { normal: UnitVector3::new_unchecked(n / len), distance: d / len })
    }

    /// The plane through `point` with normal `n`.
    pub fn from_point_normal(point: &Point3, n: Vector3) -> Option<Self> {
        LaserPlane::new(n, n.dot(&point.coords))
    }

    /// Signed distance of a point from the plane (mm), positive on the side `normal` points to.
    pub fn signed_distance(&self, p: &Point3) -> Real {
        self.normal.dot(&p.coords) - self.distance
    }

    /// Where the ray `origin + s·dir` (s ≥ 0) meets the plane; `None` if parallel or behind the origin.
    ///
    /// ```
    /// use rig::{LaserPlane, Point3, Vector3};
    /// let plane = LaserPlane::new(Vector3::z(), 500.0).unwrap(); // z = 500 mm
    /// let hit = plane.intersect_ray(&Point3::origin(), &Vector3::new(0.1, -0.2, 1.0)).unwrap();
    /// assert!((hit.z - 500.0).abs() < 1e-12 && (hit.x - 50.0).abs() < 1e-12);
    /// ```
    pub fn intersect_ray(&self, origin: &Point3, dir: &Vector3) -> Option<Point3> {
        let denom = self.normal.dot(dir);
        if denom.abs() < 1e-12 * dir.norm() {
            return None;
        }
        let s = -self.signed_distance(origin) / denom;
        (s >= 0.0 && s.is_finite()).then(|| origin + dir * s)
    }
}
