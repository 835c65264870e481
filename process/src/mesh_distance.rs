//! Distances from points to a triangle mesh: AdFFT's subdivision test (the Hausdorff distance of a
//! cell's samples to its local surface) and accuracy measurements against reference meshes.

use crate::kd_tree::PointTree;
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

/// Point-to-mesh distances through a uniform grid of triangle bounding boxes, and a k-d tree over
/// the grid's occupied cells for points far from the mesh.
pub struct MeshDistance {
    tris: Vec<[Point3; 3]>,
    cell: Real,
    // Fx hashing: the ring search looks up 27 or more cells a query, and SipHash dominated it.
    cells: FxHashMap<[i64; 3], Vec<u32>>,
    /// The occupied cells' keys, and a tree over their centres: a point far from the mesh looks only
    /// at occupied cells near its distance instead of every empty cell of the rings in between (a
    /// point 30 cells away would have looked up 200,000 of them).
    occupied: Vec<[i64; 3]>,
    centres: Option<PointTree>,
    /// Triangles spanning more than [`MAX_CELLS_PER_TRIANGLE`] cells, checked on every query instead:
    /// one vertex 10³⁰ mm out (a stray in an exported mesh) had a triangle filed in cell after cell
    /// until memory ran out.
    large: Vec<u32>,
    /// Grid keys spanned by the mesh, for ending the ring search.
    lo: [i64; 3],
    hi: [i64; 3],
}

/// Rings searched cell by cell before the search turns to the tree of occupied cells: a point within
/// two cells of the mesh settles there in at most 125 lookups.
const NEAR_RINGS: i64 = 2;

/// The most cells one triangle is filed in. A scan's base cap has triangles of 10⁴–10⁵ cells; beyond
/// 2²⁰ the cell is not made for the triangle, and checking it on every query costs less.
const MAX_CELLS_PER_TRIANGLE: Real = (1 << 20) as Real;

