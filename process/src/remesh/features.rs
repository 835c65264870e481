//! Feature lines: the mesh edges where the surface folds (dihedral angle above a threshold), used as
//! line constraints (eq. 6.3) so quads follow creases. Boundary edges and non-manifold edges are not
//! features (they have no dihedral angle, or no single one).

use super::edge_faces::EdgeFaces;
use rig::TriMesh;
use rig::math::Real;
use std::collections::HashMap;

/// The edges `(a, b)` with `a < b` whose two faces' normals differ by more than `min_angle_deg`.
pub fn feature_edges(mesh: &TriMesh, min_angle_deg: Real) -> Vec<(usize, usize)> {
    let normal = |f: u32| {
        let [a, b, c] = mesh.faces[f as usize].map(|i| mesh.vertices[i as usize]);
        (b - a).cross(&(c - a)).normalize()
    };
    let cos_limit = min_angle_deg.to_radians().cos();
    let mut edges: Vec<(usize, usize)> = EdgeFaces::new(mesh)
        .edges()
        .filter(|(_, fs)| {
            let &[f, g] = *fs else { return false };
            let (n0, n1) = (normal(f), normal(g));
            n0.iter().all(|c| c.is_finite()) && n1.iter().all(|c| c.is_finite()) && n0.dot(&n1) < cos_limit
        })
        .map(|(e, _)| e)
        .collect();
    edges.sort_unstable();
    edges
}

/// Chains edges into polylines (vertex paths): a path runs until a vertex where it cannot continue
/// uniquely (an end, or a junction of three or more feature edges); closed loops come back to their
/// start.
pub fn chain(edges: &[(usize, usize)]) -> Vec<Vec<usize>> {
    let mut adjacent: HashMap<usize, Vec<usize>> = HashMap::new();
    for &(a, b) in edges {
        adjacent.entry(a).or_default().push(b);
        adjacent.entry(b).or_default().push(a);
    }
    let key = |a: usize, b: usize| (a.min(b), a.max(b));
    let mut used: std::collections::HashSet<(usize, usize)> = Default::default();
    let mut lines = Vec::new();
    // Paths start at ends and junctions first, then whatever is left is loops.
    let mut starts: Vec<usize> = adjacent.iter().filter(|(_, n)| n.len() != 2).map(|(v, _)| *v).collect();
    starts.sort_unstable();
    let mut loop_starts: Vec<usize> = adjacent.keys().copied().collect();
    loop_starts.sort_unstable();
    for start in starts.into_iter().chain(loop_starts) {
        for &next in &adjacent[&start] {
            if used.contains(&key(start, next)) {
                continue;
            }
            let mut path = vec![start, next];
            used.insert(key(start, next));
            let mut cur = next;
            while adjacent[&cur].len() == 2 && cur != start {
                let Some(&n) = adjacent[&cur].iter().find(|&&n| !used.contains(&key(cur, n))) else { break };
                used.insert(key(cur, n));
                path.push(n);
                cur = n;
            }
            lines.push(path);
        }
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::math::Point3;

    /// A closed box of 12 triangles.
    fn cube() -> TriMesh {
        let v: Vec<Point3> =
            (0..8).map(|c| Point3::new((c & 1) as Real, (c >> 1 & 1) as Real, (c >> 2 & 1) as Real)).collect();
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let faces = quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
        TriMesh { vertices: v, faces, normals: None }
    }

    #[test]
    fn a_cube_has_twelve_feature_edges_in_loops_and_paths() {
        let m = cube();
        assert!(m.signed_volume() > 0.0);
        // The 12 box edges fold by 90°; the 6 face diagonals are flat.
        let edges = feature_edges(&m, 30.0);
        assert_eq!(edges.len(), 12, "{edges:?}");
        assert!(feature_edges(&m, 95.0).is_empty());
        // Every corner joins three features: chaining gives 12 one-edge paths between junctions.
        let lines = chain(&edges);
        assert_eq!(lines.iter().map(|l| l.len() - 1).sum::<usize>(), 12);
        assert!(lines.iter().all(|l| l.len() == 2));
    }

    #[test]
    fn a_ring_chains_into_one_loop() {
        let edges: Vec<(usize, usize)> = (0..6).map(|i| (i, (i + 1) % 6)).collect();
        let lines = chain(&edges);
        assert_eq!(lines.len(), 1);
        assert_eq!(lines[0].len(), 7);
        assert_eq!(lines[0].first(), lines[0].last());
    }
}
