//! One leaf's local solve (thesis 5.3, step 3): the FFT method on a cube twice the cell's edge, its
//! iso-level fitted to the samples, and the values cut to the leaf's support on the global grid.

use crate::kd_tree::PointTree;
use crate::reconstruct::global_fft::{Cube, FftReport, IndicatorWork, sample, solve_indicator};
use rig::math::{Point3, Real, Vector3};
use serde::Serialize;
use std::ops::Range;
use std::sync::Mutex;

/// A leaf to solve: its cell's centre and edge (the cloud's units). With [`LeafGrid`] and the
/// samples, all a worker needs ([`LeafSolver`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
pub struct LeafTask {
    /// The cell's centre.
    pub centre: [Real; 3],
    /// The cell's edge.
    pub edge: Real,
}

/// The global grid every leaf is solved onto, and the solve's parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
pub struct LeafGrid {
    /// The grid's first point.
    pub origin: [Real; 3],
    /// Its spacing.
    pub h: Real,
    /// Points per axis.
    pub n: usize,
    /// A leaf's support over its edge ([`AdFftParams::scale`]).
    ///
    /// [`AdFftParams::scale`]: super::AdFftParams::scale
    pub scale: Real,
    /// [`AdFftParams::smoothing_cells`].
    ///
    /// [`AdFftParams::smoothing_cells`]: super::AdFftParams::smoothing_cells
    pub smoothing_cells: Real,
}

impl LeafGrid {
    /// Whether the grid can be swept (one sent from elsewhere, say): 4 to 4096 points per axis at a
    /// positive spacing, a support scale of 1 to 4 and smoothing of 0 to 64 cells, the layers within
    /// it. Says what is wrong.
    pub fn check(&self, layers: &[Range<usize>]) -> Result<(), String> {
        if !((4..=1 << 12).contains(&self.n) && self.h > 0.0 && self.h.is_finite()) {
            return Err(format!("grid of {} points per axis at spacing {}", self.n, self.h));
        }
        // The same ranges as the library's own entry ([`AdFftParams::check_fields`](super::AdFftParams::check_fields)): these
        // come from a job handed between machines.
        use crate::limits::{ADFFT_SCALE, ADFFT_SMOOTHING_CELLS};
        if !(ADFFT_SCALE.contains(&self.scale) && ADFFT_SMOOTHING_CELLS.contains(&self.smoothing_cells)) {
            return Err(format!(
                "support scale {} or smoothing of {} cells out of range",
                self.scale, self.smoothing_cells
            ));
        }
        match layers.iter().find(|l| l.is_empty() || l.end > self.n - 1) {
            Some(l) => Err(format!("layers {l:?} outside the grid's 0..{}", self.n - 1)),
            None => Ok(()),
        }
    }
}

/// Solves leaves from the samples (on a worker of a distributed run): the samples' tree is built
/// once, then [`LeafSolver::solve`] is exactly the solve [`reconstruct_adfft`] does itself.
///
/// [`reconstruct_adfft`]: super::reconstruct_adfft
pub struct LeafSolver<'a> {
    samples: Samples<'a>,
}

impl<'a> LeafSolver<'a> {
    /// A solver over the oriented samples and their area weights (as [`reconstruct_adfft_slabs`]
    /// hands them out in its [`SlabJob`]).
    ///
    /// [`reconstruct_adfft_slabs`]: super::reconstruct_adfft_slabs
    /// [`SlabJob`]: super::SlabJob
    pub fn new(positions: &'a [Point3], normals: &'a [Vector3], weights: Vec<Real>) -> Self {
        LeafSolver { samples: Samples::new(positions, normals, weights) }
    }

    /// One leaf's χ − iso on the global grid points of its support, with its blending weights. The
    /// solve runs on the calling thread: solve a batch side by side (its bits do not depend on
    /// where it runs).
    pub fn solve(&self, leaf: &LeafTask, grid: &LeafGrid) -> SolvedLeaf {
        solve_leaf(&self.samples, leaf, grid, false)
    }
}

/// The oriented, weighted samples and a tree over them.
pub(super) struct Samples<'a> {
    pub(super) positions: &'a [Point3],
    pub(super) normals: &'a [Vector3],
    pub(super) weights: Vec<Real>,
    pub(super) tree: PointTree,
    /// Local solves' buffers, handed from one leaf to the next ([`Samples::solve_in_work`]): at most
    /// one per thread, so no more than the solves running at once hold.
    works: Mutex<Vec<IndicatorWork>>,
}

