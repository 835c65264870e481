//! Distances from points to a triangle mesh: AdFFT's subdivision test (the Hausdorff distance of a
//! cell's samples to its local surface) and accuracy measurements against reference meshes.

use rig::TriMesh;
use rig::math::{Point3, Real};
use rustc_hash::FxHashMap;

/// The closest point on triangle abc to p (Ericson, Real-Time Collision Detection, 5.1.5).
pub fn closest_on_triangle(p: &Point3, a: &Point3, b: &Point3, c: &Point3) -> Point3 {
    let q = closest_on_proper_triangle(p, a, b, c);
    if q.coords.iter().all(|v| v.is_finite()) {
        return q;
    }
    // A degenerate triangle (two corners equal, or all three on a line: a meshing tool's sliver)
    // divides by zero above; its closest point is on one of its edges.
    [(a, b), (b, c), (c, a)]
        .into_iter()
        .map(|(u, v)| closest_on_segment(p, u, v))
        .min_by(|x, y| (x - p).norm_squared().total_cmp(&(y - p).norm_squared()))
        .unwrap_or(*a)
}

/// The point of segment uv closest to `p` (u itself when the segment has no length).
fn closest_on_segment(p: &Point3, u: &Point3, v: &Point3) -> Point3 {
    let uv = v - u;
    let length2 = uv.norm_squared();
    if length2 <= 0.0 {
        return *u;
    }
    u + uv * ((p - u).dot(&uv) / length2).clamp(0.0, 1.0)
}

