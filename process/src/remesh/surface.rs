//! What streamline tracing needs to know about a triangle mesh: which face lies across each edge,
//! the faces around each vertex in order, each face's unit normal and the gradients of its barycentric
//! coordinates. Positions on the surface are a face and barycentric coordinates, so crossing an edge
//! hands the two shared coordinates over exactly instead of re-locating a 3D point.
//!
//! Conventions: edge `k` of a face is the one opposite its corner `k`, from corner `k+1` to `k+2`
//! (counter-clockwise about the normal, so the face's interior is on its left).

use rig::TriMesh;
use rig::math::{Point3, Real, Vector3};
use std::collections::HashMap;

/// No face: across a boundary edge.
pub const NONE: u32 = u32::MAX;

/// A point on the surface: a face and its barycentric coordinates there (non-negative, summing to 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// The face.
    pub face: u32,
    /// Weights of the face's three corners.
    pub bary: [Real; 3],
}

/// Connectivity and per-face geometry of a triangle mesh.
pub struct Surface<'a> {
    /// The mesh.
    pub mesh: &'a TriMesh,
    /// Per face and edge `k`: the face across it and that face's index for the same edge.
    neighbour: Vec<[(u32, u8); 3]>,
    /// Per vertex, the corners `(face, k)` that sit on it, in CSR layout.
    corner_start: Vec<u32>,
    corners: Vec<(u32, u8)>,
    /// Unit normal per face (zero for degenerate faces).
    pub normal: Vec<Vector3>,
    /// Per face, the gradients of its three barycentric coordinates (zero for degenerate faces).
    pub grad_bary: Vec<[Vector3; 3]>,
    /// Twice each face's area.
    pub area2: Vec<Real>,
}

