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

    /// The plane `n·X = d` as a file wrote it: a normal within 1e-9 of unit length is kept bit for bit
    /// (normalising it would change its last digits, and a written rig or calibration would not read
    /// back the same); any other is normalised as [`LaserPlane::new`] does.
    pub fn as_written(n: Vector3, d: Real) -> Option<Self> {
        if (n.norm() - 1.0).abs() < 1e-9 && d.is_finite() {
            Some(LaserPlane { normal: UnitVector3::new_unchecked(n), distance: d })
        } else {
            LaserPlane::new(n, d)
        }
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

/// The colour a line laser shines in, which picks the laser's signal out of a colour frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LaserColour {
    /// A red laser (Ciclop, FabScanPi).
    #[default]
    Red,
    /// A green laser.
    Green,
    /// A blue laser.
    Blue,
    /// Any other (an infrared laser seen by a grey sensor): the pixel's luma.
    White,
}

impl LaserColour {
    /// How strongly one RGB pixel shows this laser: the pixel's luma, weighted by how much of the
    /// laser's colour it holds (full weight from half the brightest channel's level up: a line's core;
    /// none for white or grey light).
    ///
    /// The weight rejects white light (ambient, the work light, a white wall's glow, a highlight) that
    /// raises all three channels alike, where the red channel alone would take it for laser (Horus and
    /// FabScanPi use red alone). The level is luma's rather than the colour difference's because a
    /// camera's JPEG keeps colour at half resolution (4:2:0): red minus the larger of green and blue
    /// moved line centres by blocks of two pixels (0.33 mm RMS on the FabScanPi sweep, against 0.29
    /// with luma).
    #[inline]
    pub fn signal(self, rgb: [u8; 3]) -> f32 {
        let [r, g, b] = rgb.map(f32::from);
        let luma = 0.299 * r + 0.587 * g + 0.114 * b;
        let (own, others) = match self {
            LaserColour::Red => (r, g.max(b)),
            LaserColour::Green => (g, r.max(b)),
            LaserColour::Blue => (b, r.max(g)),
            LaserColour::White => return luma,
        };
        // A line's core clips its own channel first and then the others (a bright laser turns
        // white-pink at its centre): a clipped own channel is laser, whatever the others say.
        if own >= 250.0 {
            return luma;
        }
        let purity = if own > 0.0 { (own - others) / own } else { 0.0 };
        luma * (4.0 * purity).clamp(0.0, 1.0)
    }

    /// The colour's name as the rig file writes it.
    pub fn name(self) -> &'static str {
        match self {
            LaserColour::Red => "red",
            LaserColour::Green => "green",
            LaserColour::Blue => "blue",
            LaserColour::White => "white",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_red_laser_stands_out_of_white_light_but_not_of_red_paint_under_white_light() {
        let red = LaserColour::Red;
        // A laser's core: full luma.
        assert!((red.signal([200, 40, 30]) - (0.299 * 200.0 + 0.587 * 40.0 + 0.114 * 30.0)).abs() < 1e-3);
        // White ambient light raises every channel: no signal.
        assert_eq!(red.signal([120, 120, 118]), 0.0);
        // Pinkish light (the laser's glow on a white wall under white light): part of it.
        let pink = red.signal([200, 160, 160]);
        assert!(pink > 0.0 && pink < 0.99 * 164.9, "{pink}");
        assert!(LaserColour::Green.signal([10, 90, 30]) > 50.0);
        assert!((LaserColour::White.signal([100, 100, 100]) - 100.0).abs() < 1e-3);
    }
}
