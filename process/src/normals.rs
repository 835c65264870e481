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
    plane_normal(points, &tree.nearest_k(p, k), toward)
}

/// [`pca_normal`] over neighbours taken from several views: of the `4·k` nearest, at most `per_view`
/// from any one view (`view_of`), nearest first, until `k`. A laser view is a line, dense along it
/// and far from the next view's line: the `k` nearest all lie on one line, whose "plane" turns freely
/// about it (a 36-view laser scan's mesh came out a 130 mm box). Capping each view's share reaches
/// across to the neighbouring lines, which fix the plane. Where the neighbours still lie on one line —
/// two lasers 60° apart lighting the same meridian every 10° step, so two views share each line —
/// the candidates widen (16·k, then 64·k) until they reach off it.
pub fn pca_normal_across_views(
    points: &[Point3],
    tree: &PointTree,
    k: usize,
    per_view: usize,
    view_of: impl Fn(usize) -> u32,
    p: &Point3,
    toward: Vector3,
) -> Vector3 {
    let mut nb = Vec::with_capacity(k);
    for (round, widen) in [4, 16, 64].into_iter().enumerate() {
        let mut taken: Vec<(u32, usize)> = Vec::new();
        nb.clear();
        for j in tree.nearest_k(p, widen * k) {
            let v = view_of(j);
            let count = match taken.iter_mut().find(|(w, _)| *w == v) {
                Some((_, c)) => c,
                None => {
                    taken.push((v, 0));
                    &mut taken.last_mut().expect("pushed").1
                }
            };
            if *count < per_view {
                *count += 1;
                nb.push(j);
                if nb.len() == k {
                    break;
                }
            }
        }
        if round == 2 || !is_line(points, &nb) {
            break;
        }
    }
    plane_normal(points, &nb, toward)
}

/// Neighbours whose spread across their main direction is under a tenth of the spread along it
/// (second eigenvalue of their covariance under 1 % of the first): a line, with no plane of its own.
pub(crate) fn is_line(points: &[Point3], nb: &[usize]) -> bool {
    let e = covariance(points, nb).symmetric_eigen().eigenvalues;
    let mut e = [e[0], e[1], e[2]];
    e.sort_by(|a, b| b.total_cmp(a));
    e[1] < 0.01 * e[0]
}

fn covariance(points: &[Point3], nb: &[usize]) -> Matrix3 {
    let mean = nb.iter().fold(Vector3::zeros(), |a, &j| a + points[j].coords) / nb.len().max(1) as f64;
    nb.iter().fold(Matrix3::zeros(), |a, &j| {
        let d = points[j].coords - mean;
        a + d * d.transpose()
    })
}

/// The normal of the plane through `nb` (least squares), turned to the side of `toward`.
fn plane_normal(points: &[Point3], nb: &[usize], toward: Vector3) -> Vector3 {
    let eig = covariance(points, nb).symmetric_eigen();
    let n = eig.eigenvectors.column(eig.eigenvalues.imin()).into_owned();
    if n.dot(&toward) < 0.0 { -n } else { n }
}