impl MeshDistance {
    /// Indexes `mesh` with grid cells of edge `cell` (about the triangles' size, or the distances
    /// expected, whichever is larger).
    pub fn new(mesh: &TriMesh, cell: Real) -> Self {
        let tris: Vec<[Point3; 3]> = mesh.faces.iter().map(|f| f.map(|i| mesh.vertices[i as usize])).collect();
        let mut cells: FxHashMap<[i64; 3], Vec<u32>> = FxHashMap::default();
        let (mut lo, mut hi) = ([i64::MAX; 3], [i64::MIN; 3]);
        let mut large = Vec::new();
        for (t, tri) in tris.iter().enumerate() {
            let a = key(&tri[0].inf(&tri[1]).inf(&tri[2]), cell);
            let b = key(&tri[0].sup(&tri[1]).sup(&tri[2]), cell);
            // In floating point: three spans of up to 2⁶⁴ cells overflow any integer.
            if (0..3).map(|d| b[d] as Real - a[d] as Real + 1.0).product::<Real>() > MAX_CELLS_PER_TRIANGLE {
                large.push(t as u32);
                continue;
            }
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
        let occupied: Vec<[i64; 3]> = cells.keys().copied().collect();
        let centres = (!occupied.is_empty()).then(|| {
            PointTree::new(
                &occupied.iter().map(|k| Point3::from(k.map(|c| (c as Real + 0.5) * cell))).collect::<Vec<_>>(),
            )
        });
        MeshDistance { tris, cell, cells, occupied, centres, large, lo, hi }
    }

    /// The distance from `p` to the mesh (infinite for an empty mesh or a non-finite `p`). Searches
    /// the nearest rings of grid cells, then, where they hold nothing near enough, the occupied
    /// cells within reach (see `search`).
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

    /// The ring search: stops at `limit`, or as soon as a triangle within `enough` is found. Within
    /// [`NEAR_RINGS`] cells it looks up the rings cell by cell; beyond, it asks the tree of occupied
    /// cells for those whose centre is within the distance found (or the nearest one's) plus half a
    /// cell's diagonal: the nearest point of any nearer triangle lies in such a cell.
    fn search(&self, p: &Point3, limit: Real, enough: Real) -> Option<(Real, usize)> {
        // A NaN compares false with every bound, so the ring search would end up checking every
        // triangle, for nothing.
        if !p.coords.iter().all(|c| c.is_finite()) || self.tris.is_empty() {
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
        for &t in &self.large {
            consider(t as usize, &mut best);
            if best.is_some_and(|(d, _)| d <= enough) {
                return best;
            }
        }
        let k = key(p, self.cell);
        for ring in 0..=NEAR_RINGS {
            if (ring - 1) as Real * self.cell > limit {
                return best;
            }
            if ((2 * ring + 1) as usize).pow(3) > 8 * self.tris.len() {
                (0..self.tris.len()).for_each(|t| consider(t, &mut best));
                return best;
            }
            for dx in -ring..=ring {
                for dy in -ring..=ring {
                    for dz in -ring..=ring {
                        if dx.abs().max(dy.abs()).max(dz.abs()) != ring {
                            continue;
                        }
                        for &t in self
                            .cells
                            .get(&[k[0].saturating_add(dx), k[1].saturating_add(dy), k[2].saturating_add(dz)])
                            .into_iter()
                            .flatten()
                        {
                            consider(t as usize, &mut best);
                            if best.is_some_and(|(d, _)| d <= enough) {
                                return best;
                            }
                        }
                    }
                }
            }
            // Cells beyond this ring are at least `ring · cell` away.
            let beyond_mesh =
                (0..3).all(|d| k[d].saturating_sub(ring) <= self.lo[d] && k[d].saturating_add(ring) >= self.hi[d]);
            if best.is_some_and(|(d, _)| d <= ring as Real * self.cell) || beyond_mesh {
                return best;
            }
        }
        // Farther out: a triangle at distance d has its nearest point in a cell whose centre is within
        // d plus half the cell's diagonal.
        let Some(centres) = self.centres.as_ref() else { return best };
        let half = 0.5 * 3f64.sqrt() * self.cell;
        let mut reach = match best {
            Some((d, _)) => d,
            None => {
                let (nearest, d2) = centres.nearest(p);
                if d2.sqrt() - half > limit {
                    return None;
                }
                for &t in &self.cells[&self.occupied[nearest]] {
                    consider(t as usize, &mut best);
                }
                best.map_or(Real::INFINITY, |(d, _)| d)
            }
        };
        if best.is_some_and(|(d, _)| d <= enough) {
            return best;
        }
        reach = reach.min(limit) + half;
        for c in centres.within(p, reach) {
            for &t in &self.cells[&self.occupied[c]] {
                consider(t as usize, &mut best);
                if best.is_some_and(|(d, _)| d <= enough) {
                    return best;
                }
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

    /// A triangle with a corner 10³⁰ mm out is checked on every query instead of being filed in
    /// cell after cell (which ran out of memory); the answers are still every triangle's.
    #[test]
    fn a_vertex_far_out_is_not_filed_cell_by_cell() {
        let mut mesh = sheet(3, 6);
        let k = mesh.vertices.len() as u32;
        mesh.vertices.extend([Point3::new(0.0, 0.0, 20.0), Point3::new(1.0, 0.0, 20.0), Point3::new(1e30, 1e30, 1e30)]);
        mesh.faces.push([k, k + 1, k + 2]);
        let index = MeshDistance::new(&mesh, 0.5);
        assert_eq!(index.large, vec![mesh.faces.len() as u32 - 1]);
        let tris: Vec<[Point3; 3]> = mesh.faces.iter().map(|f| f.map(|i| mesh.vertices[i as usize])).collect();
        for p in [Point3::new(3.0, 3.0, 1.0), Point3::new(0.5, 0.2, 21.0), Point3::new(-40.0, 10.0, 5.0)] {
            let want = tris
                .iter()
                .map(|[a, b, c]| (closest_on_triangle(&p, a, b, c) - p).norm())
                .fold(Real::INFINITY, Real::min);
            assert!((index.distance(&p) - want).abs() <= 1e-9 * want.max(1.0), "{p}: {} vs {want}", index.distance(&p));
        }
    }

    /// A bumpy open sheet of small triangles with a few large ones across it, from a seed.
    fn sheet(seed: u64, n: usize) -> TriMesh {
        let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut vertices = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (i as f64 + 0.3 * next(), j as f64 + 0.3 * next());
                vertices.push(Point3::new(x, y, (0.4 * x).sin() + 0.2 * next()));
            }
        }
        let at = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        let mut faces = Vec::new();
        for j in 0..n {
            for i in 0..n {
                faces.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                faces.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
        for _ in 0..3 {
            let k = vertices.len() as u32;
            for _ in 0..3 {
                vertices.push(Point3::new(next() * n as f64, next() * n as f64, 5.0 * next()));
            }
            faces.push([k, k + 1, k + 2]);
        }
        TriMesh { vertices, faces, normals: None }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(24))]
        /// Every query answers as checking every triangle would, near the mesh (the rings) and far
        /// from it (the tree of occupied cells), with and without a limit or an early answer.
        #[test]
        fn answers_equal_checking_every_triangle(seed in 0u64..1000, n in 1usize..14, cell in 0.2..4.0f64, reach in 0.5..80.0f64) {
            // n = 1: five triangles, which the search checks one by one.
            let mesh = sheet(seed, n);
            let index = MeshDistance::new(&mesh, cell);
            let tris: Vec<[Point3; 3]> = mesh.faces.iter().map(|f| f.map(|i| mesh.vertices[i as usize])).collect();
            let mut state = seed ^ 0x9e37_79b9_7f4a_7c15;
            let mut u = move || {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (state >> 11) as f64 / (1u64 << 53) as f64
            };
            let middle = n as f64 / 2.0;
            for q in 0..40 {
                let p = Point3::new(middle + reach * (2.0 * u() - 1.0), middle + reach * (2.0 * u() - 1.0), reach * (2.0 * u() - 1.0));
                let want = tris.iter().map(|[a, b, c]| (closest_on_triangle(&p, a, b, c) - p).norm()).fold(Real::INFINITY, Real::min);
                let (got, t) = index.nearest(&p).unwrap();
                proptest::prop_assert!((got - want).abs() <= 1e-9, "{} at {}: {} vs {}", q, p, got, want);
                let [a, b, c] = &tris[t];
                proptest::prop_assert!(((closest_on_triangle(&p, a, b, c) - p).norm() - got).abs() <= 1e-12);
                for limit in [0.5 * want, 0.99 * want, want, 2.0 * want] {
                    let d = index.distance_up_to(&p, limit);
                    if want <= limit {
                        proptest::prop_assert!((d - want).abs() <= 1e-9, "limit {}: {} vs {}", limit, d, want);
                    } else {
                        proptest::prop_assert!(d > limit, "limit {}: {} is not beyond it", limit, d);
                    }
                }
                for bound in [0.5 * want, 1.01 * want, 3.0 * want] {
                    match index.distance_beyond(&p, bound) {
                        None => proptest::prop_assert!(want <= bound, "bound {}: None for {}", bound, want),
                        Some(d) => proptest::prop_assert!(want > bound && (d - want).abs() <= 1e-9, "bound {}: {} vs {}", bound, d, want),
                    }
                }
            }
            // So far out that the grid's keys saturate: still an answer, not an overflow.
            let far = Point3::new(1e300, 0.0, 0.0);
            proptest::prop_assert!(index.distance(&far) > 1e299);
        }
    }
}
