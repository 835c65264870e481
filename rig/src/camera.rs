//! The pinhole camera with OpenCV's five-term Brown–Conrady distortion.
//!
//! # Conventions
//! Camera frame: x right, y down, z forward (OpenCV). Pixel (0, 0) is the centre of the top-left pixel, so
//! the image covers u ∈ [−0.5, width − 0.5]. A point X = (X, Y, Z) has normalised coordinates
//! (x, y) = (X/Z, Y/Z); distortion maps them to (x_d, y_d) exactly as OpenCV's `projectPoints` does, and
//! u = fx·x_d + cx, v = fy·y_d + cy.

use crate::math::{Point2, Point3, Real, UnitVector3, Vector3};

/// The largest image side a camera or projector may have, pixels.
pub const MAX_SIDE_PX: u32 = 32_768;
/// Lens distortion coefficients in OpenCV order (k1, k2, p1, p2, k3): radial k1, k2, k3, tangential p1, p2.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Distortion {
    /// Radial r² coefficient.
    pub k1: Real,
    /// Radial r⁴ coefficient.
    pub k2: Real,
    /// First tangential coefficient.
    pub p1: Real,
    /// Second tangential coefficient.
    pub p2: Real,
    /// Radial r⁶ coefficient.
    pub k3: Real,
}

impl Distortion {
    /// No distortion.
    pub const NONE: Distortion = Distortion { k1: 0.0, k2: 0.0, p1: 0.0, p2: 0.0, k3: 0.0 };

    /// From OpenCV's order `[k1, k2, p1, p2, k3]`.
    pub fn from_opencv(c: [Real; 5]) -> Self {
        Distortion { k1: c[0], k2: c[1], p1: c[2], p2: c[3], k3: c[4] }
    }

    /// In OpenCV's order `[k1, k2, p1, p2, k3]`.
    pub fn to_opencv(&self) -> [Real; 5] {
        [self.k1, self.k2, self.p1, self.p2, self.k3]
    }

    /// True when every coefficient is zero.
    pub fn is_none(&self) -> bool {
        self.to_opencv().iter().all(|&c| c == 0.0)
    }

    /// Checks the coefficients are finite and within [`crate::limits`]' bounds: |k1|, |k2|, |k3| ≤
    /// [`MAX_RADIAL_DISTORTION`](crate::limits::MAX_RADIAL_DISTORTION), |p1|, |p2| ≤
    /// [`MAX_TANGENTIAL_DISTORTION`](crate::limits::MAX_TANGENTIAL_DISTORTION). The message names the term.
    pub fn validate(&self) -> Result<(), String> {
        use crate::limits::{MAX_RADIAL_DISTORTION, MAX_TANGENTIAL_DISTORTION};
        let terms = [
            ("k1", self.k1, MAX_RADIAL_DISTORTION),
            ("k2", self.k2, MAX_RADIAL_DISTORTION),
            ("p1", self.p1, MAX_TANGENTIAL_DISTORTION),
            ("p2", self.p2, MAX_TANGENTIAL_DISTORTION),
            ("k3", self.k3, MAX_RADIAL_DISTORTION),
        ];
        for (name, v, max) in terms {
            if !v.is_finite() {
                return Err(format!("distortion {name} = {v} must be finite"));
            }
            if v.abs() > max {
                return Err(format!("distortion {name} = {v:e} is beyond any real lens (|{name}| ≤ {max:e})"));
            }
        }
        Ok(())
    }

