//! Consistent normal orientation without a sensor (Hoppe et al. 1992): PCA normals know their line,
//! not their side. Over the k-nearest-neighbour graph weighted by `1 − |n_i · n_j|` — cheap between
//! near-parallel normals — a minimum spanning tree carries the orientation from a seed along the
//! smoothest paths, so it turns sharp corners last and least often wrongly.
//!
//! The seed of each connected part is its highest point (largest z), turned to face +z: the top of
//! an object standing on a turntable faces up.

use crate::kd_tree::PointTree;
use rayon::prelude::*;
use rig::math::{Point3, Vector3};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Flips `normals` (one per point, any sign) so that neighbours agree; `k` neighbours per point in the
/// graph (8–16 suits scanned surfaces). Returns the number of connected parts seeded.
pub fn orient_by_spanning_tree(points: &[Point3], normals: &mut [Vector3], k: usize) -> usize {
    assert_eq!(points.len(), normals.len(), "one normal per point");
    let n = points.len();
    if n == 0 {
        return 0;
    }
    let tree = PointTree::new(points);
    let knn: Vec<Vec<usize>> = points.par_iter().map(|p| tree.nearest_k(p, k + 1)).collect();
    // Symmetric adjacency (CSR): j in i's list or i in j's, so no point is reachable only one way.
    let mut degree = vec![0usize; n + 1];
    for (i, nb) in knn.iter().enumerate() {
        for &j in nb.iter().filter(|&&j| j != i) {
            degree[i + 1] += 1;
            degree[j + 1] += 1;
        }
    }
    for i in 0..n {
        degree[i + 1] += degree[i];
    }
    let start = degree;
    let mut fill = start.clone();
    let mut adjacency = vec![0u32; start[n]];
    for (i, nb) in knn.iter().enumerate() {
        for &j in nb.iter().filter(|&&j| j != i) {
            adjacency[fill[i]] = j as u32;
            fill[i] += 1;
            adjacency[fill[j]] = i as u32;
            fill[j] += 1;
        }
    }
    drop(knn);

    // Seeds in order of height; Prim's algorithm from each unvisited one.
    let mut by_height: Vec<usize> = (0..n).collect();
    by_height.sort_by(|&a, &b| points[b].z.total_cmp(&points[a].z));
    let mut visited = vec![false; n];
    let mut parts = 0;
    let mut heap = BinaryHeap::new();
    for &seed in &by_height {
        if visited[seed] {
            continue;
        }
        parts += 1;
        if normals[seed].z < 0.0 {
            normals[seed] = -normals[seed];
        }
        heap.push((Reverse(0u64), seed as u32, seed as u32));
        while let Some((_, i, from)) = heap.pop() {
            let (i, from) = (i as usize, from as usize);
            if visited[i] {
                continue;
            }
            visited[i] = true;
            if normals[i].dot(&normals[from]) < 0.0 {
                normals[i] = -normals[i];
            }
            for &j in &adjacency[start[i]..start[i + 1]] {
                let j = j as usize;
                if !visited[j] {
                    let w = 1.0 - normals[i].dot(&normals[j]).abs();
                    // Weights in [0, 1] as integers keep the heap's order total.
                    heap.push((Reverse((w.clamp(0.0, 1.0) * 1e12) as u64), j as u32, i as u32));
                }
            }
        }
    }
    parts
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::normals::pca_normals;

    /// A torus (R = 30, r = 10) sampled on a jittered lattice, with its outward normals.
    fn torus() -> (Vec<Point3>, Vec<Vector3>) {
        let (mut points, mut normals) = (Vec::new(), Vec::new());
        let mut rng = fixtures::Lcg::new(7);
        let mut u = move || rng.uniform();
        for a in 0..240 {
            for b in 0..80 {
                let (a, b) =
                    ((a as f64 + u()) * std::f64::consts::TAU / 240.0, (b as f64 + u()) * std::f64::consts::TAU / 80.0);
                let n = Vector3::new(b.cos() * a.cos(), b.cos() * a.sin(), b.sin());
                let c = Vector3::new(30.0 * a.cos(), 30.0 * a.sin(), 0.0);
                points.push(Point3::from(c + n * 10.0));
                normals.push(n);
            }
        }
        (points, normals)
    }

    #[test]
    fn a_torus_with_random_signs_is_oriented_outward() {
        let (points, truth) = torus();
        let tree = PointTree::new(&points);
        // PCA normals with their signs scrambled: nothing but the line is known.
        let mut normals: Vec<Vector3> = pca_normals(&points, &tree, 10, |_| Vector3::z())
            .into_iter()
            .enumerate()
            .map(|(i, n)| if (i * 7919) % 3 == 0 { -n } else { n })
            .collect();
        let parts = orient_by_spanning_tree(&points, &mut normals, 10);
        let agree = normals.iter().zip(&truth).filter(|(n, t)| n.dot(t) > 0.0).count();
        assert_eq!(parts, 1);
        assert_eq!(agree, points.len(), "{} of {} outward", agree, points.len());
    }

    #[test]
    fn separate_parts_are_each_seeded_facing_up() {
        // Two flat patches far apart, normals ±z at random: each part ends facing +z.
        let mut points = Vec::new();
        for part in 0..2 {
            for i in 0..400 {
                points.push(Point3::new((i % 20) as f64 + part as f64 * 1000.0, (i / 20) as f64, part as f64 * 5.0));
            }
        }
        let mut normals: Vec<Vector3> =
            (0..points.len()).map(|i| if i % 3 == 0 { -Vector3::z() } else { Vector3::z() }).collect();
        assert_eq!(orient_by_spanning_tree(&points, &mut normals, 8), 2);
        assert!(normals.iter().all(|n| n.z > 0.0));
    }
}
