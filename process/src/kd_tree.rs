//! The k-d tree every neighbourhood query goes through (ICP correspondences, PCA normals, mean-shift
//! kernels, area weights, orientation graphs): kiddo's immutable tree over our points.

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rig::math::Point3;
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

    /// Whether a point lies within `radius` of `p`. The search stops at `radius`: a nearest-point query
    /// from far outside the cloud visits much of the tree (most of a second for the 8,000 vertices of a
    /// phantom component away from the bunny's 362,272 samples).
    pub fn any_within(&self, p: &Point3, radius: f64) -> bool {
        let one = NonZero::new(1).expect("1 ≥ 1");
        !self.tree.nearest_n_within::<SquaredEuclidean>(&[p.x, p.y, p.z], radius * radius, one, false).is_empty()
    }

    /// Indices of the points within `radius` of `p`, in no order.
    pub fn within(&self, p: &Point3, radius: f64) -> Vec<usize> {
        self.tree
            .within_unsorted::<SquaredEuclidean>(&[p.x, p.y, p.z], radius * radius)
            .into_iter()
            .map(|n| n.item as usize)
            .collect()
    }

    /// The `k` nearest points' indices in no order, and the largest squared distance among them. Where
    /// only the set and its reach matter (area weights), a heap of the nearest is cheaper than keeping
    /// them sorted: kiddo's sorted list inserted each candidate, a third of the weights' time.
    pub fn nearest_k_unsorted(&self, p: &Point3, k: usize) -> (Vec<usize>, f64) {
        let k = NonZero::new(k.max(1)).expect("k ≥ 1");
        let found = self.tree.nearest_n_within::<SquaredEuclidean>(&[p.x, p.y, p.z], f64::INFINITY, k, false);
        let reach = found.iter().map(|n| n.distance).fold(0.0, f64::max);
        (found.into_iter().map(|n| n.item as usize).collect(), reach)
    }

    /// The `k` nearest points' indices, nearest first.
    pub fn nearest_k(&self, p: &Point3, k: usize) -> Vec<usize> {
        let k = NonZero::new(k.max(1)).expect("k ≥ 1");
        self.tree.nearest_n::<SquaredEuclidean>(&[p.x, p.y, p.z], k).into_iter().map(|n| n.item as usize).collect()
    }
}
