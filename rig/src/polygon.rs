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
    /// The mesh as readers triangulate it without an edge of three faces: every face a triangle or a
    /// convex quad, started at a corner whose fan diagonal is new (readers — Open3D, trimesh, MeshLab —
    /// fan each polygon from its first corner). Larger and non-convex faces are cut by [`ear_clip`],
    /// from the first corner whose diagonals repeat no edge. Where no start avoids it (a convex quad
    /// both of whose diagonals are edges of neighbours, for one), each repeated diagonal is split at
    /// its midpoint by a new vertex, and the two triangles on it into four, whose edges to it are all
    /// new; the vertex's normal and colour are its ends' mean. Orientation is kept.
    pub fn with_readable_faces(&self) -> (PolyMesh, ReadableCut) {
        let mut out = PolyMesh {
            vertices: self.vertices.clone(),
            normals: self.normals.clone(),
            colors: self.colors.clone(),
            ..PolyMesh::default()
        };
        // Every edge the faces have, and every diagonal taken so far: a diagonal that repeats one
        // (the edge of a neighbour, or of an earlier cut) would be an edge of three faces.
        let key = crate::mesh::edge_key;
        let mut taken = self.edge_set();
        let mut report = ReadableCut::default();
        for f in self.faces() {
            let n = f.len();
            if n == 3 {
                out.push_face(f);
                continue;
            }
            let pts: Vec<Point3> = f.iter().map(|&v| self.vertices[v as usize]).collect();
            let side = |a: u32, b: u32| (0..n).any(|k| key(f[k], f[(k + 1) % n]) == key(a, b));
            let diagonals = |tris: &[[u32; 3]]| -> Vec<(u32, u32)> {
                let edges = tris.iter().flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]);
                edges.filter(|&(a, b)| !side(a, b)).map(|(a, b)| key(a, b)).collect()
            };
            let convex_quad = n == 4 && is_convex(&pts);
            // The triangles from each start: a convex quad's fan (what readers make of it), else ear clipping.
            let from = |r: usize| -> Vec<[u32; 3]> {
                if convex_quad {
                    return vec![[f[r], f[(r + 1) % 4], f[(r + 2) % 4]], [f[r], f[(r + 2) % 4], f[(r + 3) % 4]]];
                }
                let turned: Vec<Point3> = (0..n).map(|k| pts[(k + r) % n]).collect();
                ear_clip(&turned).iter().map(|t| t.map(|k| f[(k + r) % n])).collect()
            };
            let found = (0..n).map(|r| (r, from(r))).find(|(_, t)| diagonals(t).iter().all(|d| !taken.contains(d)));
            let (start, mut tris) = match found {
                Some((r, t)) => (Some(r), t),
                None => (None, from(0)),
            };
            match start {
                Some(r) if convex_quad => {
                    taken.extend(diagonals(&tris));
                    let turned: Vec<u32> = (0..4).map(|k| f[(k + r) % 4]).collect();
                    out.push_face(&turned);
                    continue;
                }
                Some(_) => {}
                None => {
                    // Each diagonal is shared by two of the triangles; the midpoint's four edges are new.
                    let mut repeated: Vec<(u32, u32)> =
                        diagonals(&tris).into_iter().filter(|d| taken.contains(d)).collect();
                    // Each diagonal is listed from both of its triangles.
                    repeated.sort_unstable();
                    repeated.dedup();
                    for (a, b) in repeated {
                        let m = out.push_midpoint(a, b);
                        let mut split = Vec::with_capacity(tris.len() + 2);
                        for t in tris {
                            match (0..3).find(|&k| key(t[k], t[(k + 1) % 3]) == (a, b)) {
                                // (p, q, c) with p–q the diagonal: (p, m, c) and (m, q, c) keep its turn.
                                Some(k) => {
                                    let (p, q, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
                                    split.extend([[p, m, c], [m, q, c]]);
                                }
                                None => split.push(t),
                            }
                        }
                        tris = split;
                        report.midpoints += 1;
                    }
                }
            }
            taken.extend(diagonals(&tris));
            report.cut += 1;
            tris.iter().for_each(|t| out.push_face(t));
        }
        (out, report)
    }

    /// Appends a vertex halfway between `a` and `b`, with their mean normal and colour; its index.
    fn push_midpoint(&mut self, a: u32, b: u32) -> u32 {
        let (a, b) = (a as usize, b as usize);
        self.vertices.push(Point3::from((self.vertices[a].coords + self.vertices[b].coords) / 2.0));
        if let Some(normals) = self.normals.as_mut() {
            let mean = (normals[a] + normals[b]).try_normalize(0.0).unwrap_or(normals[a]);
            normals.push(mean);
        }
        if let Some(colors) = self.colors.as_mut() {
            colors.push(std::array::from_fn(|c| ((colors[a][c] as u16 + colors[b][c] as u16) / 2) as u8));
        }
        self.vertices.len() as u32 - 1
    }
}

