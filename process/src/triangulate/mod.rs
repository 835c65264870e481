//! Triangulation: a camera ray against the projector (its column plane, or its ray when rows are coded
//! too) or against a laser plane, giving points in the camera frame.
//!
//! The thesis's eq. 2.3 is the planar special case: in the plane of a laser beam, the camera and the
//! point, with baseline b between camera and laser, α the beam's angle to the baseline at the laser and β
//! the viewing ray's angle to the baseline at the camera, the camera–point distance is
//! `d = b·sin α / sin(α + β)` ([`depth_eq_2_3`]). The thesis prints `−b·sin α / sin(α + β)` because its
//! eq. 2.2 measures β from the baseline's extension (the exterior angle); with interior angles the sign
//! is +. The general ray–plane intersection here reduces to it (see the tests).

pub mod grid_normals;
pub mod laser_line;

use decode::projector_map::ProjectorMap;
use rayon::prelude::*;
use rig::math::{Point2, Point3, Real, Vector3};
use rig::{LaserPlane, PinholeCamera, Projector, RangeGrid, Sensor};
use serde::Serialize;

/// Eq. 2.3: the camera–point distance of a planar triangulation with baseline `b` and interior angles
/// `alpha` (at the emitter) and `beta` (at the camera), radians.
pub fn depth_eq_2_3(b: Real, alpha: Real, beta: Real) -> Real {
    b * alpha.sin() / (alpha + beta).sin()
}

/// The point where the camera ray through `px` meets a laser plane (camera frame, mm).
pub fn camera_ray_plane(camera: &PinholeCamera, px: Point2, plane: &LaserPlane) -> Option<Point3> {
    let d = camera.unproject(px)?;
    plane.intersect_ray(&Point3::origin(), &d)
}

/// The closest points of two rays `a + s·d` and `b + t·e`: their midpoint and the gap between them.
pub fn ray_ray(a: &Point3, d: &Vector3, b: &Point3, e: &Vector3) -> Option<(Point3, Real)> {
    let w0 = a - b;
    let (aa, bb, cc, dd, ee) = (d.dot(d), d.dot(e), e.dot(e), d.dot(&w0), e.dot(&w0));
    let denom = aa * cc - bb * bb;
    if denom.abs() < 1e-12 * aa * cc {
        return None;
    }
    let s = (bb * ee - cc * dd) / denom;
    let t = (aa * ee - bb * dd) / denom;
    let (p, q) = (a + d * s, b + e * t);
    Some((Point3::from((p.coords + q.coords) / 2.0), (p - q).norm()))
}

/// [`ray_ray`] for a camera ray from the origin, specialised for the per-pixel loop: one division,
/// and the gap compared squared. The midpoint, where the rays pass within `max_gap` and in front of
/// the camera.
#[inline]
fn camera_ray_meets(d: &Vector3, b: &Point3, e: &Vector3, max_gap: Real) -> Option<Point3> {
    let w0 = -b.coords;
    let (aa, bb, cc, dd, ee) = (d.dot(d), d.dot(e), e.dot(e), d.dot(&w0), e.dot(&w0));
    let denom = aa * cc - bb * bb;
    if denom.abs() < 1e-12 * aa * cc {
        return None;
    }
    let inv = 1.0 / denom;
    let (s, t) = ((bb * ee - cc * dd) * inv, (aa * ee - bb * dd) * inv);
    let (p, q) = (d * s, b.coords + e * t);
    let mid = (p + q) * 0.5;
    ((p - q).norm_squared() <= max_gap * max_gap && mid.z > 0.0).then_some(Point3::from(mid))
}

/// How the projector correspondences become points.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TriangulateParams {
    /// Use the projector ray (columns and rows, least squares) where rows are decoded; otherwise, and
    /// when false, the camera ray against the projector's column surface.
    pub use_rows: bool,
    /// Ray–ray: reject points where the camera and projector rays pass farther apart than this (mm).
    pub max_ray_gap_mm: Real,
}

impl Default for TriangulateParams {
    fn default() -> Self {
        TriangulateParams { use_rows: true, max_ray_gap_mm: 1.0 }
    }
}

/// Where the camera ray `s·d` meets the projector's column `u`, distortion included: the plane through
/// the projector centre and two of the column's rays gives a start, then Newton's method on the
/// projected column along the ray removes the lens's curvature of that "plane".
pub fn camera_ray_projector_column(d: &Vector3, projector: &Projector, u: Real) -> Option<Point3> {
    let h = projector.lens.height as Real;
    let (c, r1) = projector.ray_in_camera(Point2::new(u, 0.0))?;
    let (_, r2) = projector.ray_in_camera(Point2::new(u, h - 1.0))?;
    let n = r1.cross(&r2);
    let denom = n.dot(d);
    if denom.abs() < 1e-12 {
        return None;
    }
    let mut s = n.dot(&c.coords) / denom;
    let column = |s: Real| projector.project(&Point3::from(d * s)).map(|p| p.x - u);
    for _ in 0..4 {
        let f = column(s)?;
        let step = 1e-4 * s.abs().max(1.0);
        let df = (column(s + step)? - column(s - step)?) / (2.0 * step);
        if df.abs() < 1e-15 {
            break;
        }
        s -= f / df;
        if f.abs() < 1e-9 {
            break;
        }
    }
    (s > 0.0 && s.is_finite()).then(|| Point3::from(d * s))
}

