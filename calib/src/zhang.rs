//! Zhang's closed-form initialisation (Zhang 2000, "A flexible new technique for camera
//! calibration", §3.1): each board homography `H = K [r1 r2 t]` gives two linear constraints on
//! `B = K⁻ᵀK⁻¹` (r1 ⟂ r2, |r1| = |r2|); three or more views determine B, hence K; each view's pose
//! follows from `K⁻¹H`. Skew is taken as zero.

use rig::math::{Isometry3, Matrix3, Real, Rotation3, Translation3, Vector3};

type M6 = nalgebra::SMatrix<Real, 6, 6>;
type V6 = nalgebra::SVector<Real, 6>;

fn v(h: &Matrix3, i: usize, j: usize) -> V6 {
    let (a, b) = (h.column(i), h.column(j));
    V6::from_row_slice(&[
        a[0] * b[0],
        a[0] * b[1] + a[1] * b[0],
        a[1] * b[1],
        a[2] * b[0] + a[0] * b[2],
        a[2] * b[1] + a[1] * b[2],
        a[2] * b[2],
    ])
}

/// The intrinsic matrix from three or more homographies, `Err` with the reason when the views
/// cannot determine it (too few, or boards all parallel to one another).
pub fn intrinsics(homographies: &[Matrix3]) -> Result<Matrix3, String> {
    if homographies.len() < 3 {
        return Err(format!("{} usable views; at least 3 are needed", homographies.len()));
    }
    let mut vtv = M6::zeros();
    for h in homographies {
        // Scale each homography so no view dominates.
        let h = h / h.column(0).norm().max(h.column(1).norm());
        for row in [v(&h, 0, 1), v(&h, 0, 0) - v(&h, 1, 1)] {
            vtv += row * row.transpose();
        }
    }
    let eig = vtv.symmetric_eigen();
    let mut order: Vec<usize> = (0..6).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let (e1, e5) = (eig.eigenvalues[order[1]], eig.eigenvalues[order[5]]);
    if e1 <= 1e-9 * e5 {
        return Err(
            "degenerate poses: the boards are (nearly) parallel to each other; tilt the board between views".into()
        );
    }
    let mut b = eig.eigenvectors.column(order[0]).into_owned();
    if b[0] < 0.0 {
        b = -b;
    }
    let (b11, b12, b22, b13, b23, b33) = (b[0], b[1], b[2], b[3], b[4], b[5]);
    let d = b11 * b22 - b12 * b12;
    if b11 <= 0.0 || d <= 0.0 {
        return Err("degenerate poses: the views do not determine the focal length; vary the board's tilt".into());
    }
    let v0 = (b12 * b13 - b11 * b23) / d;
    let lambda = b33 - (b13 * b13 + v0 * (b12 * b13 - b11 * b23)) / b11;
    let alpha = (lambda / b11).sqrt();
    let beta = (lambda * b11 / d).sqrt();
    let u0 = -b13 * alpha * alpha / lambda;
    if !(alpha.is_finite() && beta.is_finite() && alpha > 0.0 && beta > 0.0) {
        return Err("degenerate poses: no positive focal length fits the views".into());
    }
    Ok(Matrix3::new(alpha, 0.0, u0, 0.0, beta, v0, 0.0, 0.0, 1.0))
}

/// The board pose (camera_from_board) for homography `h` under intrinsics `k`, with the rotation
/// made orthonormal and the board in front of the camera.
pub fn pose(k: &Matrix3, h: &Matrix3) -> Option<Isometry3> {
    let kinv = k.try_inverse()?;
    let (a, b, c) = (kinv * h.column(0), kinv * h.column(1), kinv * h.column(2));
    let mut s = 1.0 / a.norm();
    if (c * s).z < 0.0 {
        s = -s;
    }
    let (r1, r2, t) = (a * s, b * s, c * s);
    let r3 = r1.cross(&r2);
    let m = Matrix3::from_columns(&[r1, r2, r3]);
    let svd = m.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let mut r = u * vt;
    if r.determinant() < 0.0 {
        r = -r;
    }
    Some(Isometry3::from_parts(Translation3::from(Vector3::from(t)), Rotation3::from_matrix_unchecked(r).into()))
}
