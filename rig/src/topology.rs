//! Whether a triangle mesh is a closed, consistently oriented 2-manifold, and its genus: what a
//! reconstruction promises and what downstream tools (remeshers, slicers, 3D printers) require.

use crate::TriMesh;
use crate::union_find::UnionFind;
use rayon::prelude::*;
use serde::Serialize;

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
///
/// Edges are found by sorting the faces' edge keys rather than in a hash map, and each vertex's link
/// is checked in parallel: on a 1.2 M-triangle reconstruction the map and the per-vertex link lists
/// had been half a second of serial work after every reconstruction.
pub fn topology(mesh: &TriMesh) -> Topology {
    let n = mesh.vertices.len();
    // Each face edge as (min << 32 | max, +1 when traversed min → max, −1 the other way).
    let mut keyed: Vec<(u64, i32)> = mesh
        .faces
        .par_iter()
        .flat_map_iter(|f| {
            (0..3).map(move |k| {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                ((a.min(b) as u64) << 32 | a.max(b) as u64, if a < b { 1 } else { -1 })
            })
        })
        .collect();
    keyed.par_sort_unstable_by_key(|e| e.0);
    let mut t = Topology { faces: mesh.faces.len(), ..Default::default() };
    let mut sets = UnionFind::new(n);
    let mut used = vec![false; n];
    for run in keyed.chunk_by(|x, y| x.0 == y.0) {
        t.edges += 1;
        let dir: i32 = run.iter().map(|e| e.1).sum();
        match run.len() {
            1 => t.boundary_edges += 1,
            2 if dir != 0 => t.misoriented_edges += 1,
            2 => {}
            _ => t.non_manifold_edges += 1,
        }
        // Components by union–find over faces sharing vertices would merge sheets touching at a
        // vertex; over vertices joined by edges it counts the surface's pieces.
        let (a, b) = ((run[0].0 >> 32) as usize, (run[0].0 & u32::MAX as u64) as usize);
        used[a] = true;
        used[b] = true;
        sets.union(a, b);
    }
    drop(keyed);
    t.vertices = used.iter().filter(|&&u| u).count();
    t.components = (0..n).filter(|&i| used[i] && sets.find(i) == i).count();
    // A manifold vertex's faces form one fan: the edges opposite it (the link) are one cycle or path.
    // The links side by side (a vertex's at starts[v]..starts[v + 1]), then their pieces counted with
    // a small union–find over each vertex's neighbours.
    let mut starts = vec![0usize; n + 1];
    for f in &mesh.faces {
        for &v in f {
            starts[v as usize + 1] += 1;
        }
    }
    for v in 0..n {
        starts[v + 1] += starts[v];
    }
    let mut next = starts.clone();
    let mut link = vec![(0u32, 0u32); starts[n]];
    for f in &mesh.faces {
        for k in 0..3 {
            let v = f[k] as usize;
            link[next[v]] = (f[(k + 1) % 3], f[(k + 2) % 3]);
            next[v] += 1;
        }
    }
    t.non_manifold_vertices = (0..n)
        .into_par_iter()
        .with_min_len(4096)
        .filter(|&v| {
            let l = &link[starts[v]..starts[v + 1]];
            if l.is_empty() {
                return false;
            }
            let mut ids: Vec<u32> = l.iter().flat_map(|&(a, b)| [a, b]).collect();
            ids.sort_unstable();
            ids.dedup();
            let mut pieces_of = UnionFind::new(ids.len());
            let at = |v: u32| ids.binary_search(&v).unwrap_or(0);
            for &(a, b) in l {
                pieces_of.union(at(a), at(b));
            }
            (0..ids.len()).filter(|&i| pieces_of.find(i) == i).count() > 1
        })
        .count();
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

    /// The counts as first written: edges in a hash map, a link list per vertex. The sorted version
    /// must agree on any face soup, degenerate faces and unused vertices included.
    fn reference(mesh: &TriMesh) -> Topology {
        use std::collections::HashMap;
        let mut edges: HashMap<(u32, u32), (u32, i32)> = HashMap::new();
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
            for &(a, b) in l {
                pieces_of.union(ids.binary_search(&a).unwrap(), ids.binary_search(&b).unwrap());
            }
            if (0..ids.len()).filter(|&i| pieces_of.find(i) == i).count() > 1 {
                t.non_manifold_vertices += 1;
            }
        }
        t
    }

    proptest::proptest! {
        #[test]
        fn sorted_edges_count_as_the_hash_map_did(
            vertices in 1usize..12,
            faces in proptest::collection::vec((0u32..12, 0u32..12, 0u32..12), 0..40),
        ) {
            let n = vertices as u32;
            let mesh = TriMesh {
                vertices: vec![Point3::origin(); vertices],
                faces: faces.iter().map(|&(a, b, c)| [a % n, b % n, c % n]).collect(),
                normals: None,
            };
            proptest::prop_assert_eq!(topology(&mesh), reference(&mesh));
        }
    }
}
