//! How good a quad remesh is: the share of quads, how square their corners are, how far the result
//! strays from the input (two-sided Hausdorff), how much of the constraint lines it follows, and
//! whether its edges are manifold and closed.

use crate::reconstruct::mesh_distance::MeshDistance;
use rayon::prelude::*;
use rig::math::{Point3, Real};
use rig::{PolyMesh, TriMesh};
use serde::Serialize;
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};

/// Upper ends of the |angle − 90°| histogram bins, in degrees (the last bin is open).
pub const ANGLE_BINS: [Real; 6] = [5.0, 10.0, 20.0, 30.0, 45.0, 90.0];

/// The quality report of a remesh.
#[derive(Debug, Clone, Default, Serialize, serde::Deserialize)]
pub struct Quality {
    /// Faces in the output.
    pub faces: usize,
    /// Faces with four corners.
    pub quads: usize,
    /// Faces with three.
    pub triangles: usize,
    /// Faces with five or more.
    pub polygons: usize,
    /// `quads / faces`.
    pub quad_fraction: Real,
    /// Mean |corner angle − 90°| over quad corners, in degrees.
    pub mean_angle_error_deg: Real,
    /// Quad corners per |angle − 90°| bin, the bins ending at [`ANGLE_BINS`].
    pub angle_histogram: Vec<usize>,
    /// Two-sided Hausdorff distance between input and output.
    pub hausdorff: Real,
    /// The same, over the input's bounding-box diagonal.
    pub hausdorff_relative: Real,
    /// Singular vertices of the field (index of eq. 6.5 not 0).
    pub singularities: usize,
    /// Share of the constraint lines' length within `alignment_tolerance` of an output edge.
    pub constraint_alignment: Real,
    /// The distance that counts as following a constraint.
    pub alignment_tolerance: Real,
    /// Output edges with more than two faces (the remesh stage counts them again on the faces as
    /// readers triangulate them: a fan from each face's first corner).
    pub non_manifold_edges: usize,
    /// Output edges with one face.
    pub boundary_edges: usize,
}

/// Measures `out` against `input`; `constraints` are polylines (as points) to follow, within
/// `tolerance`.
pub fn measure(input: &TriMesh, out: &PolyMesh, constraints: &[Vec<Point3>], tolerance: Real) -> Quality {
    let mut q = Quality { faces: out.face_count(), alignment_tolerance: tolerance, ..Default::default() };
    let sizes = out.face_sizes();
    q.quads = sizes.quads;
    q.triangles = sizes.triangles;
    q.polygons = sizes.larger;
    q.quad_fraction = if q.faces > 0 { q.quads as Real / q.faces as Real } else { 0.0 };

    let mut hist = vec![0usize; ANGLE_BINS.len()];
    let (mut sum, mut corners) = (0.0, 0usize);
    for f in out.faces().filter(|f| f.len() == 4) {
        for k in 0..4 {
            let p = out.vertices[f[k] as usize];
            let (a, b) = (out.vertices[f[(k + 3) % 4] as usize] - p, out.vertices[f[(k + 1) % 4] as usize] - p);
            if a.norm() == 0.0 || b.norm() == 0.0 {
                continue;
            }
            let err = (a.angle(&b).to_degrees() - 90.0).abs();
            sum += err;
            corners += 1;
            let bin = ANGLE_BINS.iter().position(|&e| err < e).unwrap_or(ANGLE_BINS.len() - 1);
            hist[bin] += 1;
        }
    }
    q.mean_angle_error_deg = if corners > 0 { sum / corners as Real } else { 0.0 };
    q.angle_histogram = hist;

    (q.boundary_edges, q.non_manifold_edges) = edge_counts(out);

    let diag = input.bounding_box().map_or(0.0, |b| (b.max - b.min).norm());
    let tri_out = out.triangulate();
    if !tri_out.faces.is_empty() && !input.faces.is_empty() {
        let cell = mean_edge(input).max(diag * 1e-4);
        let to_input = MeshDistance::new(input, cell);
        let to_output = MeshDistance::new(&tri_out, mean_edge(&tri_out).max(cell));
        // Every query is independent: both directions in parallel (a 500 K-triangle input is a
        // million queries). Only the largest distance counts, so a query below the largest found so
        // far stops at the first triangle within it (the same maximum, a fraction of the search).
        let largest = AtomicU64::new(0f64.to_bits());
        let consider = |index: &MeshDistance, p: &Point3| {
            if let Some(d) = index.distance_beyond(p, f64::from_bits(largest.load(Ordering::Relaxed))) {
                // Non-negative floats order as their bits do.
                largest.fetch_max(d.to_bits(), Ordering::Relaxed);
            }
        };
        tri_out.faces.par_iter().for_each(|t| {
            let [a, b, c] = t.map(|i| tri_out.vertices[i as usize]);
            for p in
                [a, Point3::from((a.coords + b.coords) / 2.0), Point3::from((a.coords + b.coords + c.coords) / 3.0)]
            {
                consider(&to_input, &p);
            }
        });
        let out_to_input = f64::from_bits(largest.swap(0f64.to_bits(), Ordering::Relaxed));
        input.faces.par_iter().for_each(|t| {
            let [a, b, c] = t.map(|i| input.vertices[i as usize]);
            consider(&to_output, &a);
            consider(&to_output, &Point3::from((a.coords + b.coords + c.coords) / 3.0));
        });
        let input_to_out = f64::from_bits(largest.load(Ordering::Relaxed));
        let h = out_to_input.max(input_to_out);
        q.hausdorff = h;
        q.hausdorff_relative = if diag > 0.0 { h / diag } else { 0.0 };
    }
    q.constraint_alignment = alignment(out, constraints, tolerance);
    q
}

