//! Trimming what the reconstruction made up: surface far from every sample.
//!
//! A watertight reconstruction covers the whole object, also where no sensor looked (a deep cavity, the
//! gap a laser scan leaves between its lines); there the surface is the solve's guess. Users of
//! screened Poisson know this as "trim by density". Here a triangle goes when its centre lies farther
//! than a threshold from the nearest sample of the cloud it was made from. What is left is kept a
//! manifold: a vertex where two separate fans of triangles now meet is split in two, so every vertex has
//! one fan. On request each hole is closed again by a fan from its centre, so the mesh stays closed
//! (and flat-ish where the guess was).

use crate::kd_tree::PointTree;
use rayon::prelude::*;
use rig::TriMesh;
use rig::math::{Point3, Real};
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, HashSet};

/// What trimming did.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct TrimReport {
    /// The threshold (the mesh's units).
    pub max_distance: Real,
    /// Triangles removed.
    pub removed: usize,
    /// Vertices split because two fans met there.
    pub split_vertices: usize,
    /// Holes (boundary loops) after trimming.
    pub holes: usize,
    /// Triangles added to close them (0 unless asked).
    pub fill_triangles: usize,
}

/// Removes the triangles whose centre is farther than `max_distance` from every point of `samples`
/// (but never one lying wholly at or below z = `keep_below`: the base cut at the platter, its skirt and
/// cap), keeps the result manifold, and with `fill` closes each hole trimming made by a fan from its
/// centre (openings the mesh had before, an open base, stay open). A fan is flat-ish only where the hole
/// is: a hole curving far round the object is better left open (the default).
pub fn trim(
    mesh: &TriMesh,
    samples: &[Point3],
    max_distance: Real,
    fill: bool,
    keep_below: Option<Real>,
) -> (TriMesh, TrimReport) {
    let mut report = TrimReport { max_distance, ..Default::default() };
    if samples.is_empty() {
        return (mesh.clone(), report);
    }
    let tree = PointTree::new(samples);
    let limit = max_distance * max_distance;
    let keep: Vec<bool> = mesh
        .faces
        .par_iter()
        .map(|f| {
            let [a, b, c] = f.map(|i| mesh.vertices[i as usize].coords);
            keep_below.is_some_and(|z| a.z <= z && b.z <= z && c.z <= z)
                || tree.nearest(&Point3::from((a + b + c) / 3.0)).1 <= limit
        })
        .collect();
    let mut faces: Vec<[u32; 3]> = mesh.faces.iter().zip(&keep).filter(|(_, k)| **k).map(|(f, _)| *f).collect();
    report.removed = mesh.faces.len() - faces.len();
    let mut vertices = mesh.vertices.clone();
    let mut source: Vec<u32> = (0..vertices.len() as u32).collect();
    report.split_vertices = split_pinched_vertices(&mut vertices, &mut faces, &mut source);
    let loops = boundary_loops(&faces);
    report.holes = loops.len();
    if fill {
        // An opening the mesh had before trimming (an open base) stays open, and so does a hole that
        // trimming joined to one. Which loops those are is told by their edges, not by where they lie:
        // a hole trimmed beside a flat base's cap runs along the platter too, and must be closed.
        let before = boundary_edges(&mesh.faces);
        let opening = |lp: &Vec<u32>| {
            (0..lp.len()).any(|k| before.contains(&(source[lp[k] as usize], source[lp[(k + 1) % lp.len()] as usize])))
        };
        for lp in &loops {
            if opening(lp) {
                continue;
            }
            let centre = lp.iter().map(|&v| vertices[v as usize].coords).sum::<rig::math::Vector3>() / lp.len() as Real;
            vertices.push(Point3::from(centre));
            let c = (vertices.len() - 1) as u32;
            for k in 0..lp.len() {
                // The boundary runs a → b inside its triangle; the fill takes the edge back, b → a.
                let (a, b) = (lp[k], lp[(k + 1) % lp.len()]);
                faces.push([b, a, c]);
                report.fill_triangles += 1;
            }
        }
    }
    let mut used = vec![false; vertices.len()];
    faces.iter().flatten().for_each(|&i| used[i as usize] = true);
    let mut map = vec![u32::MAX; vertices.len()];
    let mut kept = Vec::new();
    for (i, v) in vertices.into_iter().enumerate() {
        if used[i] {
            map[i] = kept.len() as u32;
            kept.push(v);
        }
    }
    let faces = faces.into_iter().map(|f| f.map(|i| map[i as usize])).collect();
    (TriMesh { vertices: kept, faces, normals: None }, report)
}

