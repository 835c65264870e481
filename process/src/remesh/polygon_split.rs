//! Splitting the n-gons the streamline graph leaves (at T-junctions, where a line ended on another,
//! and around singularities) into quads and at most one triangle each, so the result is a quad-
//! dominant mesh that tri/quad tools accept. Each cut takes the most rectangular run of four
//! consecutive corners; a cut that would duplicate an existing edge or make a reflex corner is not
//! taken, and a polygon with no good cut stays as it is.

use rig::PolyMesh;
use rig::math::Real;
use std::collections::HashSet;

/// How many polygons were split and into how many faces.
#[derive(Debug, Clone, Copy, Default, serde::Serialize, serde::Deserialize)]
pub struct SplitStats {
    /// Polygons of five or more corners before splitting.
    pub polygons: usize,
    /// Of those, how many were split.
    pub split: usize,
    /// Faces cut into triangles afterwards so other tools can read them: polygons the split left,
    /// non-convex quads, and convex quads whose both diagonals are edges already ([`rig::PolyMesh::with_readable_faces`]).
    #[serde(default)]
    pub cut_for_readers: usize,
    /// Of those cuts' diagonals, how many were split at their midpoints by a new vertex because
    /// every way of cutting the face repeated an edge of the mesh (an edge of three faces).
    #[serde(default)]
    pub midpoints_for_readers: usize,
}

/// The sum of |corner angle − 90°| of a quad, in degrees; `None` if a corner is reflex-like
/// (beyond 170°) or degenerate, or the quad folds (its two triangulations' normals differ by more
/// than 25°: the cut would leave the surface).
fn quad_error(m: &PolyMesh, q: [u32; 4]) -> Option<Real> {
    let p = q.map(|i| m.vertices[i as usize]);
    for k in 0..2 {
        let (a, b, c, d) = (p[k], p[k + 1], p[(k + 2) % 4], p[(k + 3) % 4]);
        let (n1, n2) = ((b - a).cross(&(c - a)), (c - a).cross(&(d - a)));
        if n1.norm() == 0.0 || n2.norm() == 0.0 || n1.angle(&n2) > 25f64.to_radians() {
            return None;
        }
    }
    let mut sum = 0.0;
    for k in 0..4 {
        let p = m.vertices[q[k] as usize];
        let (a, b) = (m.vertices[q[(k + 3) % 4] as usize] - p, m.vertices[q[(k + 1) % 4] as usize] - p);
        if a.norm() == 0.0 || b.norm() == 0.0 {
            return None;
        }
        let angle = a.angle(&b).to_degrees();
        if angle > 170.0 {
            return None;
        }
        sum += (angle - 90.0).abs();
    }
    Some(sum)
}

/// Splits every face of five or more corners (see the module notes).
pub fn split_polygons(mesh: &PolyMesh) -> (PolyMesh, SplitStats) {
    let mut stats = SplitStats::default();
    let mut edges: HashSet<(u32, u32)> = HashSet::new();
    for f in mesh.faces() {
        for k in 0..f.len() {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            edges.insert((a.min(b), a.max(b)));
        }
    }
    let mut out = PolyMesh { vertices: mesh.vertices.clone(), normals: mesh.normals.clone(), ..Default::default() };
    for f in mesh.faces() {
        if f.len() < 5 {
            out.push_face(f);
            continue;
        }
        stats.polygons += 1;
        let mut rest: Vec<u32> = f.to_vec();
        let mut pieces: Vec<Vec<u32>> = Vec::new();
        while rest.len() >= 5 {
            let n = rest.len();
            let best = (0..n)
                .filter_map(|i| {
                    let q = [rest[i], rest[(i + 1) % n], rest[(i + 2) % n], rest[(i + 3) % n]];
                    let cut = (q[0].min(q[3]), q[0].max(q[3]));
                    if edges.contains(&cut) || q[0] == q[3] {
                        return None;
                    }
                    // The remainder must stay a proper polygon: its new corners not reflex-like.
                    quad_error(mesh, q).map(|e| (e, i))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let Some((_, i)) = best else { break };
            let q: Vec<u32> = (0..4).map(|k| rest[(i + k) % n]).collect();
            edges.insert((q[0].min(q[3]), q[0].max(q[3])));
            // Drop the two inner corners of the cut quad from the remainder.
            let (r1, r2) = ((i + 1) % n, (i + 2) % n);
            rest = (0..n).filter(|&k| k != r1 && k != r2).map(|k| rest[k]).collect();
            pieces.push(q);
        }
        if pieces.is_empty() {
            out.push_face(f);
            continue;
        }
        stats.split += 1;
        pieces.push(rest);
        for p in pieces {
            out.push_face(&p);
        }
    }
    (out, stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::math::Point3;

    #[test]
    fn a_hexagon_of_two_squares_becomes_two_quads_and_a_t_pentagon_a_quad_and_a_triangle() {
        // A 2 × 1 rectangle with corners and mid-points of the long sides: a hexagon.
        let v = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(2.0, 0.0, 0.0),
            Point3::new(2.0, 1.0, 0.0),
            Point3::new(1.0, 1.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
        ];
        let hex = PolyMesh::from_faces(v.clone(), [vec![0u32, 1, 2, 3, 4, 5]]);
        let (out, stats) = split_polygons(&hex);
        assert_eq!(stats.split, 1);
        assert_eq!(out.face_sizes().quads, 2, "{:?}", out.faces().collect::<Vec<_>>());
        // The same without the top mid-point: a pentagon with a straight corner at 1.
        let pent = PolyMesh::from_faces(v, [vec![0u32, 1, 2, 3, 5]]);
        let (out, _) = split_polygons(&pent);
        let sizes = out.face_sizes();
        assert_eq!((sizes.quads, sizes.triangles), (1, 1));
        // Every original edge is still used once, and the cut once from each side.
        let mut uses = std::collections::HashMap::new();
        for f in out.faces() {
            for k in 0..f.len() {
                *uses.entry((f[k].min(f[(k + 1) % f.len()]), f[k].max(f[(k + 1) % f.len()]))).or_insert(0) += 1;
            }
        }
        assert_eq!(uses.values().filter(|&&n| n == 2).count(), 1);
        assert_eq!(uses.len(), 6);
    }
}
