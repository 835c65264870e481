//! Displacement directions: least-squares normals (additive noise) or lines of sight (view-dependent
//! noise), one unit vector per valid cell, zero where none can be found.

use super::Direction;
use rayon::prelude::*;
use rig::RangeGrid;
use rig::math::{Matrix3, Point3, Vector3};

/// The normal of the least-squares plane through the valid cells of the `(2·half + 1)²` window around
/// each cell (the eigenvector of the smallest eigenvalue of their covariance), turned toward the sensor.
pub fn least_squares_normals(grid: &RangeGrid, half: usize) -> Vec<Vector3> {
    let (w, h) = (grid.width, grid.height);
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            if !grid.valid[i] {
                return Vector3::zeros();
            }
            let (c, r) = ((i % w) as isize, (i / w) as isize);
            let hs = half as isize;
            let mut pts: Vec<Point3> = Vec::with_capacity((2 * half + 1).pow(2));
            for rr in (r - hs).max(0)..=(r + hs).min(h as isize - 1) {
                for cc in (c - hs).max(0)..=(c + hs).min(w as isize - 1) {
                    let j = rr as usize * w + cc as usize;
                    if grid.valid[j] {
                        pts.push(grid.points[j]);
                    }
                }
            }
            if pts.len() < 3 {
                return Vector3::zeros();
            }
            let mean = pts.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / pts.len() as f64;
            let cov = pts.iter().fold(Matrix3::zeros(), |a, p| {
                let d = p.coords - mean;
                a + d * d.transpose()
            });
            let eig = cov.symmetric_eigen();
            let k = eig.eigenvalues.imin();
            let n = eig.eigenvectors.column(k).into_owned();
            if n.dot(&grid.line_of_sight(i)) < 0.0 { -n } else { n }
        })
        .collect()
}

/// The displacement direction of every cell.
pub fn directions(grid: &RangeGrid, how: Direction, normal_half: usize) -> Vec<Vector3> {
    match how {
        Direction::Normal => least_squares_normals(grid, normal_half),
        Direction::LineOfSight => (0..grid.points.len())
            .map(|i| if grid.valid[i] { grid.line_of_sight(i).into_inner() } else { Vector3::zeros() })
            .collect(),
    }
}
