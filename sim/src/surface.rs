//! What rays hit: analytic shapes (exact, for ground-truth tests) and triangle meshes (through a BVH),
//! each in its own local frame.
//!
//! # Conventions
//! A [`Surface`] answers rays in its local frame ([`Surface::cast_local`]); [`Surface::cast`] takes the
//! pose that maps local coordinates into the frame the ray is given in. Distances `t` are along the ray's
//! direction as given (unit directions give millimetres). Normals are unit, geometric, and not flipped.

use crate::bvh::Bvh;
use rig::math::{Isometry3, Point3, Real, Vector3};

/// A local hit: distance, unit geometric normal (local frame), and where on the surface (for albedo).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalHit {
    /// Distance along the ray.
    pub t: Real,
    /// Unit geometric normal in the surface's local frame.
    pub normal: Vector3,
    /// Surface coordinates for albedo: (triangle, u, v) barycentrics for meshes; local (x, y) for planes.
    pub uv: (u32, Real, Real),
}

/// Something rays can hit.
pub trait Surface: Send + Sync {
    /// The nearest hit with `t ∈ (t_min, t_max)` of a ray in the local frame.
    fn cast_local(&self, origin: &Point3, dir: &Vector3, t_min: Real, t_max: Real) -> Option<LocalHit>;

    /// Whether anything is hit with `t ∈ (t_min, t_max)`; surfaces may answer faster than `cast_local`.
    fn occluded_local(&self, origin: &Point3, dir: &Vector3, t_min: Real, t_max: Real) -> bool {
        self.cast_local(origin, dir, t_min, t_max).is_some()
    }

    /// The nearest hit of a ray given in the frame `pose` maps local coordinates into; the normal is
    /// returned in that frame too.
    fn cast(&self, pose: &Isometry3, origin: &Point3, dir: &Vector3, t_min: Real, t_max: Real) -> Option<LocalHit> {
        let inv = pose.inverse();
        let hit = self.cast_local(&(inv * origin), &(inv * dir), t_min, t_max)?;
        Some(LocalHit { normal: pose * hit.normal, ..hit })
    }
}

/// A sphere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre (local frame, mm).
    pub center: Point3,
    /// Radius (mm).
    pub radius: Real,
}

impl Surface for Sphere {
    fn cast_local(&self, origin: &Point3, dir: &Vector3, t_min: Real, t_max: Real) -> Option<LocalHit> {
        // |o + t·d − c|² = r², solved in the numerically stable form (no cancellation for far spheres).
        let oc = origin - self.center;
        let a = dir.norm_squared();
        let half_b = oc.dot(dir);
        let c = oc.norm_squared() - self.radius * self.radius;
        let disc = half_b * half_b - a * c;
        if disc < 0.0 {
            return None;
        }
        let q = -(half_b + half_b.signum() * disc.sqrt());
        let (mut t0, mut t1) = (q / a, c / q);
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        let t = [t0, t1].into_iter().find(|&t| t > t_min && t < t_max)?;
        let n = (origin + dir * t - self.center) / self.radius;
        Some(LocalHit { t, normal: n, uv: (0, n.x, n.y) })
    }
}

/// A flat rectangle in its local z = 0 plane, centred on the origin, normal +z.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rectangle {
    /// Half the size along local x (mm).
    pub half_width: Real,
    /// Half the size along local y (mm).
    pub half_height: Real,
}

impl Surface for Rectangle {
    fn cast_local(&self, origin: &Point3, dir: &Vector3, t_min: Real, t_max: Real) -> Option<LocalHit> {
        let t = -origin.z / dir.z;
        if !(t > t_min && t < t_max) {
            return None;
        }
        let p = origin + dir * t;
        (p.x.abs() <= self.half_width && p.y.abs() <= self.half_height).then_some(LocalHit {
            t,
            normal: Vector3::z(),
            uv: (0, p.x, p.y),
        })
    }
}

/// A flat disc in its local z = 0 plane, centred on the origin, normal +z (the turntable's platter).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Disc {
    /// Radius (mm).
    pub radius: Real,
}

impl Surface for Disc {
    fn cast_local(&self, origin: &Point3, dir: &Vector3, t_min: Real, t_max: Real) -> Option<LocalHit> {
        let t = -origin.z / dir.z;
        if !(t > t_min && t < t_max) {
            return None;
        }
        let p = origin + dir * t;
        (p.x * p.x + p.y * p.y <= self.radius * self.radius).then_some(LocalHit {
            t,
            normal: Vector3::z(),
            uv: (0, p.x, p.y),
        })
    }
}

/// A triangle mesh behind a BVH built once.
pub struct MeshSurface {
    bvh: Bvh,
    normals: Vec<Vector3>,
}

impl MeshSurface {
    /// Builds the BVH and the face normals.
    pub fn new(mesh: &rig::TriMesh) -> Self {
        let normals = mesh
            .faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|i| mesh.vertices[i as usize]);
                (b - a).cross(&(c - a)).try_normalize(0.0).unwrap_or_else(Vector3::z)
            })
            .collect();
        MeshSurface { bvh: Bvh::new(mesh), normals }
    }
}

impl Surface for MeshSurface {
    fn cast_local(&self, origin: &Point3, dir: &Vector3, t_min: Real, t_max: Real) -> Option<LocalHit> {
        let h = self.bvh.cast(origin, dir, t_min, t_max)?;
        Some(LocalHit { t: h.t, normal: self.normals[h.triangle as usize], uv: (h.triangle, h.u, h.v) })
    }

    fn occluded_local(&self, origin: &Point3, dir: &Vector3, t_min: Real, t_max: Real) -> bool {
        self.bvh.occluded(origin, dir, t_min, t_max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_hits_the_near_side_and_the_far_side_from_inside() {
        let s = Sphere { center: Point3::new(0.0, 0.0, 100.0), radius: 10.0 };
        let h = s.cast_local(&Point3::origin(), &Vector3::z(), 0.0, f64::INFINITY).unwrap();
        assert!((h.t - 90.0).abs() < 1e-12 && (h.normal + Vector3::z()).norm() < 1e-12);
        let inside = s.cast_local(&Point3::new(0.0, 0.0, 100.0), &Vector3::z(), 0.0, f64::INFINITY).unwrap();
        assert!((inside.t - 10.0).abs() < 1e-12);
    }

    #[test]
    fn posed_cast_returns_normals_in_the_ray_frame() {
        let pose = Isometry3::new(Vector3::new(0.0, 0.0, 300.0), Vector3::new(0.0, std::f64::consts::PI, 0.0));
        // A rectangle turned to face −z, 300 mm ahead.
        let h = Rectangle { half_width: 10.0, half_height: 10.0 }
            .cast(&pose, &Point3::origin(), &Vector3::z(), 0.0, f64::INFINITY)
            .unwrap();
        assert!((h.t - 300.0).abs() < 1e-9 && (h.normal + Vector3::z()).norm() < 1e-9);
    }
}