/// Ericson's region test (Real-Time Collision Detection, 5.1.5), for a triangle with area.
fn closest_on_proper_triangle(p: &Point3, a: &Point3, b: &Point3, c: &Point3) -> Point3 {
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

/// Point-to-mesh distances through a uniform grid of triangle bounding boxes.
pub struct MeshDistance {
    tris: Vec<[Point3; 3]>,
    cell: Real,
    // Fx hashing: the ring search looks up 27 or more cells a query, and SipHash dominated it.
    cells: FxHashMap<[i64; 3], Vec<u32>>,
    /// Grid keys spanned by the mesh, for ending the ring search.
    lo: [i64; 3],
    hi: [i64; 3],
}

impl MeshDistance {
    /// Indexes `mesh` with grid cells of edge `cell` (about the triangles' size, or the distances
    /// expected, whichever is larger).
    pub fn new(mesh: &TriMesh, cell: Real) -> Self {
        let tris: Vec<[Point3; 3]> = mesh.faces.iter().map(|f| f.map(|i| mesh.vertices[i as usize])).collect();
        let mut cells: FxHashMap<[i64; 3], Vec<u32>> = FxHashMap::default();
        let (mut lo, mut hi) = ([i64::MAX; 3], [i64::MIN; 3]);
        for (t, tri) in tris.iter().enumerate() {
            let a = key(&tri[0].inf(&tri[1]).inf(&tri[2]), cell);
            let b = key(&tri[0].sup(&tri[1]).sup(&tri[2]), cell);
            for d in 0..3 {
                lo[d] = lo[d].min(a[d]);
                hi[d] = hi[d].max(b[d]);
            }
            for x in a[0]..=b[0] {
                for y in a[1]..=b[1] {
                    for z in a[2]..=b[2] {
                        cells.entry([x, y, z]).or_default().push(t as u32);
                    }
                }
            }
        }
        MeshDistance { tris, cell, cells, lo, hi }
    }

    /// The distance from `p` to the mesh (infinite for an empty mesh or a non-finite `p`). Searches
    /// rings of grid cells outward until the nearest triangle found is closer than the unsearched cells
    /// can be; far from the mesh, where the rings would hold more cells than there are triangles, it
    /// checks every triangle instead.
    pub fn distance(&self, p: &Point3) -> Real {
        self.distance_up_to(p, Real::INFINITY)
    }

    /// Like [`distance`](Self::distance), but stops searching at `limit`: returns the distance when it
    /// is at most `limit`, otherwise some value above `limit` (possibly infinite).
    pub fn distance_up_to(&self, p: &Point3, limit: Real) -> Real {
        self.nearest_up_to(p, limit).map_or(Real::INFINITY, |(d, _)| d)
    }

    /// The nearest triangle (index into the mesh's faces) and its distance; `None` for an empty mesh
    /// or a point with a non-finite coordinate (such as an invalid range-grid cell's NaN).
    pub fn nearest(&self, p: &Point3) -> Option<(Real, usize)> {
        self.nearest_up_to(p, Real::INFINITY)
    }

    /// The distance from `p` to the mesh when it exceeds `bound`, `None` when it does not. A
    /// Hausdorff distance (the largest of many distances) needs exact values only above the largest
    /// found so far: below it, the first triangle within `bound` settles the query.
    pub fn distance_beyond(&self, p: &Point3, bound: Real) -> Option<Real> {
        match self.search(p, Real::INFINITY, bound) {
            Some((d, _)) if d <= bound => None,
            Some((d, _)) => Some(d),
            None => Some(Real::INFINITY),
        }
    }

    fn nearest_up_to(&self, p: &Point3, limit: Real) -> Option<(Real, usize)> {
        self.search(p, limit, -1.0)
    }

    /// The ring search: stops at `limit`, or as soon as a triangle within `enough` is found.
    fn search(&self, p: &Point3, limit: Real, enough: Real) -> Option<(Real, usize)> {
        // A NaN compares false with every bound, so the ring search would end up checking every
        // triangle, for nothing.
        if !p.coords.iter().all(|c| c.is_finite()) {
            return None;
        }
        let mut best: Option<(Real, usize)> = None;
        let consider = |t: usize, best: &mut Option<(Real, usize)>| {
            let [a, b, c] = &self.tris[t];
            let d = (closest_on_triangle(p, a, b, c) - p).norm();
            if best.is_none_or(|(bd, _)| d < bd) {
                *best = Some((d, t));
            }
        };
        let k = key(p, self.cell);
        for ring in 0i64.. {
            if self.tris.is_empty() || (ring - 1) as Real * self.cell > limit {
                break;
            }
            if ((2 * ring + 1) as usize).pow(3) > 8 * self.tris.len() {
                (0..self.tris.len()).for_each(|t| consider(t, &mut best));
                break;
            }
            for dx in -ring..=ring {
                for dy in -ring..=ring {
                    for dz in -ring..=ring {
                        if dx.abs().max(dy.abs()).max(dz.abs()) != ring {
                            continue;
                        }
                        for &t in self.cells.get(&[k[0] + dx, k[1] + dy, k[2] + dz]).into_iter().flatten() {
                            consider(t as usize, &mut best);
                            if best.is_some_and(|(d, _)| d <= enough) {
                                return best;
                            }
                        }
                    }
                }
            }
            // Cells beyond this ring are at least `ring · cell` away.
            let beyond_mesh = (0..3).all(|d| k[d] - ring <= self.lo[d] && k[d] + ring >= self.hi[d]);
            if best.is_some_and(|(d, _)| d <= ring as Real * self.cell) || beyond_mesh {
                break;
            }
        }
        best
    }

    /// The unit normal of triangle `t` (counter-clockwise vertices facing the viewer).
    pub fn triangle_normal(&self, t: usize) -> rig::math::Vector3 {
        let [a, b, c] = &self.tris[t];
        (b - a).cross(&(c - a)).normalize()
    }
}

fn key(p: &Point3, cell: Real) -> [i64; 3] {
    [(p.x / cell).floor() as i64, (p.y / cell).floor() as i64, (p.z / cell).floor() as i64]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Degenerate triangles (corners repeated, corners on a line) give the distance to their edges,
    /// not NaN: one in PoissonRecon's depth-10 bunny had made a whole completeness mean NaN.
    #[test]
    fn degenerate_triangles_measure_to_their_edges() {
        let p = Point3::new(0.5, 2.0, 0.0);
        let (a, b, c) = (Point3::new(0.0, 0.0, 0.0), Point3::new(1.0, 0.0, 0.0), Point3::new(2.0, 0.0, 0.0));
        for (u, v, w) in [(a, a, b), (a, b, c), (b, a, a), (a, a, a), (c, a, b)] {
            let q = closest_on_triangle(&p, &u, &v, &w);
            let expected = if (u, v, w) == (a, a, a) { a } else { Point3::new(0.5, 0.0, 0.0) };
            assert!((q - expected).norm() < 1e-12, "{u} {v} {w}: {q}");
        }
        let mesh = TriMesh { vertices: vec![a, b, c], faces: vec![[0, 1, 2], [0, 0, 1]], normals: None };
        assert!((MeshDistance::new(&mesh, 1.0).distance(&p) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn distances_to_a_square_match_the_geometry() {
        let mesh = TriMesh {
            vertices: vec![
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(1.0, 1.0, 0.0),
                Point3::new(0.0, 1.0, 0.0),
            ],
            faces: vec![[0, 1, 2], [0, 2, 3]],
            normals: None,
        };
        let d = MeshDistance::new(&mesh, 0.25);
        assert!((d.distance(&Point3::new(0.5, 0.5, 0.3)) - 0.3).abs() < 1e-12);
        assert!((d.distance(&Point3::new(2.0, 0.5, 0.0)) - 1.0).abs() < 1e-12);
        // Far away: the ring search still finds the corner.
        assert!((d.distance(&Point3::new(-30.0, -40.0, 0.0)) - 50.0).abs() < 1e-9);
        // No answer for a point that is not one.
        assert_eq!(d.nearest(&Point3::new(f64::NAN, 0.0, 0.0)), None);
        assert_eq!(d.distance(&Point3::new(0.0, f64::INFINITY, 0.0)), Real::INFINITY);
    }
}
