//! Whether a triangle mesh is a closed, consistently oriented 2-manifold, and its genus: what a
//! reconstruction promises and what downstream tools (remeshers, slicers, 3D printers) require.

use crate::TriMesh;
use crate::union_find::UnionFind;
use serde::Serialize;
use std::collections::HashMap;

/// Edge and vertex counts that decide watertightness, manifoldness and orientation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct Topology {
    /// Vertices referenced by a face.
    pub vertices: usize,
    /// Undirected edges.
    pub edges: usize,
    /// Faces (triangles), degenerate ones included.
    pub faces: usize,
    /// Edges with one face: holes.
    pub boundary_edges: usize,
    /// Edges with three or more faces.
    pub non_manifold_edges: usize,
    /// Edges whose two faces traverse them in the same direction (orientation flips).
    pub misoriented_edges: usize,
    /// Vertices whose faces form more than one fan (two sheets touching at a point).
    pub non_manifold_vertices: usize,
    /// Connected components (through shared edges).
    pub components: usize,
}

impl Topology {
    /// V − E + F over the referenced vertices.
    pub fn euler(&self) -> i64 {
        self.vertices as i64 - self.edges as i64 + self.faces as i64
    }

    /// Closed, manifold at every edge and vertex, and consistently oriented.
    pub fn is_closed_oriented_manifold(&self) -> bool {
        self.boundary_edges == 0
            && self.non_manifold_edges == 0
            && self.misoriented_edges == 0
            && self.non_manifold_vertices == 0
    }

    /// The total genus of a closed oriented manifold: Σ over components of (2 − χ_c)/2, which is
    /// (2·components − χ)/2. `None` when the mesh is not one.
    pub fn genus(&self) -> Option<i64> {
        self.is_closed_oriented_manifold().then(|| (2 * self.components as i64 - self.euler()) / 2)
    }
}

/// Counts everything in [`Topology`] for a triangle mesh.
pub fn topology(mesh: &TriMesh) -> Topology {
    // Per undirected edge: (faces, +1 per a→b traversal with a < b, −1 per b→a).
    let mut edges: HashMap<(u32, u32), (u32, i32)> = HashMap::with_capacity(mesh.faces.len() * 3 / 2);
    for f in &mesh.faces {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            let e = edges.entry((a.min(b), a.max(b))).or_default();
            e.0 += 1;
            e.1 += if a < b { 1 } else { -1 };
        }
    }
    let mut t = Topology { faces: mesh.faces.len(), edges: edges.len(), ..Default::default() };
    for &(n, dir) in edges.values() {
        match n {
            1 => t.boundary_edges += 1,
            2 if dir != 0 => t.misoriented_edges += 1,
            2 => {}
            _ => t.non_manifold_edges += 1,
        }
    }
    // Components by union–find over faces sharing vertices would merge sheets touching at a vertex;
    // over vertices joined by edges it counts the surface's pieces.
    let n = mesh.vertices.len();
    let mut sets = UnionFind::new(n);
    let mut used = vec![false; n];
    for &(a, b) in edges.keys() {
        used[a as usize] = true;
        used[b as usize] = true;
        sets.union(a as usize, b as usize);
    }
    t.vertices = used.iter().filter(|&&u| u).count();
    t.components = (0..n).filter(|&i| used[i] && sets.find(i) == i).count();
    // A manifold vertex's faces form one fan: the edges opposite it (the link) are one cycle or path.
    // Count the link's pieces per vertex with a small union–find over its neighbours.
    let mut link: Vec<Vec<(u32, u32)>> = vec![Vec::new(); n];
    for f in &mesh.faces {
        for k in 0..3 {
            link[f[k] as usize].push((f[(k + 1) % 3], f[(k + 2) % 3]));
        }
    }
    for l in link.iter().filter(|l| !l.is_empty()) {
        let mut ids: Vec<u32> = l.iter().flat_map(|&(a, b)| [a, b]).collect();
        ids.sort_unstable();
        ids.dedup();
        let mut pieces_of = UnionFind::new(ids.len());
        let at = |v: u32| ids.binary_search(&v).expect("in link");
        for &(a, b) in l {
            pieces_of.union(at(a), at(b));
        }
        let pieces = (0..ids.len()).filter(|&i| pieces_of.find(i) == i).count();
        if pieces > 1 {
            t.non_manifold_vertices += 1;
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Point3;

    fn tetrahedron() -> TriMesh {
        let v = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(0.0, 0.0, 1.0),
        ];
        TriMesh { vertices: v, faces: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], normals: None }
    }

    #[test]
    fn a_tetrahedron_is_a_closed_sphere() {
        let t = topology(&tetrahedron());
        assert_eq!((t.vertices, t.edges, t.faces, t.euler(), t.components), (4, 6, 4, 2, 1));
        assert_eq!(t.genus(), Some(0));
    }

    #[test]
    fn holes_flips_and_pinches_are_counted() {
        let mut m = tetrahedron();
        m.faces.pop();
        assert_eq!(topology(&m).boundary_edges, 3);
        let mut m = tetrahedron();
        m.faces[3] = [1, 3, 2];
        assert_eq!(topology(&m).misoriented_edges, 3);
        // Two tetrahedra sharing one vertex: closed and oriented at every edge, pinched at the vertex.
        let mut m = tetrahedron();
        let offset = m.vertices.len() as u32 - 1;
        for p in [Point3::new(-1.0, 0.0, 0.0), Point3::new(0.0, -1.0, 0.0), Point3::new(0.0, 0.0, -1.0)] {
            m.vertices.push(p);
        }
        let remap = |i: u32| if i == 0 { 0 } else { i + offset };
        for f in tetrahedron().faces {
            m.faces.push([remap(f[0]), remap(f[2]), remap(f[1])]);
        }
        let t = topology(&m);
        assert_eq!((t.boundary_edges, t.misoriented_edges, t.non_manifold_vertices), (0, 0, 1));
        assert_eq!(t.genus(), None);
    }
}