impl<'a> Surface<'a> {
    /// Builds the tables; edges shared by more than two faces are treated as boundaries.
    pub fn new(mesh: &'a TriMesh) -> Self {
        let nf = mesh.faces.len();
        let mut neighbour = vec![[(NONE, 0u8); 3]; nf];
        let mut by_edge: HashMap<(u32, u32), Vec<(u32, u8)>> = HashMap::with_capacity(nf * 3 / 2);
        for (f, face) in mesh.faces.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (face[(k + 1) % 3], face[(k + 2) % 3]);
                by_edge.entry((a.min(b), a.max(b))).or_default().push((f as u32, k as u8));
            }
        }
        for sides in by_edge.values() {
            if let [(f, k), (g, l)] = sides[..] {
                neighbour[f as usize][k as usize] = (g, l);
                neighbour[g as usize][l as usize] = (f, k);
            }
        }
        let nv = mesh.vertices.len();
        let mut corner_start = vec![0u32; nv + 1];
        for face in &mesh.faces {
            for &v in face {
                corner_start[v as usize + 1] += 1;
            }
        }
        for v in 0..nv {
            corner_start[v + 1] += corner_start[v];
        }
        let mut fill = corner_start.clone();
        let mut corners = vec![(0u32, 0u8); corner_start[nv] as usize];
        for (f, face) in mesh.faces.iter().enumerate() {
            for (k, &v) in face.iter().enumerate() {
                corners[fill[v as usize] as usize] = (f as u32, k as u8);
                fill[v as usize] += 1;
            }
        }
        let mut normal = Vec::with_capacity(nf);
        let mut grad_bary = Vec::with_capacity(nf);
        let mut area2 = Vec::with_capacity(nf);
        for face in &mesh.faces {
            let p = face.map(|i| mesh.vertices[i as usize]);
            let n = (p[1] - p[0]).cross(&(p[2] - p[0]));
            let a2 = n.norm();
            area2.push(a2);
            if a2 <= 0.0 || !a2.is_finite() {
                normal.push(Vector3::zeros());
                grad_bary.push([Vector3::zeros(); 3]);
                continue;
            }
            let nu = n / a2;
            normal.push(nu);
            // ∇λ_k = n̂ × e_k / 2A with e_k the edge opposite corner k, as in eq. 6.1.
            grad_bary.push(std::array::from_fn(|k| nu.cross(&(p[(k + 2) % 3] - p[(k + 1) % 3])) / a2));
        }
        Surface { mesh, neighbour, corner_start, corners, normal, grad_bary, area2 }
    }

    /// The face across edge `k` of face `f` and that face's index for the edge, `None` at a boundary.
    pub fn across(&self, f: u32, k: usize) -> Option<(u32, usize)> {
        let (g, l) = self.neighbour[f as usize][k];
        (g != NONE).then_some((g, l as usize))
    }

    /// The corners `(face, k)` on vertex `v`, in no particular order.
    pub fn corners_of(&self, v: u32) -> &[(u32, u8)] {
        &self.corners[self.corner_start[v as usize] as usize..self.corner_start[v as usize + 1] as usize]
    }

    /// The corners on vertex `v` in counter-clockwise order (each face's next corner is the previous
    /// face's last), and whether they close into a full disc; `None` for non-manifold fans.
    pub fn fan(&self, v: u32) -> Option<(Vec<(u32, u8)>, bool)> {
        let corners = self.corners_of(v);
        if corners.is_empty() {
            return None;
        }
        // Walking counter-clockwise: from corner (f, k), the next face is the one across the edge
        // from v to corner k+2, i.e. edge k+1 of f.
        let corner_in = |g: u32| -> Option<(u32, u8)> {
            let face = self.mesh.faces[g as usize];
            (0..3).find(|&c| face[c] == v).map(|c| (g, c as u8))
        };
        // Corner (f, k) spans v → corner k+1 → corner k+2; the face across edge k+1 (v to corner k+2)
        // comes next, the one across edge k+2 (v to corner k+1) before.
        let step = |(f, k): (u32, u8)| self.across(f, (k as usize + 1) % 3).and_then(|(g, _)| corner_in(g));
        let back = |(f, k): (u32, u8)| self.across(f, (k as usize + 2) % 3).and_then(|(g, _)| corner_in(g));
        // Rewind to the first face of an open fan.
        let mut first = corners[0];
        for _ in 0..corners.len() {
            match back(first) {
                Some(c) if c != corners[0] => first = c,
                Some(_) => break,
                None => break,
            }
        }
        let mut order = vec![first];
        let mut closed = false;
        while let Some(next) = step(*order.last().expect("non-empty")) {
            if next == first {
                closed = true;
                break;
            }
            if order.len() >= corners.len() {
                return None;
            }
            order.push(next);
        }
        (order.len() == corners.len()).then_some((order, closed))
    }

    /// For a segment `a b` along an edge of face `f` (both ends on its corners), the face across
    /// that edge.
    pub fn face_across_segment(&self, f: u32, a: &Point3, b: &Point3) -> Option<u32> {
        let face = self.mesh.faces[f as usize];
        let corner = |p: &Point3| (0..3).find(|&c| self.mesh.vertices[face[c] as usize] == *p);
        let (ca, cb) = (corner(a)?, corner(b)?);
        if ca == cb {
            return None;
        }
        self.across(f, 3 - ca - cb).map(|(g, _)| g)
    }

    /// The 3D position of a surface point.
    pub fn position(&self, p: &SurfacePoint) -> Point3 {
        let f = self.mesh.faces[p.face as usize];
        let v = f.map(|i| self.mesh.vertices[i as usize].coords);
        Point3::from(v[0] * p.bary[0] + v[1] * p.bary[1] + v[2] * p.bary[2])
    }

    /// Barycentric velocity of moving along `d` in face `f`: how fast each coordinate changes.
    pub fn velocity(&self, f: u32, d: &Vector3) -> [Real; 3] {
        self.grad_bary[f as usize].map(|g| g.dot(d))
    }

    /// `p`'s coordinates handed over to the face across edge `k` (where `p.bary[k] == 0`).
    pub fn hand_over(&self, p: &SurfacePoint, k: usize) -> Option<SurfacePoint> {
        let (g, _) = self.across(p.face, k)?;
        let from = self.mesh.faces[p.face as usize];
        let to = self.mesh.faces[g as usize];
        let mut bary = [0.0; 3];
        for c in [(k + 1) % 3, (k + 2) % 3] {
            let j = (0..3).find(|&j| to[j] == from[c])?;
            bary[j] = p.bary[c];
        }
        Some(SurfacePoint { face: g, bary })
    }

    /// The surface point of face `f` closest to `q` (projected, then clamped into the triangle).
    pub fn locate_in(&self, f: u32, q: &Point3) -> SurfacePoint {
        let face = self.mesh.faces[f as usize];
        let p0 = self.mesh.vertices[face[0] as usize];
        let g = &self.grad_bary[f as usize];
        let d = q - p0;
        let mut b = [1.0 - g[1].dot(&d) - g[2].dot(&d), g[1].dot(&d), g[2].dot(&d)];
        if !b.iter().all(|x| x.is_finite()) {
            b = [1.0 / 3.0; 3];
        }
        for x in &mut b {
            *x = x.max(0.0);
        }
        let s: Real = b.iter().sum();
        SurfacePoint { face: f, bary: if s > 0.0 { b.map(|x| x / s) } else { [1.0 / 3.0; 3] } }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetrahedron() -> TriMesh {
        TriMesh {
            vertices: vec![
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(0.0, 1.0, 0.0),
                Point3::new(0.0, 0.0, 1.0),
            ],
            faces: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
            normals: None,
        }
    }

    #[test]
    fn neighbours_fans_and_hand_over_agree() {
        let m = tetrahedron();
        let s = Surface::new(&m);
        for f in 0..4u32 {
            for k in 0..3 {
                let (g, l) = s.across(f, k).expect("closed");
                assert_eq!(s.across(g, l), Some((f, k)));
            }
        }
        for v in 0..4 {
            let (fan, closed) = s.fan(v).expect("manifold");
            assert!(closed);
            assert_eq!(fan.len(), 3);
        }
        // A point on edge 0 of face 0 keeps its 3D position when handed over.
        let p = SurfacePoint { face: 0, bary: [0.0, 0.3, 0.7] };
        let q = s.hand_over(&p, 0).expect("interior edge");
        assert!((s.position(&p) - s.position(&q)).norm() < 1e-12);
        // Barycentric gradients: moving along an edge changes its two ends' weights oppositely.
        let v = s.velocity(0, &(m.vertices[2] - m.vertices[0]));
        assert!((v[0] + 1.0).abs() < 1e-12 && (v[1] - 1.0).abs() < 1e-12 && v[2].abs() < 1e-12);
        let located = s.locate_in(2, &Point3::new(0.2, 0.3, 0.5));
        assert!((s.position(&located) - Point3::new(0.2, 0.3, 0.5)).norm() < 1e-12);
    }
}
