//! Plane-to-image homographies by the normalised direct linear transform (Hartley): both point sets
//! moved to their centroid and scaled to a mean distance of √2, the 2N × 9 system's null vector taken
//! from the smallest eigenvector of AᵀA, and the scaling undone.

use rig::math::{Matrix3, Point2, Real};

type M9 = nalgebra::SMatrix<Real, 9, 9>;

/// The similarity that moves points to centroid 0 and mean distance √2.
fn normaliser(points: &[Point2]) -> Matrix3 {
    let n = points.len() as Real;
    let c = points.iter().fold(nalgebra::Vector2::zeros(), |a, p| a + p.coords) / n;
    let mean = points.iter().map(|p| (p.coords - c).norm()).sum::<Real>() / n;
    let s = if mean > 0.0 { std::f64::consts::SQRT_2 / mean } else { 1.0 };
    Matrix3::new(s, 0.0, -s * c.x, 0.0, s, -s * c.y, 0.0, 0.0, 1.0)
}

fn apply(m: &Matrix3, p: &Point2) -> Point2 {
    let v = m * nalgebra::Vector3::new(p.x, p.y, 1.0);
    Point2::new(v.x / v.z, v.y / v.z)
}

/// The homography `H` with `image ~ H · (plane, 1)`, from four or more correspondences in general
/// position; `None` when they are too few or degenerate (collinear).
pub fn homography(plane: &[Point2], image: &[Point2]) -> Option<Matrix3> {
    if plane.len() < 4 || plane.len() != image.len() {
        return None;
    }
    let (tp, ti) = (normaliser(plane), normaliser(image));
    let mut ata = M9::zeros();
    for (p, q) in plane.iter().zip(image) {
        let (p, q) = (apply(&tp, p), apply(&ti, q));
        let rows = [
            [-p.x, -p.y, -1.0, 0.0, 0.0, 0.0, q.x * p.x, q.x * p.y, q.x],
            [0.0, 0.0, 0.0, -p.x, -p.y, -1.0, q.y * p.x, q.y * p.y, q.y],
        ];
        for r in rows {
            let v = nalgebra::SVector::<Real, 9>::from_row_slice(&r);
            ata += v * v.transpose();
        }
    }
    let eig = ata.symmetric_eigen();
    let (k, _) = eig.eigenvalues.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1))?;
    let mut sorted: Vec<Real> = eig.eigenvalues.iter().copied().collect();
    sorted.sort_by(|a, b| a.total_cmp(b));
    if sorted[1] <= 1e-12 * sorted[8] {
        return None; // a second null direction: degenerate point set
    }
    let h = eig.eigenvectors.column(k);
    let hn = Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
    let m = ti.try_inverse()? * hn * tp;
    let scale = m[(2, 2)];
    Some(if scale.abs() > 1e-300 { m / scale } else { m })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_known_homography_comes_back() {
        let truth = Matrix3::new(800.0, 20.0, 320.0, -10.0, 790.0, 240.0, 0.1, -0.05, 1.0);
        let plane: Vec<Point2> =
            (0..6).flat_map(|j| (0..8).map(move |i| Point2::new(i as Real * 0.03, j as Real * 0.03))).collect();
        let image: Vec<Point2> = plane.iter().map(|p| apply(&truth, p)).collect();
        let h = homography(&plane, &image).unwrap();
        for (p, q) in plane.iter().zip(&image) {
            assert!((apply(&h, p) - q).norm() < 1e-6);
        }
        assert!(homography(&plane[..3], &image[..3]).is_none());
        let line: Vec<Point2> = (0..6).map(|i| Point2::new(i as Real, 2.0 * i as Real)).collect();
        assert!(homography(&line, &line).is_none());
    }
}
