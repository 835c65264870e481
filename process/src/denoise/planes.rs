//! Range grids as separate single-precision planes (x, y, z, valid), the layout the filter's inner
//! loops vectorise over.
//!
//! Positions are stored relative to a shared origin near the data (the current frame's mean), so
//! single precision keeps ~1e-7 of the object's size rather than of its distance from the sensor. Only
//! differences of nearby points enter the filter, and the displacement it computes is applied to the
//! original double-precision points.

use rayon::prelude::*;
use rig::RangeGrid;
use rig::math::{Point3, Real, Vector3};

/// One grid's positions (relative to an origin) and validity, row-major, zero where invalid.
pub(super) struct Planes {
    pub w: usize,
    pub h: usize,
    pub x: Vec<f32>,
    pub y: Vec<f32>,
    pub z: Vec<f32>,
    /// 1 where the cell holds a measurement, 0 where not.
    pub m: Vec<f32>,
}

impl Planes {
    /// `grid`'s points minus `origin`.
    pub fn new(grid: &RangeGrid, origin: &Point3) -> Self {
        let n = grid.points.len();
        let (mut x, mut y, mut z, mut m) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let w = grid.width.max(1);
        (x.par_chunks_mut(w), y.par_chunks_mut(w), z.par_chunks_mut(w), m.par_chunks_mut(w))
            .into_par_iter()
            .enumerate()
            .for_each(|(r, (x, y, z, m))| {
                for c in 0..x.len() {
                    let i = r * w + c;
                    if grid.valid[i] {
                        let p = grid.points[i] - origin;
                        (x[c], y[c], z[c], m[c]) = (p.x as f32, p.y as f32, p.z as f32, 1.0);
                    }
                }
            });
        Planes { w: grid.width, h: grid.height, x, y, z, m }
    }

    /// Row `r` of each plane, columns `c0..c1`.
    pub fn row(&self, r: usize, c0: usize, c1: usize) -> [&[f32]; 4] {
        let s = r * self.w;
        [&self.x[s + c0..s + c1], &self.y[s + c0..s + c1], &self.z[s + c0..s + c1], &self.m[s + c0..s + c1]]
    }
}

/// The current frame's displacement directions as planes, and each cell's largest usable
/// neighbourhood reach (−1 where the cell is invalid or has no direction).
pub(super) struct Directions {
    pub x: Vec<f32>,
    pub y: Vec<f32>,
    pub z: Vec<f32>,
    pub reach: Vec<f32>,
}

impl Directions {
    /// From unit directions (zero where none) and the adaptive neighbourhood radii.
    pub fn new(grid: &RangeGrid, dirs: &[Vector3], radius: &[usize]) -> Self {
        let n = dirs.len();
        let (mut x, mut y, mut z, mut reach) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![-1.0; n]);
        let w = grid.width.max(1);
        (x.par_chunks_mut(w), y.par_chunks_mut(w), z.par_chunks_mut(w), reach.par_chunks_mut(w))
            .into_par_iter()
            .enumerate()
            .for_each(|(r, (x, y, z, reach))| {
                for c in 0..x.len() {
                    let (i, d) = (r * w + c, dirs[r * w + c]);
                    if grid.valid[i] && d.norm_squared() > 0.0 {
                        (x[c], y[c], z[c], reach[c]) = (d.x as f32, d.y as f32, d.z as f32, radius[i] as f32);
                    }
                }
            });
        Directions { x, y, z, reach }
    }

    /// Row `r` of each plane, columns `c0..c1`, from row-major storage of width `w`.
    pub fn row(&self, w: usize, r: usize, c0: usize, c1: usize) -> [&[f32]; 4] {
        let s = r * w;
        [&self.x[s + c0..s + c1], &self.y[s + c0..s + c1], &self.z[s + c0..s + c1], &self.reach[s + c0..s + c1]]
    }
}

/// The mean of a grid's valid points (the origin of its planes); the origin if none is valid.
pub(super) fn valid_mean(grid: &RangeGrid) -> Point3 {
    let (mut sum, mut n) = (Vector3::zeros(), 0usize);
    for (p, _) in grid.points.iter().zip(&grid.valid).filter(|(_, v)| **v) {
        sum += p.coords;
        n += 1;
    }
    if n == 0 { Point3::origin() } else { Point3::from(sum / n as Real) }
}
