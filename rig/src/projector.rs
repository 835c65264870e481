//! The projector: an inverse pinhole camera with its own lens, placed relative to the camera.
//!
//! # Conventions
//! `from_camera` maps camera coordinates to projector coordinates, `X_p = R·X_c + t` (OpenCV
//! `stereoCalibrate`'s R and T, in mm). Projector pixel (0, 0) is the centre of the top-left pixel of the
//! projected image, exactly as for cameras.

use crate::camera::PinholeCamera;
use crate::math::{Isometry3, Point2, Point3, Real, UnitVector3};

/// A calibrated projector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projector {
    /// The projector's lens as a pinhole model (size = projected image size, px).
    pub lens: PinholeCamera,
    /// Camera frame → projector frame.
    pub from_camera: Isometry3,
    /// Response exponent: emitted light ∝ drive^gamma (1 for a linear projector). Capture programs
    /// drive grey-level patterns with [`Projector::drive`] so the emitted light is what the pattern
    /// asks for — an uncorrected gamma is the most common cause of wavy phase-shift surfaces.
    pub gamma: Real,
}

impl Projector {
    /// The drive value (what the projector is sent) that emits relative `light` in [0, 1].
    pub fn drive(&self, light: Real) -> Real {
        light.clamp(0.0, 1.0).powf(1.0 / self.gamma)
    }

    /// The projector pixel that lights a point given in the camera frame (mm).
    pub fn project(&self, p_cam: &Point3) -> Option<Point2> {
        self.lens.project(&(self.from_camera * p_cam))
    }

    /// The projector's centre of projection in the camera frame (mm).
    pub fn center_in_camera(&self) -> Point3 {
        self.from_camera.inverse() * Point3::origin()
    }

    /// The ray a projector pixel emits, in the camera frame: (origin in mm, unit direction).
    pub fn ray_in_camera(&self, px: Point2) -> Option<(Point3, UnitVector3)> {
        let d = self.lens.unproject(px)?;
        let to_cam = self.from_camera.inverse();
        Some((to_cam * Point3::origin(), to_cam.rotation * d))
    }
}
