//! Point-cloud normals by principal component analysis over the k nearest neighbours, oriented toward
//! a known sensor (a range grid's line of sight, a scanner's viewing direction).

pub use crate::kd_tree::PointTree;
use rayon::prelude::*;
use rig::math::{Matrix3, Point3, Real, Vector3};

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
    let e = symmetric_eigenvalues(&covariance(points, nb));
    e[1] < 0.01 * e[0]
}

/// The eigenvalues of a symmetric 3×3 matrix, largest first, in closed form (the trigonometric
/// solution of the characteristic cubic, Smith 1961): area weights ask every one of millions of
/// neighbourhoods whether it is a line, and need no eigenvectors for it. Accurate to about √ε of the
/// largest where two coincide.
pub(crate) fn symmetric_eigenvalues(m: &Matrix3) -> [Real; 3] {
    let off = m[(0, 1)].powi(2) + m[(0, 2)].powi(2) + m[(1, 2)].powi(2);
    let q = m.trace() / 3.0;
    let d = [m[(0, 0)] - q, m[(1, 1)] - q, m[(2, 2)] - q];
    let p = ((d[0] * d[0] + d[1] * d[1] + d[2] * d[2] + 2.0 * off) / 6.0).sqrt();
    if p <= Real::EPSILON * q.abs() || p == 0.0 {
        return [q; 3];
    }
    let b = (m - Matrix3::identity() * q) / p;
    let phi = (b.determinant() / 2.0).clamp(-1.0, 1.0).acos() / 3.0;
    let largest = q + 2.0 * p * phi.cos();
    let smallest = q + 2.0 * p * (phi + 2.0 * std::f64::consts::FRAC_PI_3).cos();
    [largest, 3.0 * q - largest - smallest, smallest]
}

fn covariance(points: &[Point3], nb: &[usize]) -> Matrix3 {
    let mean = nb.iter().fold(Vector3::zeros(), |a, &j| a + points[j].coords) / nb.len().max(1) as f64;
    nb.iter().fold(Matrix3::zeros(), |a, &j| {
        let d = points[j].coords - mean;
        a + d * d.transpose()
    })
}

/// The normal of the plane through `nb` (least squares), turned to the side of `toward`.
pub(crate) fn plane_normal(points: &[Point3], nb: &[usize], toward: Vector3) -> Vector3 {
    let eig = covariance(points, nb).symmetric_eigen();
    let n = eig.eigenvectors.column(eig.eigenvalues.imin()).into_owned();
    if n.dot(&toward) < 0.0 { -n } else { n }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_form_eigenvalues_match_the_iterative_ones() {
        // Covariances of flat, linear, round and degenerate neighbourhoods, rotated arbitrarily.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut r = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as Real / (1u64 << 53) as Real - 0.5
        };
        for case in 0..2000 {
            let scales = match case % 4 {
                0 => [1.0, 1.0, 1e-4],
                1 => [1.0, 1e-3, 1e-6],
                2 => [r().abs() + 0.1, r().abs() + 0.1, r().abs() + 0.1],
                _ => [1.0, 0.0, 0.0],
            };
            let rot = rig::math::Rotation3::from_scaled_axis(Vector3::new(r(), r(), r()) * 6.0);
            let m = rot.matrix() * Matrix3::from_diagonal(&Vector3::from(scales)) * rot.matrix().transpose() * 40.0;
            let m = (m + m.transpose()) / 2.0;
            let mut want: Vec<Real> = m.symmetric_eigen().eigenvalues.iter().copied().collect();
            want.sort_by(|a, b| b.total_cmp(a));
            let got = symmetric_eigenvalues(&m);
            // Where two eigenvalues coincide the cubic's root is found to √ε of the largest: far
            // below the 1 % the line test asks of them.
            for k in 0..3 {
                assert!(
                    (got[k] - want[k]).abs() <= 1e-6 * want[0].abs().max(1e-300),
                    "case {case}: {got:?} vs {want:?}"
                );
            }
        }
        assert_eq!(symmetric_eigenvalues(&(Matrix3::identity() * 2.0)), [2.0; 3]);
    }
}