/// Set up once per rig, used for every view: the camera's ray through every pixel and the projector's
/// undistortion sampled on its pixel grid (bilinear in between), so triangulating a pixel costs a few
/// multiplications instead of two iterative undistortions.
pub struct Triangulator {
    camera: PinholeCamera,
    projector: Projector,
    rays: Vec<Vector3>,
    /// The projector's ray direction (camera frame, z = 1 before rotation) at projector pixel centres
    /// −1 ..= width, −1 ..= height: undistorted and rotated once here, since bilinear interpolation
    /// commutes with the rotation.
    table: Vec<Vector3>,
    table_w: usize,
    /// The projector centre in the camera frame.
    centre: Point3,
}

impl Triangulator {
    /// Tabulates the rays of a camera and projector.
    pub fn new(camera: &PinholeCamera, projector: &Projector) -> Self {
        let w = camera.width as usize;
        let rays = (0..w * camera.height as usize)
            .into_par_iter()
            .map(|i| {
                let px = Point2::new((i % w) as Real, (i / w) as Real);
                camera.unproject(px).map(|d| d.into_inner()).unwrap_or_else(|| Vector3::repeat(Real::NAN))
            })
            .collect();
        let (tw, th) = (projector.lens.width as usize + 2, projector.lens.height as usize + 2);
        let to_camera = projector.from_camera.inverse();
        let table = (0..tw * th)
            .into_par_iter()
            .map(|i| {
                let px = Point2::new((i % tw) as Real - 1.0, (i / tw) as Real - 1.0);
                match projector.lens.pixel_to_normalized(px) {
                    Some(n) => to_camera.rotation * Vector3::new(n.x, n.y, 1.0),
                    None => Vector3::repeat(Real::NAN),
                }
            })
            .collect();
        let centre = to_camera * Point3::origin();
        Triangulator { camera: *camera, projector: *projector, rays, table, table_w: tw, centre }
    }

    /// The projector's ray through (u, v), in the camera frame: origin and (non-unit) direction.
    fn projector_ray(&self, u: Real, v: Real) -> Option<(Point3, Vector3)> {
        let (x, y) = (u + 1.0, v + 1.0);
        let (x0, y0) = (x.floor(), y.floor());
        // Compared as floats before any cast: a corrupt map's u = 1e30 must not wrap into an index.
        let rows = (self.table.len() / self.table_w) as Real;
        if !(x0 >= 0.0 && y0 >= 0.0 && x0 + 1.0 < self.table_w as Real && y0 + 1.0 < rows) {
            return None;
        }
        let (fx, fy) = (x - x0, y - y0);
        let i = y0 as usize * self.table_w + x0 as usize;
        let t = &self.table;
        let top = t[i] * (1.0 - fx) + t[i + 1] * fx;
        let bottom = t[i + self.table_w] * (1.0 - fx) + t[i + self.table_w + 1] * fx;
        Some((self.centre, top * (1.0 - fy) + bottom * fy))
    }

    fn triangulate_pixel(&self, map: &ProjectorMap, i: usize, params: &TriangulateParams) -> Option<Point3> {
        let u = map.u[i];
        // Undecoded pixels (the larger part of a view) never touch the ray table.
        if !u.is_finite() {
            return None;
        }
        let (v, d) = (map.v[i], self.rays[i]);
        if !d.x.is_finite() {
            return None;
        }
        if params.use_rows && v.is_finite() {
            let (o, e) = self.projector_ray(u, v)?;
            camera_ray_meets(&d, &o, &e, params.max_ray_gap_mm)
        } else {
            camera_ray_projector_column(&d, &self.projector, u)
        }
    }

    /// The camera's image size (width, height) this triangulator was built for.
    pub fn camera_size(&self) -> (u32, u32) {
        (self.camera.width, self.camera.height)
    }

    /// Triangulates a decoded view into a range grid on the camera's pixel grid (camera frame, mm), with
    /// the decoding confidence and the camera centre as sensor. Normals are left to
    /// [`crate::triangulate::grid_normals`].
    pub fn triangulate(&self, map: &ProjectorMap, params: &TriangulateParams) -> RangeGrid {
        let (w, h) = (map.width, map.height);
        assert_eq!((w, h), (self.camera.width as usize, self.camera.height as usize), "map and camera sizes differ");
        // Every cell is written exactly once, straight into the grid's vectors: no NaN-filled grid
        // first (31 MB of writes at 1280 × 1024, a tenth of the time).
        let nan = Point3::new(Real::NAN, Real::NAN, Real::NAN);
        let points: Vec<Point3> =
            (0..w * h).into_par_iter().map(|i| self.triangulate_pixel(map, i, params).unwrap_or(nan)).collect();
        let valid: Vec<bool> = points.par_iter().map(|p| p.x.is_finite()).collect();
        let confidence: Vec<f32> =
            valid.par_iter().zip(&map.confidence).map(|(&ok, &c)| if ok { c } else { 0.0 }).collect();
        RangeGrid {
            width: w,
            height: h,
            points,
            valid,
            normals: None,
            confidence: Some(confidence),
            colors: None,
            sensor: Sensor::Center(Point3::origin()),
        }
    }
}