impl<'a> Samples<'a> {
    pub(super) fn new(positions: &'a [Point3], normals: &'a [Vector3], weights: Vec<Real>) -> Self {
        Self::with_tree(positions, normals, weights, PointTree::new(positions))
    }

    pub(super) fn with_tree(
        positions: &'a [Point3],
        normals: &'a [Vector3],
        weights: Vec<Real>,
        tree: PointTree,
    ) -> Self {
        Samples { positions, normals, weights, tree, works: Mutex::new(Vec::new()) }
    }

    /// Runs `solve` with buffers for an `n`³ local grid: kept ones of that size, or new ones (a kept
    /// one of another size is dropped first, so sizes changing from leaf to leaf do not pile up).
    /// `parallel`: whether the solve spreads over the threads ([`IndicatorWork::set_parallel`]).
    fn solve_in_work<T>(&self, n: usize, parallel: bool, solve: impl FnOnce(&mut IndicatorWork) -> T) -> T {
        let kept = {
            let mut works = self.works.lock().unwrap_or_else(|e| e.into_inner());
            match works.iter().position(|w| w.n() == n) {
                Some(i) => Some(works.swap_remove(i)),
                None => {
                    works.pop();
                    None
                }
            }
        };
        let mut work = kept.unwrap_or_else(|| IndicatorWork::new(n));
        work.set_parallel(parallel);
        let out = solve(&mut work);
        let mut works = self.works.lock().unwrap_or_else(|e| e.into_inner());
        if works.len() < rayon::current_num_threads() {
            works.push(work);
        }
        out
    }

    /// Frees the kept buffers (before the mesh's clean-up, whose peak they would add to).
    pub(super) fn release_works(&self) {
        self.works.lock().unwrap_or_else(|e| e.into_inner()).clear();
    }

    /// Indices of the points within the cube of half-edge `half` about `centre`.
    fn in_cube(&self, centre: &Point3, half: Real) -> Vec<u32> {
        self.tree
            .within(centre, half * 3f64.sqrt())
            .into_iter()
            .filter(|&i| (self.positions[i] - centre).amax() <= half)
            .map(|i| i as u32)
            .collect()
    }

    /// The local χ of a cell on a cube of twice its edge at `work`'s points per axis, from the points in
    /// the cell scaled by `scale`, left in `work` ([`IndicatorWork::chi`]); returned: the cube and
    /// the local iso-level (the mean of χ there).
    pub(super) fn local_chi(
        &self,
        cell: &LeafTask,
        scale: Real,
        work: &mut IndicatorWork,
        smoothing_cells: Real,
    ) -> (Cube, Level) {
        let n = work.n();
        let (centre, edge) = (Point3::from(cell.centre), cell.edge);
        let ids = self.in_cube(&centre, scale * edge / 2.0);
        let positions: Vec<Point3> = ids.iter().map(|&i| self.positions[i as usize]).collect();
        let normals: Vec<Vector3> = ids.iter().map(|&i| self.normals[i as usize]).collect();
        let weights: Vec<Real> = ids.iter().map(|&i| self.weights[i as usize]).collect();
        let cube = Cube { origin: centre - Vector3::repeat(edge), size: 2.0 * edge, n };
        let mut scratch = FftReport::default();
        solve_indicator(&positions, &normals, &weights, &cube, smoothing_cells, &mut scratch, work);
        let chi = work.chi();
        let values: Vec<Real> = positions.iter().map(|p| sample(chi, n, cube.origin, cube.cell(), p)).collect();
        (cube, Level::fit(&positions, &values, centre))
    }
}

/// A leaf's iso-level as a quadratic field in `p − centre`, fitted to χ at its samples. A patch cut out
/// of a surface leaves χ at the samples drifting across the cell (the missing surface's far field); a
/// constant level lets the surface drift with it. On the bunny at 256³, the mean of accuracy and
/// completeness was 0.084 mm with a constant level, 0.067 with an affine one and 0.058 with this
/// quadratic one (defaults otherwise equal).
#[derive(Debug, Clone, Copy)]
pub(super) struct Level {
    coefficients: nalgebra::SVector<Real, 10>,
    pub(super) centre: Point3,
    /// RMS distance of the samples from the centre: coordinates are divided by it, for conditioning.
    spread: Real,
}