/// What [`PolyMesh::with_readable_faces`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ReadableCut {
    /// Faces cut into triangles (larger or non-convex faces, and convex quads no fan could take).
    pub cut: usize,
    /// Diagonals split at their midpoints by a new vertex, because every start repeated an edge.
    pub midpoints: usize,
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
        assert_eq!(cut, ReadableCut { cut: 2, midpoints: 0 });
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
        assert_eq!((count.cut, cut.face_count()), (1, 4));
        assert!(uses(&cut).values().all(|&n| n <= 2), "{:?}", cut.indices);
    }

    /// A convex quad both of whose diagonals are edges of neighbours: either fan would give an edge
    /// of three faces, so its diagonal is split at its midpoint into four triangles.
    #[test]
    fn a_quad_no_fan_can_cut_is_split_at_a_diagonal_midpoint() {
        let vertices = vec![
            Point3::new(0., 0., 0.),
            Point3::new(1., 0., 0.),
            Point3::new(1., 1., 0.),
            Point3::new(0., 1., 0.),
            Point3::new(0.5, 0.5, 1.0),
            Point3::new(0.5, 0.5, -1.0),
        ];
        let mut mesh = PolyMesh::from_faces(vertices, [vec![0, 1, 2, 3], vec![0, 2, 4], vec![1, 3, 5]]);
        mesh.normals = Some(vec![Vector3::z(); 6]);
        mesh.colors = Some(vec![[10, 20, 30], [30, 20, 10], [30, 20, 10], [30, 20, 10], [0; 3], [0; 3]]);
        let (out, report) = mesh.with_readable_faces();
        assert_eq!(report, ReadableCut { cut: 1, midpoints: 1 });
        assert_eq!(out.vertices.len(), 7);
        assert!((out.vertices[6] - Point3::new(0.5, 0.5, 0.0)).norm() < 1e-12);
        assert_eq!((out.normals.as_ref().unwrap()[6], out.colors.as_ref().unwrap()[6]), (Vector3::z(), [20, 20, 20]));
        let mut uses = std::collections::HashMap::new();
        for f in out.triangulate().faces {
            for k in 0..3 {
                *uses.entry(crate::mesh::edge_key(f[k], f[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        assert!(uses.values().all(|&n| n <= 2), "{uses:?}");
        // The four triangles keep the quad's orientation (+z) and area.
        let tris = &out.triangulate().faces[..4];
        let flat: Vec<Point3> = out.vertices.clone();
        let normals: Vec<Vector3> = tris
            .iter()
            .map(|t| (flat[t[1] as usize] - flat[t[0] as usize]).cross(&(flat[t[2] as usize] - flat[t[0] as usize])))
            .collect();
        assert!(normals.iter().all(|n| n.z > 0.0), "{normals:?}");
        assert!((normals.iter().map(|n| n.norm() / 2.0).sum::<Real>() - 1.0).abs() < 1e-12);
    }
}