    /// Distorts normalised coordinates: (x, y) ↦ (x_d, y_d).
    pub fn apply(&self, p: Point2) -> Point2 {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        Point2::new(
            x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x),
            y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y,
        )
    }

    /// The Jacobian of [`Distortion::apply`] at `p`, row-major `[[∂xd/∂x, ∂xd/∂y], [∂yd/∂x, ∂yd/∂y]]`.
    fn jacobian(&self, p: Point2) -> [[Real; 2]; 2] {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        let d_radial = self.k1 + r2 * (2.0 * self.k2 + 3.0 * r2 * self.k3);
        let cross = 2.0 * x * y * d_radial + 2.0 * self.p1 * x + 2.0 * self.p2 * y;
        [
            [radial + 2.0 * x * x * d_radial + 2.0 * self.p1 * y + 6.0 * self.p2 * x, cross],
            [cross, radial + 2.0 * y * y * d_radial + 6.0 * self.p1 * y + 2.0 * self.p2 * x],
        ]
    }

    /// Inverts [`Distortion::apply`] by damped Newton iteration: (x_d, y_d) ↦ (x, y).
    ///
    /// Newton reaches machine precision in a handful of steps where OpenCV's fixed-point iteration needs
    /// about twenty for strong lenses. Returns `None` where the lens model folds over (no unique inverse
    /// near the start point) or the iteration does not converge.
    pub fn remove(&self, pd: Point2) -> Option<Point2> {
        if self.is_none() {
            return Some(pd);
        }
        let residual = |p: Point2| self.apply(p) - pd;
        let mut p = pd;
        let mut r = residual(p);
        for _ in 0..60 {
            let j = self.jacobian(p);
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            if !det.is_finite() || det.abs() < 1e-12 {
                return None;
            }
            let step = Point2::new((j[1][1] * r.x - j[0][1] * r.y) / det, (-j[1][0] * r.x + j[0][0] * r.y) / det);
            // Halve the step while it makes things worse, so a far start point cannot jump to another fold.
            let mut scale = 1.0;
            let mut next = p - step.coords;
            let mut next_r = residual(next);
            while next_r.norm() > r.norm() && scale > 1e-4 {
                scale *= 0.5;
                next = p - step.coords * scale;
                next_r = residual(next);
            }
            p = next;
            r = next_r;
            if step.coords.norm() * scale <= 1e-15 * (1.0 + p.coords.norm()) {
                break;
            }
        }
        (r.norm() <= 1e-12 * (1.0 + pd.coords.norm())).then_some(p)
    }
}

/// A calibrated pinhole camera: image size, intrinsics (px) and distortion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PinholeCamera {
    /// Image width (px).
    pub width: u32,
    /// Image height (px).
    pub height: u32,
    /// Focal length along x (px).
    pub fx: Real,
    /// Focal length along y (px).
    pub fy: Real,
    /// Principal point x (px).
    pub cx: Real,
    /// Principal point y (px).
    pub cy: Real,
    /// Lens distortion.
    pub distortion: Distortion,
}

impl PinholeCamera {
    /// A distortion-free camera with square pixels and the principal point at the image centre.
    ///
    /// ```
    /// use rig::{PinholeCamera, Point3};
    /// let cam = PinholeCamera::ideal(640, 480, 500.0);
    /// // A point on the optical axis lands on the image centre.
    /// let px = cam.project(&Point3::new(0.0, 0.0, 300.0)).unwrap();
    /// assert_eq!((px.x, px.y), (319.5, 239.5));
    /// ```
    pub fn ideal(width: u32, height: u32, focal_px: Real) -> Self {
        PinholeCamera {
            width,
            height,
            fx: focal_px,
            fy: focal_px,
            cx: (width as Real - 1.0) / 2.0,
            cy: (height as Real - 1.0) / 2.0,
            distortion: Distortion::NONE,
        }
    }

    /// Projects a point in the camera frame (mm) to a pixel. `None` for points at or behind the camera.
    pub fn project(&self, p: &Point3) -> Option<Point2> {
        if p.z <= 0.0 || !p.z.is_finite() {
            return None;
        }
        Some(self.normalized_to_pixel(Point2::new(p.x / p.z, p.y / p.z)))
    }

    /// Normalised (undistorted) coordinates to a pixel, applying distortion.
    pub fn normalized_to_pixel(&self, n: Point2) -> Point2 {
        let d = self.distortion.apply(n);
        Point2::new(self.fx * d.x + self.cx, self.fy * d.y + self.cy)
    }

    /// A pixel to normalised (undistorted) coordinates, removing distortion.
    pub fn pixel_to_normalized(&self, px: Point2) -> Option<Point2> {
        let d = Point2::new((px.x - self.cx) / self.fx, (px.y - self.cy) / self.fy);
        self.distortion.remove(d)
    }