/// Ridge on the non-constant terms, relative to the samples' count (the samples lie on a surface,
/// which pins the level along the surface but hardly across it). The bunny at 256³: 3e-3 → 0.0535 mm,
/// 1e-3 → 0.0526 mm, 3e-4 → 0.0520 mm.
const LEVEL_RIDGE: Real = 3e-4;

/// 1, x, y, z, x², y², z², xy, xz, yz.
fn quadratic_basis(d: Vector3) -> nalgebra::SVector<Real, 10> {
    nalgebra::SVector::<Real, 10>::from_column_slice(&[
        1.0,
        d.x,
        d.y,
        d.z,
        d.x * d.x,
        d.y * d.y,
        d.z * d.z,
        d.x * d.y,
        d.x * d.z,
        d.y * d.z,
    ])
}

impl Level {
    /// Least squares with a small ridge on every term but the constant.
    pub(super) fn fit(points: &[Point3], values: &[Real], centre: Point3) -> Level {
        let count = points.len().max(1) as Real;
        let spread = (points.iter().map(|p| (p - centre).norm_squared()).sum::<Real>() / count).sqrt().max(1e-12);
        let mut m = nalgebra::SMatrix::<Real, 10, 10>::zeros();
        let mut r = nalgebra::SVector::<Real, 10>::zeros();
        for (p, v) in points.iter().zip(values) {
            let x = quadratic_basis((p - centre) / spread);
            m += x * x.transpose();
            r += x * *v;
        }
        for k in 1..10 {
            m[(k, k)] += LEVEL_RIDGE * count + 1e-12;
        }
        let coefficients = m.try_inverse().map_or_else(nalgebra::SVector::zeros, |inv| inv * r);
        Level { coefficients, centre, spread }
    }

    pub(super) fn at(&self, p: &Point3) -> Real {
        self.coefficients.dot(&quadratic_basis((p - self.centre) / self.spread))
    }

    /// The level along the line through `(·, y, z)` as a quadratic in u = (x − centre_x) / spread:
    /// `[a, b, c]` with level = a + b·u + c·u² (the basis's order as in [`quadratic_basis`]). A leaf's
    /// values are computed row by row, and this is the level per point at three flops instead of ten
    /// products (it had been a tenth of AdFFT's run at 512³).
    fn along_x(&self, y: Real, z: Real) -> [Real; 3] {
        let c = &self.coefficients;
        let (v, w) = ((y - self.centre.y) / self.spread, (z - self.centre.z) / self.spread);
        [c[0] + c[2] * v + c[3] * w + c[5] * v * v + c[6] * w * w + c[9] * v * w, c[1] + c[7] * v + c[8] * w, c[4]]
    }
}

/// The largest magnitude a leaf's value is kept at (f16's largest finite value: the sweep holds
/// the values in 16 bits).
pub(super) const F16_LIMIT: f32 = 65504.0;

/// A solved leaf, kept while the sweep crosses its support: χ − iso on the global grid points of the
/// support box, and the separable blending weights along each axis.
#[derive(Debug, Clone, PartialEq)]
pub struct SolvedLeaf {
    /// The support box's first grid point.
    pub lo: [usize; 3],
    /// Its grid points per axis.
    pub dims: [usize; 3],
    /// χ − iso at those points, x fastest.
    pub values: Vec<f32>,
    /// The blending weight along each axis.
    pub weight: [Vec<f32>; 3],
}

type Solved = SolvedLeaf;

/// The global grid index range a leaf's support covers, clamped to the grid.
pub(super) fn support_range(
    cell: &LeafTask,
    scale: Real,
    origin: &Point3,
    h: Real,
    n: usize,
) -> ([usize; 3], [usize; 3]) {
    let half = scale * cell.edge / 2.0;
    let mut lo = [0; 3];
    let mut hi = [0; 3];
    for d in 0..3 {
        let a = ((cell.centre[d] - half - origin[d]) / h).ceil().max(0.0) as usize;
        let b = (((cell.centre[d] + half - origin[d]) / h).floor().max(0.0) as usize).min(n - 1);
        lo[d] = a;
        hi[d] = b.max(a);
    }
    (lo, hi)
}

