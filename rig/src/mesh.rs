//! Triangle meshes and polygon meshes (quads and n-gons).

use crate::math::{Point3, Real, Vector3};
use crate::point_cloud::Aabb;

/// A triangle mesh: shared vertices and faces as three vertex indices, counter-clockwise seen from
/// outside.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TriMesh {
    /// Vertex positions.
    pub vertices: Vec<Point3>,
    /// Triangles as vertex indices.
    pub faces: Vec<[u32; 3]>,
    /// Optional per-vertex unit normals.
    pub normals: Option<Vec<Vector3>>,
}

impl TriMesh {
    /// Each vertex's neighbours along edges (sorted, each once).
    pub fn vertex_neighbours(&self) -> Vec<Vec<u32>> {
        let mut n = vec![Vec::new(); self.vertices.len()];
        for f in &self.faces {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                n[a as usize].push(b);
                n[b as usize].push(a);
            }
        }
        for list in &mut n {
            list.sort_unstable();
            list.dedup();
        }
        n
    }

    /// The enclosed volume by the divergence theorem: positive for a closed mesh whose triangles face
    /// outward (counter-clockwise seen from outside), negative for inward-facing ones. Summed about the
    /// bounding box's centre (about the origin, a mesh 10⁷ away would lose its volume to rounding), in
    /// order (a record that keeps it reads the same bits from run to run).
    pub fn signed_volume(&self) -> Real {
        let Some(b) = self.bounding_box() else { return 0.0 };
        let centre = nalgebra::center(&b.min, &b.max);
        self.faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|i| self.vertices[i as usize] - centre);
                a.dot(&b.cross(&c)) / 6.0
            })
            .sum()
    }

    /// The axis-aligned bounding box, `None` without vertices.
    pub fn bounding_box(&self) -> Option<Aabb> {
        Aabb::of(&self.vertices)
    }

    /// Unit vertex normals: the area-weighted sum of the incident faces' normals (faces counter-clockwise
    /// seen from outside, so they point out); a vertex without area gets +z rather than NaN, which
    /// readers such as glTF viewers refuse.
    pub fn vertex_normals(&self) -> Vec<Vector3> {
        let mut n = vec![Vector3::zeros(); self.vertices.len()];
        for f in &self.faces {
            let [a, b, c] = f.map(|i| self.vertices[i as usize]);
            // Twice the area times the unit normal: the area weighting for free.
            let fn_ = (b - a).cross(&(c - a));
            f.iter().for_each(|&i| n[i as usize] += fn_);
        }
        n.into_iter().map(|v| v.try_normalize(1e-300).unwrap_or_else(Vector3::z)).collect()
    }

    /// This mesh as a polygon mesh.
    pub fn to_poly(&self) -> PolyMesh {
        PolyMesh {
            vertices: self.vertices.clone(),
            indices: self.faces.iter().flatten().copied().collect(),
            offsets: (0..=self.faces.len() as u32).map(|i| 3 * i).collect(),
            normals: self.normals.clone(),
            colors: None,
        }
    }
}

/// A polygon mesh: faces of any size (≥ 3) stored compactly: face `f` is
/// `indices[offsets[f]..offsets[f + 1]]`.
///
/// ```text
///   faces      [0 1 2] [2 1 3 4]          (a triangle and a quad)
///   indices    0 1 2 2 1 3 4
///   offsets    0     3       7
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct PolyMesh {
    /// Vertex positions.
    pub vertices: Vec<Point3>,
    /// All faces' vertex indices, one face after another.
    pub indices: Vec<u32>,
    /// Where each face starts in `indices`, plus a final end: `faces + 1` entries.
    pub offsets: Vec<u32>,
    /// Optional per-vertex unit normals.
    pub normals: Option<Vec<Vector3>>,
    /// Optional per-vertex 8-bit RGB colours.
    pub colors: Option<Vec<[u8; 3]>>,
}

impl Default for PolyMesh {
    fn default() -> Self {
        PolyMesh { vertices: Vec::new(), indices: Vec::new(), offsets: vec![0], normals: None, colors: None }
    }
}

/// An undirected edge: its two vertices, the smaller first.
pub fn edge_key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

impl PolyMesh {
    /// Builds a mesh from faces given as index lists.
    pub fn from_faces<F: AsRef<[u32]>>(vertices: Vec<Point3>, faces: impl IntoIterator<Item = F>) -> Self {
        let mut mesh = PolyMesh { vertices, ..Default::default() };
        for f in faces {
            mesh.push_face(f.as_ref());
        }
        mesh
    }

    /// Appends one face.
    pub fn push_face(&mut self, face: &[u32]) {
        self.indices.extend_from_slice(face);
        self.offsets.push(self.indices.len() as u32);
    }

    /// Number of faces.
    pub fn face_count(&self) -> usize {
        self.offsets.len() - 1
    }