/// Splits every vertex whose triangles form more than one fan (connected through edges at the vertex)
/// into one vertex per fan. Returns the number of copies made.
fn split_pinched_vertices(vertices: &mut Vec<Point3>, faces: &mut [[u32; 3]], source: &mut Vec<u32>) -> usize {
    let mut incident: Vec<Vec<usize>> = vec![Vec::new(); vertices.len()];
    for (fi, f) in faces.iter().enumerate() {
        for &v in f {
            incident[v as usize].push(fi);
        }
    }
    let mut copies = 0;
    for v in 0..incident.len() {
        let around = &incident[v];
        if around.len() < 2 {
            continue;
        }
        // Union the triangles around v that share an edge v–w.
        let mut parent: Vec<usize> = (0..around.len()).collect();
        fn root(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        let mut by_other: HashMap<u32, usize> = HashMap::new();
        for (k, &fi) in around.iter().enumerate() {
            for &w in faces[fi].iter().filter(|&&w| w != v as u32) {
                match by_other.get(&w) {
                    Some(&j) => {
                        let (a, b) = (root(&mut parent, k), root(&mut parent, j));
                        parent[a] = b;
                    }
                    None => {
                        by_other.insert(w, k);
                    }
                }
            }
        }
        let mut fan_of_root: HashMap<usize, u32> = HashMap::new();
        for k in 0..around.len() {
            let r = root(&mut parent, k);
            let next = fan_of_root.len();
            let target = *fan_of_root.entry(r).or_insert_with(|| {
                if next == 0 {
                    v as u32
                } else {
                    vertices.push(vertices[v]);
                    source.push(source[v]);
                    copies += 1;
                    (vertices.len() - 1) as u32
                }
            });
            if target != v as u32 {
                for c in faces[around[k]].iter_mut().filter(|c| **c == v as u32) {
                    *c = target;
                }
            }
        }
    }
    copies
}

/// The directed edges that no triangle has reversed.
fn boundary_edges(faces: &[[u32; 3]]) -> HashSet<(u32, u32)> {
    let directed: HashSet<(u32, u32)> =
        faces.iter().flat_map(|f| (0..3).map(move |k| (f[k], f[(k + 1) % 3]))).collect();
    directed.iter().filter(|&&(a, b)| !directed.contains(&(b, a))).copied().collect()
}

/// The boundary loops: chains of directed edges that no triangle has reversed.
fn boundary_loops(faces: &[[u32; 3]]) -> Vec<Vec<u32>> {
    // Sorted, so a vertex with two ways out (possible only before pinched vertices are split) keeps
    // the same one on every run.
    let mut edges: Vec<(u32, u32)> = boundary_edges(faces).into_iter().collect();
    edges.sort_unstable();
    let mut next: HashMap<u32, u32> = edges.into_iter().collect();
    let mut starts: Vec<u32> = next.keys().copied().collect();
    starts.sort_unstable();
    let mut loops = Vec::new();
    for s in starts {
        if !next.contains_key(&s) {
            continue;
        }
        let mut lp = vec![s];
        let mut at = s;
        while let Some(n) = next.remove(&at) {
            if n == s {
                break;
            }
            lp.push(n);
            at = n;
        }
        if lp.len() >= 3 {
            loops.push(lp);
        }
    }
    loops
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The six corners of an octahedron of radius 10 about the origin, poles last.
    fn octahedron() -> Vec<Point3> {
        vec![
            Point3::new(10.0, 0.0, 0.0),
            Point3::new(0.0, 10.0, 0.0),
            Point3::new(-10.0, 0.0, 0.0),
            Point3::new(0.0, -10.0, 0.0),
            Point3::new(0.0, 0.0, 10.0),
            Point3::new(0.0, 0.0, -10.0),
        ]
    }

    /// An octahedron whose samples cover only its upper half: the lower faces go, the rest stays
    /// manifold with one hole; filled, it is closed again.
    #[test]
    fn surface_far_from_the_samples_goes_and_the_rest_stays_manifold() {
        let v = octahedron();
        let faces = vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4], [1, 0, 5], [2, 1, 5], [3, 2, 5], [0, 3, 5]];
        let m = TriMesh { vertices: v, faces, normals: None };
        let samples: Vec<Point3> = m.faces[..4]
            .iter()
            .map(|f| Point3::from(f.iter().map(|&i| m.vertices[i as usize].coords).sum::<rig::math::Vector3>() / 3.0))
            .collect();
        let (open, r) = trim(&m, &samples, 1.0, false, None);
        assert_eq!((r.removed, r.holes, open.faces.len(), open.vertices.len()), (4, 1, 4, 5), "{r:?}");
        let (closed, r) = trim(&m, &samples, 1.0, true, None);
        assert_eq!(r.fill_triangles, 4);
        assert!(boundary_loops(&closed.faces).is_empty());
        assert!(closed.signed_volume() > 0.0);
    }

    /// An opening the mesh already had (here one lower face missing: an open base) stays open when
    /// holes are filled; the hole trimming made, on the far side, is closed.
    #[test]
    fn filling_closes_what_trimming_opened_and_leaves_the_mesh_s_own_opening() {
        let v = octahedron();
        // [1, 0, 5] is missing: the opening. The samples leave [2, 3, 4] out, which shares no vertex with it.
        let faces = vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4], [2, 1, 5], [3, 2, 5], [0, 3, 5]];
        let m = TriMesh { vertices: v, faces, normals: None };
        let centre = |f: &[u32; 3]| {
            Point3::from(f.iter().map(|&i| m.vertices[i as usize].coords).sum::<rig::math::Vector3>() / 3.0)
        };
        let samples: Vec<Point3> = m.faces.iter().filter(|f| **f != [2, 3, 4]).map(centre).collect();
        let (filled, r) = trim(&m, &samples, 1.0, true, None);
        assert_eq!((r.removed, r.holes, r.fill_triangles), (1, 2, 3), "{r:?}");
        let left = boundary_loops(&filled.faces);
        assert_eq!(left.len(), 1, "{left:?}");
        let mut corners: Vec<[i64; 3]> =
            left[0].iter().map(|&i| filled.vertices[i as usize].coords.map(|c| c.round() as i64).into()).collect();
        corners.sort_unstable();
        assert_eq!(corners, vec![[0, 0, -10], [0, 10, 0], [10, 0, 0]], "the opening left is the mesh's own");
    }

    /// Two triangles that touch at one vertex only: the vertex is split, one copy per fan.
    #[test]
    fn a_pinched_vertex_is_split() {
        let mut v = vec![Point3::origin(); 5];
        let mut faces = vec![[0, 1, 2], [0, 3, 4]];
        let mut source = (0..v.len() as u32).collect();
        assert_eq!(split_pinched_vertices(&mut v, &mut faces, &mut source), 1);
        assert_eq!(v.len(), 6);
        assert_ne!(faces[0][0], faces[1][0]);
    }
}