/// A leaf's solve. `parallel`: whether its local FFT spreads over the threads, as it should when few
/// leaves are solved at once; many at once are better each on a thread of its own.
pub(super) fn solve_leaf(samples: &Samples, cell: &LeafTask, grid: &LeafGrid, parallel: bool) -> Solved {
    // Local resolution so the local spacing equals the global one: 2·edge / h points.
    let local_n = ((2.0 * cell.edge / grid.h).round() as usize).max(4);
    samples.solve_in_work(local_n, parallel, |work| {
        let (cube, level) = samples.local_chi(cell, grid.scale, work, grid.smoothing_cells);
        cut_to_support(work.chi(), &cube, &level, cell, grid)
    })
}

/// A leaf's χ − iso on the global grid points of its support, with its blending weights.
fn cut_to_support(chi: &[f32], cube: &Cube, level: &Level, cell: &LeafTask, grid: &LeafGrid) -> Solved {
    let (origin, h, n) = (&Point3::from(grid.origin), grid.h, grid.n);
    let local_n = cube.n;
    let (lo, hi) = support_range(cell, grid.scale, origin, h, n);
    let dims = [hi[0] - lo[0] + 1, hi[1] - lo[1] + 1, hi[2] - lo[2] + 1];
    // Global point (lo + a) sits at local index (lo + a) − offset; the octree keeps the two grids
    // aligned (cell corners and the doubled cube's corner fall on global grid points).
    let offset: [isize; 3] = std::array::from_fn(|d| ((cube.origin[d] - origin[d]) / h).round() as isize);
    let local: [Vec<usize>; 3] = std::array::from_fn(|d| {
        (0..dims[d]).map(|a| ((lo[d] + a) as isize - offset[d]).clamp(0, local_n as isize - 1) as usize).collect()
    });
    let coordinate = |d: usize, a: usize| origin[d] + (lo[d] + a) as Real * h;
    let u: Vec<Real> = (0..dims[0]).map(|x| (coordinate(0, x) - level.centre.x) / level.spread).collect();
    // The row's local points: a run of the local grid (the support lies inside the doubled cube), or
    // gathered one by one where it would not.
    let first = local[0][0];
    let run = local[0].iter().enumerate().all(|(x, &i)| i == first + x);
    let mut values = Vec::with_capacity(dims[0] * dims[1] * dims[2]);
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            let [a, b, c] = level.along_x(coordinate(1, y), coordinate(2, z));
            let row = &chi[local_n * (local[1][y] + local_n * local[2][z])..][..local_n];
            // Within f16's range, which the sweep holds values in ([`ActiveLeaf`]): a value past it
            // would turn to ±∞ there, and ∞ times a zero weight at the support's edge to NaN, which
            // marching cubes reads as outside. χ − iso is a few units at most; the clamp keeps the
            // sign of anything wilder.
            let value = |chi: f32, u: Real| (chi - (a + u * (b + u * c)) as f32).clamp(-F16_LIMIT, F16_LIMIT);
            if run {
                values.extend(row[first..][..dims[0]].iter().zip(&u).map(|(&chi, &u)| value(chi, u)));
            } else {
                values.extend(local[0].iter().zip(&u).map(|(&i, &u)| value(row[i], u)));
            }
        }
    }
    // Eq. 5.20's Gaussian about the centre (σ = half the edge), times (1 − t²)² in each axis so the
    // weight is zero at the support's edge (t = ±1).
    let half = grid.scale * cell.edge / 2.0;
    let sigma = cell.edge / 2.0;
    let weight = std::array::from_fn(|d| {
        (0..dims[d])
            .map(|a| {
                let x = origin[d] + (lo[d] + a) as Real * h - cell.centre[d];
                let t = (x / half).clamp(-1.0, 1.0);
                ((-0.5 * (x / sigma).powi(2)).exp() * (1.0 - t * t).powi(2)) as f32
            })
            .collect()
    });
    Solved { lo, dims, values, weight }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The level along a row is the level at each of its points.
    #[test]
    fn the_level_along_a_row_is_the_level() {
        let centre = Point3::new(1.0, -2.0, 0.5);
        let level = Level {
            coefficients: nalgebra::SVector::<Real, 10>::from_fn(|i, _| (i as Real * 0.37).sin()),
            centre,
            spread: 2.5,
        };
        for (x, y, z) in [(0.0, 0.0, 0.0), (3.0, -1.0, 2.0), (-4.0, 5.0, -6.0)] {
            let [a, b, c] = level.along_x(y, z);
            let u = (x - centre.x) / level.spread;
            let p = Point3::new(x, y, z);
            assert!((a + b * u + c * u * u - level.at(&p)).abs() < 1e-12);
        }
    }
}
