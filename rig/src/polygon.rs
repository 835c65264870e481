//! Polygons other tools can read: a face of more than four corners, or a quad that is not convex, is
//! cut into triangles by ear clipping in its own plane. Readers such as Open3D triangulate each polygon
//! themselves and fail on non-convex ones ("could not be decomposed"), keeping a handful of faces; a
//! fan from the first corner folds a non-convex polygon over itself.

use crate::math::{Point3, Real, Vector3};
use crate::mesh::PolyMesh;

/// The polygon's normal by Newell's method (robust for non-convex and slightly non-planar polygons).
fn newell(points: &[Point3]) -> Vector3 {
    let mut n = Vector3::zeros();
    for (i, a) in points.iter().enumerate() {
        let b = points[(i + 1) % points.len()];
        n.x += (a.y - b.y) * (a.z + b.z);
        n.y += (a.z - b.z) * (a.x + b.x);
        n.z += (a.x - b.x) * (a.y + b.y);
    }
    n
}

/// The corners in 2-D coordinates of the polygon's plane, counter-clockwise seen along its normal;
/// `None` for a polygon of no area.
fn planar(points: &[Point3]) -> Option<Vec<[Real; 2]>> {
    let n = newell(points);
    let len = n.norm();
    if !(len > 0.0 && len.is_finite()) {
        return None;
    }
    let n = n / len;
    let helper = if n.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
    let u = n.cross(&helper).normalize();
    let v = n.cross(&u);
    Some(points.iter().map(|p| [p.coords.dot(&u), p.coords.dot(&v)]).collect())
}