    /// Face `f`'s vertex indices.
    pub fn face(&self, f: usize) -> &[u32] {
        &self.indices[self.offsets[f] as usize..self.offsets[f + 1] as usize]
    }

    /// All faces in order.
    pub fn faces(&self) -> impl ExactSizeIterator<Item = &[u32]> + '_ {
        self.offsets.windows(2).map(|w| &self.indices[w[0] as usize..w[1] as usize])
    }

    /// How many faces have each size: `(triangles, quads, larger)`.
    pub fn face_sizes(&self) -> FaceSizes {
        let mut s = FaceSizes::default();
        for f in self.faces() {
            match f.len() {
                3 => s.triangles += 1,
                4 => s.quads += 1,
                _ => s.larger += 1,
            }
        }
        s
    }

    /// Splits every face into a fan of triangles from its first corner (exact for convex faces).
    pub fn triangulate(&self) -> TriMesh {
        let mut faces = Vec::with_capacity(self.indices.len().saturating_sub(2 * self.face_count()));
        for f in self.faces() {
            for k in 1..f.len().saturating_sub(1) {
                faces.push([f[0], f[k], f[k + 1]]);
            }
        }
        TriMesh { vertices: self.vertices.clone(), faces, normals: self.normals.clone() }
    }

    /// Starts every polygon at a corner from which the fan [`PolyMesh::triangulate`] — and every reader
    /// that triangulates on load (Open3D, trimesh, MeshLab) — makes no diagonal that is already an edge of
    /// the mesh or another polygon's diagonal: such a diagonal would be shared by three or four triangles,
    /// a non-manifold edge. Faces are only rotated (orientation and geometry stay). Returns the number of
    /// polygons no rotation could clear, left as they were.
    pub fn rotate_faces_for_fans(&mut self) -> usize {
        let key = edge_key;
        let mut taken = self.edge_set();
        let mut stuck = 0;
        for fi in 0..self.face_count() {
            let (start, end) = (self.offsets[fi] as usize, self.offsets[fi + 1] as usize);
            let n = end - start;
            if n < 4 {
                continue;
            }
            let face = self.indices[start..end].to_vec();
            let face = &face;
            let diagonals = |r: usize| (2..n - 1).map(move |k| key(face[r], face[(r + k) % n]));
            match (0..n).find(|&r| diagonals(r).all(|d| !taken.contains(&d))) {
                Some(r) => {
                    taken.extend(diagonals(r));
                    self.indices[start..end].rotate_left(r);
                }
                None => stuck += 1,
            }
        }
        stuck
    }

    /// Every edge of the faces, each as [`edge_key`] spells it: what a new diagonal must not repeat
    /// (an edge of three faces).
    pub fn edge_set(&self) -> std::collections::HashSet<(u32, u32)> {
        self.faces().flat_map(|f| (0..f.len()).map(move |k| edge_key(f[k], f[(k + 1) % f.len()]))).collect()
    }

    /// The axis-aligned bounding box, `None` without vertices.
    pub fn bounding_box(&self) -> Option<Aabb> {
        Aabb::of(&self.vertices)
    }
}

/// Face counts by size.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FaceSizes {
    /// Faces with 3 corners.
    pub triangles: usize,
    /// Faces with 4 corners.
    pub quads: usize,
    /// Faces with 5 or more corners.
    pub larger: usize,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fan_triangulation_keeps_orientation() {
        let v = vec![Point3::origin(); 5];
        let m = PolyMesh::from_faces(v, [vec![0u32, 1, 2], vec![0, 1, 3, 4]]);
        assert_eq!(m.face_sizes(), FaceSizes { triangles: 1, quads: 1, larger: 0 });
        assert_eq!(m.triangulate().faces, vec![[0, 1, 2], [0, 1, 3], [0, 3, 4]]);
    }

    /// Two quads sharing the diagonal 0–2 (a quad's diagonal can also be a third face's edge): the fan
    /// from each first corner would give edge 0–2 four triangles. Rotating the second clears it.
    #[test]
    fn faces_are_rotated_so_that_fans_add_no_shared_diagonal() {
        let v = vec![Point3::origin(); 7];
        let mut m = PolyMesh::from_faces(v, [vec![0u32, 1, 2, 3], vec![0, 4, 2, 5], vec![2, 6, 0]]);
        let edges = |m: &PolyMesh| {
            let mut count = std::collections::HashMap::new();
            for f in m.triangulate().faces {
                for k in 0..3 {
                    *count.entry((f[k].min(f[(k + 1) % 3]), f[k].max(f[(k + 1) % 3]))).or_insert(0) += 1;
                }
            }
            count
        };
        assert_eq!(edges(&m)[&(0, 2)], 5);
        assert_eq!(m.rotate_faces_for_fans(), 0);
        assert!(edges(&m).values().all(|&c| c <= 2), "{:?}", edges(&m));
        assert_eq!(m.face(0), &[1, 2, 3, 0]);
        assert_eq!(m.face(1), &[4, 2, 5, 0]);
    }
}
