//! The half-split of fig. 6.5: where a constraint line turns inside one triangle, two of its edges
//! are constrained and eq. 6.3 forces all three corners to one value, flattening the field there. Such
//! faces get their third edge split at its midpoint (in both faces of that edge), so the corner between
//! the constrained edges is no longer a whole face and the new vertex stays free.

use rig::TriMesh;
use rig::math::Point3;
use std::collections::{HashMap, HashSet};

/// Splits the third edge of every face that has exactly two edges in `constrained` (pairs `(a, b)`
/// with `a < b`). Returns the new mesh, how many edges were split, and each new face's face in the
/// input (for carrying per-face data over); old vertex indices are kept.
pub fn split_doubly_constrained(mesh: &TriMesh, constrained: &HashSet<(u32, u32)>) -> (TriMesh, usize, Vec<usize>) {
    let key = |a: u32, b: u32| (a.min(b), a.max(b));
    let mut marked: HashSet<(u32, u32)> = HashSet::new();
    for f in &mesh.faces {
        let edges = [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])];
        let hit: Vec<bool> = edges.iter().map(|&(a, b)| constrained.contains(&key(a, b))).collect();
        if hit.iter().filter(|&&h| h).count() == 2 {
            let k = hit.iter().position(|&h| !h).expect("one edge is free");
            marked.insert(key(edges[k].0, edges[k].1));
        }
    }
    let mut out = TriMesh { vertices: mesh.vertices.clone(), faces: Vec::new(), normals: None };
    let mut midpoint: HashMap<(u32, u32), u32> = HashMap::new();
    let mut mid = |a: u32, b: u32, out: &mut TriMesh| -> u32 {
        *midpoint.entry(key(a, b)).or_insert_with(|| {
            let (p, q) = (out.vertices[a as usize], out.vertices[b as usize]);
            out.vertices.push(Point3::from((p.coords + q.coords) / 2.0));
            out.vertices.len() as u32 - 1
        })
    };
    let mut parent = Vec::with_capacity(mesh.faces.len());
    let mut stack: Vec<([u32; 3], usize)> = mesh.faces.iter().copied().enumerate().rev().map(|(i, f)| (f, i)).collect();
    while let Some((f, from)) = stack.pop() {
        // Split at the first marked edge; the children hold the face's other edges whole.
        match (0..3).find(|&k| marked.contains(&key(f[k], f[(k + 1) % 3]))) {
            None => {
                out.faces.push(f);
                parent.push(from);
            }
            Some(k) => {
                let (a, b, c) = (f[k], f[(k + 1) % 3], f[(k + 2) % 3]);
                let m = mid(a, b, &mut out);
                stack.push(([m, b, c], from));
                stack.push(([a, m, c], from));
            }
        }
    }
    (out, marked.len(), parent)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_corner_between_two_constrained_edges_is_split_in_both_faces() {
        // Two triangles sharing the diagonal 1–2 of a unit square; the line 1 → 0 → 2 constrains two
        // edges of face [0, 1, 2].
        let m = TriMesh {
            vertices: vec![
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(0.0, 1.0, 0.0),
                Point3::new(1.0, 1.0, 0.0),
            ],
            faces: vec![[0, 1, 2], [1, 3, 2]],
            normals: None,
        };
        let constrained: HashSet<(u32, u32)> = [(0, 1), (0, 2)].into_iter().collect();
        let (split, n, parent) = split_doubly_constrained(&m, &constrained);
        assert_eq!(n, 1);
        assert_eq!(split.faces.len(), 4);
        assert_eq!(parent, vec![0, 0, 1, 1]);
        assert_eq!(split.vertices[4], Point3::new(0.5, 0.5, 0.0));
        // Orientation and area are kept, and no face has two constrained edges any more.
        let area = |t: &TriMesh| -> f64 {
            t.faces
                .iter()
                .map(|f| {
                    let [a, b, c] = f.map(|i| t.vertices[i as usize]);
                    (b - a).cross(&(c - a)).z / 2.0
                })
                .sum()
        };
        assert!((area(&split) - area(&m)).abs() < 1e-12 && area(&split) > 0.0);
        for f in &split.faces {
            let hits = [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])]
                .iter()
                .filter(|&&(a, b)| constrained.contains(&(a.min(b), a.max(b))))
                .count();
            assert!(hits < 2, "{f:?}");
        }
    }
}
