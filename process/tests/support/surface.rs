//! Point-to-surface distances to a triangle mesh, shared by the tests that measure against
//! bun_zipper.ply.
#![allow(dead_code)]

use rig::TriMesh;
use rig::math::{Point3, Real};
use std::path::Path;

/// The closest point on triangle abc to p (Ericson, Real-Time Collision Detection, 5.1.5).
fn closest_on_triangle(p: &Point3, a: &Point3, b: &Point3, c: &Point3) -> Point3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return *a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return *b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return *c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// Point-to-surface distances to a triangle mesh through a uniform grid of triangle boxes.
pub struct SurfaceDistance {
    tris: Vec<[Point3; 3]>,
    cell: Real,
    cells: std::collections::HashMap<[i64; 3], Vec<u32>>,
}

impl SurfaceDistance {
    pub fn new(m: &TriMesh, cell: Real) -> Self {
        let tris: Vec<[Point3; 3]> = m.faces.iter().map(|f| f.map(|i| m.vertices[i as usize])).collect();
        let mut cells: std::collections::HashMap<[i64; 3], Vec<u32>> = Default::default();
        let key = |p: &Point3| [(p.x / cell).floor() as i64, (p.y / cell).floor() as i64, (p.z / cell).floor() as i64];
        for (t, tri) in tris.iter().enumerate() {
            let lo = key(&tri[0].inf(&tri[1]).inf(&tri[2]));
            let hi = key(&tri[0].sup(&tri[1]).sup(&tri[2]));
            for x in lo[0]..=hi[0] {
                for y in lo[1]..=hi[1] {
                    for z in lo[2]..=hi[2] {
                        cells.entry([x, y, z]).or_default().push(t as u32);
                    }
                }
            }
        }
        SurfaceDistance { tris, cell, cells }
    }

    /// The distance from p to the surface: exact within `rings` cells, otherwise by brute force.
    pub fn distance(&self, p: &Point3) -> Real {
        let k = [(p.x / self.cell).floor() as i64, (p.y / self.cell).floor() as i64, (p.z / self.cell).floor() as i64];
        let mut best = Real::INFINITY;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    for &t in self.cells.get(&[k[0] + dx, k[1] + dy, k[2] + dz]).into_iter().flatten() {
                        let [a, b, c] = &self.tris[t as usize];
                        best = best.min((closest_on_triangle(p, a, b, c) - p).norm());
                    }
                }
            }
        }
        // Anything found within one cell is the nearest; farther points search everything.
        if best <= self.cell {
            best
        } else {
            self.tris
                .iter()
                .map(|[a, b, c]| (closest_on_triangle(p, a, b, c) - p).norm())
                .fold(Real::INFINITY, Real::min)
        }
    }
}

/// bun_zipper.ply in millimetres (the file is in metres).
pub fn zipper_mm(path: &Path) -> TriMesh {
    let mut m = rig::read_mesh(path).unwrap().triangulate();
    m.vertices.iter_mut().for_each(|v| *v *= 1000.0);
    m
}