    /// The unit direction, in the camera frame, of the ray through a pixel.
    ///
    /// ```
    /// use rig::{PinholeCamera, Point2};
    /// let cam = PinholeCamera::ideal(640, 480, 500.0);
    /// let d = cam.unproject(Point2::new(319.5, 239.5)).unwrap();
    /// assert!((d.z - 1.0).abs() < 1e-15);
    /// ```
    pub fn unproject(&self, px: Point2) -> Option<UnitVector3> {
        let n = self.pixel_to_normalized(px)?;
        Some(UnitVector3::new_normalize(Vector3::new(n.x, n.y, 1.0)))
    }

    /// True when a pixel position lies on the image.
    pub fn contains(&self, px: Point2) -> bool {
        px.x >= -0.5 && px.y >= -0.5 && px.x < self.width as Real - 0.5 && px.y < self.height as Real - 0.5
    }

    /// Checks the parameters make a camera or a projector lens: positive size and focal lengths, finite
    /// values, distortion within real lenses' range and the principal point within an image size of the
    /// image (a projector's lens may be shifted) — the bounds of [`crate::limits`]. A camera's principal
    /// point must lie inside its image: [`PinholeCamera::validate_camera`].
    pub fn validate(&self) -> Result<(), String> {
        if self.width == 0 || self.height == 0 {
            return Err(format!("image size {}×{} must be positive", self.width, self.height));
        }
        // Far beyond any camera or projector, and the bound that keeps per-pixel tables allocatable.
        if self.width > MAX_SIDE_PX || self.height > MAX_SIDE_PX {
            return Err(format!(
                "image size {}×{} is larger than any camera or projector (at most {MAX_SIDE_PX} pixels a side)",
                self.width, self.height
            ));
        }
        if !(self.fx > 0.0 && self.fy > 0.0 && self.fx.is_finite() && self.fy.is_finite()) {
            return Err(format!("focal lengths ({}, {}) must be positive and finite", self.fx, self.fy));
        }
        if !(self.cx.is_finite() && self.cy.is_finite()) {
            return Err(format!("principal point ({}, {}) must be finite", self.cx, self.cy));
        }
        self.distortion.validate()?;
        // A projector's lens is often shifted: its principal point may lie beyond its image, within a margin.
        let m = crate::limits::PROJECTOR_PRINCIPAL_POINT_MARGIN;
        let (w, h) = (self.width as Real, self.height as Real);
        if !(-m * w - 0.5..=w * (1.0 + m) - 0.5).contains(&self.cx)
            || !(-m * h - 0.5..=h * (1.0 + m) - 0.5).contains(&self.cy)
        {
            return Err(format!(
                "principal point ({}, {}) lies more than {m} image size(s) outside the {}×{} image",
                self.cx, self.cy, self.width, self.height
            ));
        }
        // (Not checked: that the lens model is invertible out to the image's corners. Real five-term fits
        // often fold over there: the FabScanPi sample's k3 = −1.15 does beyond r² ≈ 0.5.)
        Ok(())
    }

    /// [`PinholeCamera::validate`], and the principal point inside the image (a camera's lens is centred
    /// on its sensor; a projector's may be shifted, see [`crate::limits`]).
    pub fn validate_camera(&self) -> Result<(), String> {
        self.validate()?;
        let inside = |c: Real, n: u32| (-0.5..=n as Real - 0.5).contains(&c);
        if !inside(self.cx, self.width) || !inside(self.cy, self.height) {
            return Err(format!(
                "principal point ({}, {}) lies outside the {}×{} image",
                self.cx, self.cy, self.width, self.height
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn newton_inverts_tangential_and_radial_terms() {
        let d = Distortion { k1: 0.1, k2: -0.05, p1: 0.01, p2: -0.02, k3: 0.01 };
        let p = Point2::new(0.3, -0.2);
        let back = d.remove(d.apply(p)).unwrap();
        assert!((back - p).norm() < 1e-14);
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let d = Distortion { k1: -0.27, k2: -0.04, p1: 0.0018, p2: -0.0003, k3: 0.24 };
        let p = Point2::new(0.41, -0.33);
        let j = d.jacobian(p);
        let h = 1e-7;
        for (col, e) in [Vector2::new(h, 0.0), Vector2::new(0.0, h)].iter().enumerate() {
            let fd = (d.apply(p + e) - d.apply(p - e)) / (2.0 * h);
            assert!((fd.x - j[0][col]).abs() < 1e-7 && (fd.y - j[1][col]).abs() < 1e-7);
        }
    }

    use crate::math::Vector2;
}