fn cross(o: [Real; 2], a: [Real; 2], b: [Real; 2]) -> Real {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

/// Whether a quad (or triangle) is strictly convex in its own plane.
pub fn is_convex(points: &[Point3]) -> bool {
    let Some(p) = planar(points) else { return false };
    let n = p.len();
    let signs: Vec<Real> = (0..n).map(|i| cross(p[i], p[(i + 1) % n], p[(i + 2) % n])).collect();
    signs.iter().all(|&s| s > 0.0) || signs.iter().all(|&s| s < 0.0)
}

/// Triangles (corner indices into `points`) covering the simple polygon `points`, by ear clipping in
/// its plane; a fan from the first corner where the polygon has no area or ear clipping finds no ear
/// (a self-intersecting outline).
pub fn ear_clip(points: &[Point3]) -> Vec<[usize; 3]> {
    let n = points.len();
    let fan = || (1..n.saturating_sub(1)).map(|k| [0, k, k + 1]).collect::<Vec<_>>();
    let Some(p) = planar(points) else { return fan() };
    // Newell's normal makes the outline counter-clockwise in (u, v): ears turn left.
    let mut left: Vec<usize> = (0..n).collect();
    let mut out = Vec::with_capacity(n.saturating_sub(2));
    while left.len() > 3 {
        let m = left.len();
        let ear = (0..m).find(|&i| {
            let (a, b, c) = (left[(i + m - 1) % m], left[i], left[(i + 1) % m]);
            cross(p[a], p[b], p[c]) > 0.0
                && left.iter().all(|&q| {
                    q == a
                        || q == b
                        || q == c
                        || !(cross(p[a], p[b], p[q]) >= 0.0
                            && cross(p[b], p[c], p[q]) >= 0.0
                            && cross(p[c], p[a], p[q]) >= 0.0)
                })
        });
        let Some(i) = ear else { return fan() };
        out.push([left[(i + m - 1) % m], left[i], left[(i + 1) % m]]);
        left.remove(i);
    }
    out.push([left[0], left[1], left[2]]);
    out
}

impl PolyMesh {
    /// The mesh with every face a triangle or a convex quad: larger and non-convex faces are cut by
    /// [`ear_clip`], keeping each face's orientation. Returns the mesh and how many faces were cut.
    pub fn with_readable_faces(&self) -> (PolyMesh, usize) {
        let mut out = PolyMesh {
            vertices: self.vertices.clone(),
            normals: self.normals.clone(),
            colors: self.colors.clone(),
            ..PolyMesh::default()
        };
        // Every edge the faces have: a cut's diagonal that repeats one (the edge of a neighbour, or of
        // an earlier cut) would be an edge of three faces. Ear clipping from another corner gives other
        // diagonals; the first start whose diagonals are all new is taken.
        let key = crate::mesh::edge_key;
        let mut taken = self.edge_set();
        let mut cut = 0;
        for f in self.faces() {
            let pts: Vec<Point3> = f.iter().map(|&v| self.vertices[v as usize]).collect();
            if f.len() == 3 || (f.len() == 4 && is_convex(&pts)) {
                out.push_face(f);
                continue;
            }
            cut += 1;
            let n = f.len();
            let clipped = |r: usize| -> Vec<[u32; 3]> {
                let turned: Vec<Point3> = (0..n).map(|k| pts[(k + r) % n]).collect();
                ear_clip(&turned).iter().map(|t| t.map(|k| f[(k + r) % n])).collect()
            };
            let diagonals = |tris: &[[u32; 3]]| -> Vec<(u32, u32)> {
                let side = |a: u32, b: u32| (0..n).any(|k| key(f[k], f[(k + 1) % n]) == key(a, b));
                let edges = tris.iter().flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]);
                edges.filter(|&(a, b)| !side(a, b)).map(|(a, b)| key(a, b)).collect()
            };
            let tris = (0..n)
                .map(clipped)
                .find(|tris| diagonals(tris).iter().all(|d| !taken.contains(d)))
                .unwrap_or_else(|| clipped(0));
            taken.extend(diagonals(&tris));
            for t in tris {
                out.push_face(&t);
            }
        }
        (out, cut)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(points: &[Point3], tris: &[[usize; 3]]) -> Real {
        tris.iter().map(|t| (points[t[1]] - points[t[0]]).cross(&(points[t[2]] - points[t[0]])).norm() / 2.0).sum()
    }

    #[test]
    fn an_l_shaped_hexagon_is_cut_inside_its_outline_with_its_area() {
        // An L: area 3; a fan from corner 0 would cover a triangle outside it.
        let l = [(0., 0.), (2., 0.), (2., 1.), (1., 1.), (1., 2.), (0., 2.)];
        for rotate in 0..6 {
            let pts: Vec<Point3> =
                (0..6).map(|i| l[(i + rotate) % 6]).map(|(x, y)| Point3::new(x, y, 0.5 * x)).collect();
            let tris = ear_clip(&pts);
            assert_eq!(tris.len(), 4);
            let flat: Vec<Point3> = (0..6).map(|i| l[(i + rotate) % 6]).map(|(x, y)| Point3::new(x, y, 0.0)).collect();
            assert!((area(&flat, &tris) - 3.0).abs() < 1e-12, "rotation {rotate}: {tris:?}");
        }
        assert!(!is_convex(&[
            Point3::new(0., 0., 0.),
            Point3::new(2., 0., 0.),
            Point3::new(0.5, 0.5, 0.),
            Point3::new(0., 2., 0.)
        ]));
        assert!(is_convex(&[
            Point3::new(0., 0., 0.),
            Point3::new(1., 0., 0.),
            Point3::new(1., 1., 0.),
            Point3::new(0., 1., 0.)
        ]));
    }

    #[test]
    fn readable_faces_keep_triangles_and_convex_quads_and_cut_the_rest() {
        let v = vec![
            Point3::new(0., 0., 0.),
            Point3::new(1., 0., 0.),
            Point3::new(1., 1., 0.),
            Point3::new(0., 1., 0.),
            Point3::new(0.5, 0.2, 0.),
            Point3::new(2., 0., 0.),
        ];
        let mesh = PolyMesh::from_faces(v, [vec![0u32, 1, 2, 3], vec![0, 5, 2, 4], vec![0, 1, 5, 2, 3]]);
        let (out, cut) = mesh.with_readable_faces();
        assert_eq!(cut, 2);
        assert!(out.faces().all(|f| f.len() == 3 || f.len() == 4));
        assert_eq!(out.face_sizes().quads, 1);
    }

    /// A pentagon cut for readers beside a triangle on a diagonal its first corner's cut takes:
    /// the cut starts from another corner, so no edge ends up with three faces.
    #[test]
    fn a_cut_repeats_no_edge_where_another_start_avoids_it() {
        let at = |k: u32| {
            let a = k as Real * std::f64::consts::TAU / 5.0;
            Point3::new(a.cos(), a.sin(), 0.0)
        };
        let mut vertices: Vec<Point3> = (0..5).map(at).collect();
        vertices.push(Point3::new(0.5, 0.5, 1.0));
        let uses = |m: &PolyMesh| {
            let mut n = std::collections::HashMap::new();
            for f in m.faces() {
                for k in 0..f.len() {
                    *n.entry((f[k].min(f[(k + 1) % f.len()]), f[k].max(f[(k + 1) % f.len()]))).or_insert(0) += 1;
                }
            }
            n
        };
        // Alone, the pentagon's cut takes the diagonal 1–4.
        let (alone, _) = PolyMesh::from_faces(vertices.clone(), [vec![0, 1, 2, 3, 4]]).with_readable_faces();
        assert!(uses(&alone).contains_key(&(1, 4)), "{:?}", alone.indices);
        // With a triangle on 1–4 it takes others.
        let (cut, count) = PolyMesh::from_faces(vertices, [vec![0, 1, 2, 3, 4], vec![1, 4, 5]]).with_readable_faces();
        assert_eq!((count, cut.face_count()), (1, 4));
        assert!(uses(&cut).values().all(|&n| n <= 2), "{:?}", cut.indices);
    }
}
