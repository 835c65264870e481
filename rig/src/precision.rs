//! Whether single precision holds a set of coordinates, and the units formats with a unit of their own
//! are written in.
//!
//! A `float` keeps 24 bits: a coordinate x rounds by up to |x|·2⁻²⁴. Near the origin that is far below
//! any scanner's noise, but an object far from the origin (a survey's coordinates, an export that
//! kept its scanner's offset) loses its shape: a 60 mm sphere 10⁹ mm out, written as `float`, came back
//! as two points. PLY then takes `double`; formats that hold only `float` (STL, glTF) are refused.
//!
//! E57 and glTF are in metres and STL is read as millimetres by every slicer; scanrig's data are in
//! millimetres unless the input said otherwise (a PLY `comment units m`, Stanford's Cyberware scans):
//! those formats are written from the data's own unit, so a cloud in metres does not come out 1000
//! times too small.

use crate::math::{Point3, Real};

/// The largest rounding single precision may cost, as a share of the bounding box's diagonal: 10⁻⁵
/// (1 µm on a 100 mm object), reached only where the object lies over 160 of its sizes from the
/// origin.
pub const MAX_ROUNDING: Real = 1e-5;

/// What writing `points` in single precision would do to them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rounding {
    /// The largest change of a coordinate.
    pub worst: Real,
    /// The diagonal of the finite points' bounding box.
    pub diagonal: Real,
    /// The largest coordinate's magnitude.
    pub farthest: Real,
}

impl Rounding {
    /// Measures `points` (non-finite coordinates are left out: the writers refuse or keep them).
    pub fn of<'a>(points: impl IntoIterator<Item = &'a Point3>) -> Rounding {
        let (mut lo, mut hi) = ([Real::INFINITY; 3], [Real::NEG_INFINITY; 3]);
        let (mut worst, mut farthest): (Real, Real) = (0.0, 0.0);
        for p in points {
            for (d, &c) in p.coords.iter().enumerate().filter(|(_, c)| c.is_finite()) {
                worst = worst.max((c - c as f32 as Real).abs());
                farthest = farthest.max(c.abs());
                lo[d] = lo[d].min(c);
                hi[d] = hi[d].max(c);
            }
        }
        let diagonal = (0..3).map(|d| (hi[d] - lo[d]).max(0.0).powi(2)).sum::<Real>().sqrt();
        Rounding { worst, diagonal: if diagonal.is_finite() { diagonal } else { 0.0 }, farthest }
    }

    /// Whether single precision keeps the shape (within [`MAX_ROUNDING`] of its size). Points all at
    /// one place have no shape to lose: they hold unless a coordinate is past single precision's
    /// range.
    pub fn holds(&self) -> bool {
        if self.diagonal > 0.0 { self.worst <= MAX_ROUNDING * self.diagonal } else { self.worst.is_finite() }
    }

    /// Why a single-precision format cannot take the points.
    pub fn why_not(&self, format: &str) -> String {
        format!(
            "{format} holds single precision only, and the data lie up to {:.4e} from the origin, where a \
             coordinate rounds by up to {:.3e} ({:.1e} of their size, {:.4e}): write .ply or .e57, which keep \
             double precision, or move the object near the origin",
            self.farthest,
            self.worst,
            self.worst / self.diagonal.max(Real::MIN_POSITIVE),
            self.diagonal
        )
    }
}

/// Millimetres in one `unit` (a PLY `comment units …`), for the units scanrig knows.
pub fn millimetres_per(unit: &str) -> Option<Real> {
    match unit.to_ascii_lowercase().as_str() {
        "mm" | "millimetre" | "millimetres" | "millimeter" | "millimeters" => Some(1.0),
        "cm" | "centimetre" | "centimetres" | "centimeter" | "centimeters" => Some(10.0),
        "m" | "metre" | "metres" | "meter" | "meters" => Some(1000.0),
        "um" | "µm" | "micron" | "microns" | "micrometre" | "micrometres" => Some(1e-3),
        "in" | "inch" | "inches" => Some(25.4),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sphere near the origin keeps single precision; the same far out, or in survey coordinates
    /// (metres, 5·10⁶ out), does not; a cloud of one point does, unless it lies past float's range.
    #[test]
    fn single_precision_holds_an_object_near_the_origin_only() {
        let sphere: Vec<Point3> = (0..200)
            .map(|i| {
                let (t, f) = (i as Real * 0.31, i as Real * 0.17);
                Point3::new(30.0 * t.cos() * f.sin(), 30.0 * t.sin() * f.sin(), 40.0 + 30.0 * f.cos())
            })
            .collect();
        assert!(Rounding::of(&sphere).holds());
        let far: Vec<Point3> = sphere.iter().map(|p| p + crate::math::Vector3::new(1e9, 1e9, 1e9)).collect();
        let r = Rounding::of(&far);
        assert!(!r.holds() && r.worst > 1.0, "{r:?}");
        assert!(r.why_not("STL").contains("STL holds single precision only"), "{}", r.why_not("STL"));
        let survey: Vec<Point3> =
            sphere.iter().map(|p| Point3::new(5e5 + p.x / 1e3, 5e6 + p.y / 1e3, 100.0 + p.z / 1e3)).collect();
        assert!(!Rounding::of(&survey).holds());
        assert!(Rounding::of(&[Point3::new(0.5, 2.0, -4.0)]).holds());
        // One place: nothing to lose, unless past float's range.
        assert!(Rounding::of(&[Point3::new(0.1, 0.0, 0.0)]).holds());
        assert!(!Rounding::of(&[Point3::new(1e300, 0.0, 0.0)]).holds());
        assert_eq!(
            (millimetres_per("m"), millimetres_per("MM"), millimetres_per("furlong")),
            (Some(1000.0), Some(1.0), None)
        );
    }
}
