//! Point-cloud normals by principal component analysis over the k nearest neighbours, oriented toward
//! a known sensor (a range grid's line of sight, a scanner's viewing direction).

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;
use rig::math::{Matrix3, Point3, Vector3};
use std::num::NonZero;

/// A k-d tree over points, built once and queried many times.
pub struct PointTree {
    tree: ImmutableKdTree<f64, 3>,
}

impl PointTree {
    /// Builds the tree.
    pub fn new(points: &[Point3]) -> Self {
        let coords: Vec<[f64; 3]> = points.iter().map(|p| [p.x, p.y, p.z]).collect();
        PointTree { tree: ImmutableKdTree::new_from_slice(&coords) }
    }

    /// The nearest point's index and squared distance.
    pub fn nearest(&self, p: &Point3) -> (usize, f64) {
        let n = self.tree.nearest_one::<SquaredEuclidean>(&[p.x, p.y, p.z]);
        (n.item as usize, n.distance)
    }

    /// Indices of the points within `radius` of `p`, in no order.
    pub fn within(&self, p: &Point3, radius: f64) -> Vec<usize> {
        self.tree
            .within_unsorted::<SquaredEuclidean>(&[p.x, p.y, p.z], radius * radius)
            .into_iter()
            .map(|n| n.item as usize)
            .collect()
    }

    /// The `k` nearest points' indices, nearest first.
    pub fn nearest_k(&self, p: &Point3, k: usize) -> Vec<usize> {
        let k = NonZero::new(k.max(1)).expect("k ≥ 1");
        self.tree.nearest_n::<SquaredEuclidean>(&[p.x, p.y, p.z], k).into_iter().map(|n| n.item as usize).collect()
    }
}

/// Unit PCA normals over the `k` nearest neighbours of each point, turned so that `toward(i)` (a vector
/// from point i toward its sensor) has a positive component along them.
pub fn pca_normals(
    points: &[Point3],
    tree: &PointTree,
    k: usize,
    toward: impl Fn(usize) -> Vector3 + Sync,
) -> Vec<Vector3> {
    points
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let nb = tree.nearest_k(p, k);
            let mean = nb.iter().fold(Vector3::zeros(), |a, &j| a + points[j].coords) / nb.len() as f64;
            let cov = nb.iter().fold(Matrix3::zeros(), |a, &j| {
                let d = points[j].coords - mean;
                a + d * d.transpose()
            });
            let eig = cov.symmetric_eigen();
            let n = eig.eigenvectors.column(eig.eigenvalues.imin()).into_owned();
            if n.dot(&toward(i)) < 0.0 { -n } else { n }
        })
        .collect()
}