/// Triangulates one decoded view (sets up a [`Triangulator`] for it; reuse one across views instead).
pub fn triangulate_map(
    map: &ProjectorMap,
    camera: &PinholeCamera,
    projector: &Projector,
    params: &TriangulateParams,
) -> RangeGrid {
    Triangulator::new(camera, projector).triangulate(map, params)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::math::Isometry3;

    #[test]
    fn projector_coordinates_far_outside_the_projector_triangulate_to_nothing() {
        // A cached map can hold anything (issue 19, defect 3): out-of-range values are undecoded, not
        // an index out of bounds.
        let camera = PinholeCamera::ideal(8, 6, 10.0);
        let projector = Projector {
            lens: PinholeCamera::ideal(16, 12, 20.0),
            from_camera: Isometry3::translation(-50.0, 0.0, 0.0),
            gamma: 1.0,
        };
        let tri = Triangulator::new(&camera, &projector);
        let mut map = ProjectorMap::empty(8, 6);
        for (i, u) in [1e30, -1e30, 16.4, -3.0, Real::INFINITY, 1e19].into_iter().enumerate() {
            map.u[i] = u;
            map.v[i] = u;
        }
        let grid = tri.triangulate(&map, &TriangulateParams::default());
        assert_eq!(grid.valid_count(), 0);
    }

    #[test]
    fn ray_plane_intersection_reduces_to_eq_2_3_in_the_plane() {
        // Camera at the origin, laser at (b, 0, 0) on the baseline; everything in the y = 0 plane, z ahead.
        let b = 120.0;
        for (alpha_deg, beta_deg) in [(60.0, 70.0), (45.0, 80.0), (75.0, 50.0), (30.0, 100.0)] {
            let (alpha, beta): (Real, Real) = (f64::to_radians(alpha_deg), f64::to_radians(beta_deg));
            let laser = Point3::new(b, 0.0, 0.0);
            // The beam leaves the laser at α to the baseline (toward the camera side), the viewing ray
            // leaves the camera at β to the baseline; the laser plane holds the beam and the y axis.
            let beam = Vector3::new(-alpha.cos(), 0.0, alpha.sin());
            let plane = LaserPlane::from_point_normal(&laser, beam.cross(&Vector3::y())).unwrap();
            let ray = Vector3::new(beta.cos(), 0.0, beta.sin());
            let p = plane.intersect_ray(&Point3::origin(), &ray).unwrap();
            let d = depth_eq_2_3(b, alpha, beta);
            assert!((p.coords.norm() - d).abs() < 1e-9 * d, "α {alpha_deg}° β {beta_deg}°: {} vs {d}", p.coords.norm());
        }
    }

    #[test]
    fn column_and_ray_triangulation_find_a_known_point() {
        let mut lens = PinholeCamera::ideal(1024, 768, 1700.0);
        lens.distortion.k1 = 0.05;
        let from_camera = Isometry3::new(Vector3::new(-150.0, 0.0, 30.0), Vector3::new(0.0, 0.35, 0.0));
        let projector = Projector { lens, from_camera, gamma: 1.0 };
        let camera = PinholeCamera::ideal(1280, 1024, 2400.0);
        for x in [Point3::new(10.0, -20.0, 430.0), Point3::new(-40.0, 35.0, 400.0), Point3::new(60.0, 50.0, 470.0)] {
            let uv = projector.project(&x).unwrap();
            let d = camera.unproject(camera.project(&x).unwrap()).unwrap().into_inner();
            let p = camera_ray_projector_column(&d, &projector, uv.x).unwrap();
            assert!((p - x).norm() < 1e-6, "column: {p:?} vs {x:?}");
            let (o, e) = projector.ray_in_camera(uv).unwrap();
            let (q, gap) = ray_ray(&Point3::origin(), &d, &o, &e).unwrap();
            assert!((q - x).norm() < 1e-6 && gap < 1e-6, "ray–ray: {q:?} vs {x:?}");
            // The tabulated projector rays agree with the exact ones.
            let t = Triangulator::new(&camera, &projector);
            let (o2, e2) = t.projector_ray(uv.x, uv.y).unwrap();
            let (q2, _) = ray_ray(&Point3::origin(), &d, &o2, &e2).unwrap();
            assert!((q2 - x).norm() < 1e-4, "tabulated: {q2:?} vs {x:?}");
        }
    }
}