/// How many edges of `mesh` have one face (its boundary) and how many more than two (non-manifold).
pub fn edge_counts(mesh: &PolyMesh) -> (usize, usize) {
    let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
    for f in mesh.faces() {
        for k in 0..f.len() {
            *uses.entry(rig::mesh::edge_key(f[k], f[(k + 1) % f.len()])).or_default() += 1;
        }
    }
    (uses.values().filter(|&&n| n == 1).count(), uses.values().filter(|&&n| n > 2).count())
}

fn mean_edge(m: &TriMesh) -> Real {
    let mut sum = 0.0;
    for f in &m.faces {
        sum += (m.vertices[f[1] as usize] - m.vertices[f[0] as usize]).norm();
    }
    if m.faces.is_empty() { 0.0 } else { sum / m.faces.len() as Real }
}

/// The share of the polylines' length whose points lie within `tol` of an edge of `out`.
fn alignment(out: &PolyMesh, lines: &[Vec<Point3>], tol: Real) -> Real {
    if lines.is_empty() || tol <= 0.0 {
        return 1.0;
    }
    let mut segs: Vec<(Point3, Point3)> = Vec::new();
    for f in out.faces() {
        for k in 0..f.len() {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            if a < b {
                segs.push((out.vertices[a as usize], out.vertices[b as usize]));
            }
        }
    }
    // Edges hashed into cubes of 4·tol along their length.
    let cell = 4.0 * tol;
    let key = |p: &Point3| [p.x, p.y, p.z].map(|c| (c / cell).floor() as i64);
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    for (i, (a, b)) in segs.iter().enumerate() {
        let steps = ((b - a).norm() / cell).ceil().max(1.0) as usize;
        let mut last = None;
        for s in 0..=steps {
            let k = key(&(a + (b - a) * (s as Real / steps as Real)));
            if last != Some(k) {
                grid.entry(k).or_default().push(i as u32);
                last = Some(k);
            }
        }
    }
    let near = |p: &Point3| -> bool {
        let k = key(p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(ids) = grid.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) {
                        for &i in ids {
                            let (a, b) = segs[i as usize];
                            let ab = b - a;
                            let t = if ab.norm_squared() > 0.0 {
                                ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0)
                            } else {
                                0.0
                            };
                            if (a + ab * t - p).norm() <= tol {
                                return true;
                            }
                        }
                    }
                }
            }
        }
        false
    };
    let (mut total, mut covered) = (0.0, 0.0);
    for line in lines {
        for w in line.windows(2) {
            let len = (w[1] - w[0]).norm();
            let pieces = (len / tol).ceil().max(1.0) as usize;
            for s in 0..pieces {
                let p = w[0] + (w[1] - w[0]) * ((s as Real + 0.5) / pieces as Real);
                total += len / pieces as Real;
                if near(&p) {
                    covered += len / pieces as Real;
                }
            }
        }
    }
    if total > 0.0 { covered / total } else { 1.0 }
}
