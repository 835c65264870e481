//! Point-cloud normals by principal component analysis over the k nearest neighbours, oriented toward
//! a known sensor (a range grid's line of sight, a scanner's viewing direction).

pub use crate::kd_tree::PointTree;
use rayon::prelude::*;
use rig::math::{Matrix3, Point3, Vector3};

/// Unit PCA normals over the `k` nearest neighbours of each point, turned so that `toward(i)` (a vector
/// from point i toward its sensor) has a positive component along them.
pub fn pca_normals(
    points: &[Point3],
    tree: &PointTree,
    k: usize,
    toward: impl Fn(usize) -> Vector3 + Sync,
) -> Vec<Vector3> {
    points.par_iter().enumerate().map(|(i, p)| pca_normal(points, tree, k, p, toward(i))).collect()
}

/// The PCA normal at `p` over its `k` nearest `points`, turned to the side of `toward`.
pub fn pca_normal(points: &[Point3], tree: &PointTree, k: usize, p: &Point3, toward: Vector3) -> Vector3 {
    let nb = tree.nearest_k(p, k);
    let mean = nb.iter().fold(Vector3::zeros(), |a, &j| a + points[j].coords) / nb.len() as f64;
    let cov = nb.iter().fold(Matrix3::zeros(), |a, &j| {
        let d = points[j].coords - mean;
        a + d * d.transpose()
    });
    let eig = cov.symmetric_eigen();
    let n = eig.eigenvectors.column(eig.eigenvalues.imin()).into_owned();
    if n.dot(&toward) < 0.0 { -n } else { n }
}
