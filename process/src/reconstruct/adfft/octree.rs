//! AdFFT's plan: the samples' area weights, the error-guided octree (thesis 5.3, steps 1–2), the
//! grid the samples carry, the memory the sweep will take, and the coarse χ behind the leaves.

use super::leaf::{LeafGrid, LeafTask, Samples, support_range};
use super::params::{AdFftParams, AdFftReport};
use crate::kd_tree::PointTree;
use crate::reconstruct::global_fft::{
    Cube, FftReport, IndicatorWork, area_weights_in, bounding_cube, indicator, sample,
};
use crate::reconstruct::global_fft::{ReconstructError, check_memory, grid_bytes};
use crate::reconstruct::marching_cubes::{GridFrame, marching_cubes};
use crate::reconstruct::mesh_distance::MeshDistance;
use rayon::prelude::*;
use rig::math::{Point3, Real, Vector3};
use std::time::Instant;

/// An octree cell: its centre, edge and depth, and the indices of the points inside it.
#[derive(Debug, Clone)]
pub(super) struct Cell {
    pub(super) centre: Point3,
    pub(super) edge: Real,
    pub(super) depth: u32,
    pub(super) points: Vec<u32>,
}

impl Cell {
    /// What solving this cell as a leaf needs of it.
    fn task(&self) -> LeafTask {
        LeafTask { centre: self.centre.coords.into(), edge: self.edge }
    }
}

/// Whether a cell's local surface misses its samples by more than `error` on average (the thesis's
/// Hausdorff test over a tenth of them).
fn needs_split(samples: &Samples, cell: &Cell, params: &AdFftParams, error: Real) -> bool {
    let n = 1usize << params.test_depth;
    let mut work = IndicatorWork::new(n);
    let (cube, level) = samples.local_chi(&cell.task(), params.scale, &mut work, params.smoothing_cells);
    let chi = work.chi();
    let frame = GridFrame { dims: [n; 3], origin: cube.origin, spacing: cube.cell() };
    let mesh = marching_cubes(&frame, 0.0, |i, j, k| {
        if [i, j, k].iter().any(|&c| c == 0 || c == n - 1) {
            f32::NEG_INFINITY
        } else {
            chi[i + n * (j + n * k)] - level.at(&frame.point(i, j, k)) as f32
        }
    });
    if mesh.faces.is_empty() {
        return true;
    }
    let distance = MeshDistance::new(&mesh, 2.0 * cube.cell());
    let step = (1.0 / params.test_fraction.clamp(1e-3, 1.0)).round() as usize;
    let tested: Vec<Real> =
        cell.points.iter().step_by(step.max(1)).map(|&i| distance.distance(&samples.positions[i as usize])).collect();
    tested.iter().sum::<Real>() / tested.len().max(1) as Real > error
}

/// The 8 children of a cell with the points they hold (empty ones dropped).
pub(super) fn split(cell: &Cell, positions: &[Point3]) -> Vec<Cell> {
    let mut children: Vec<Cell> = (0..8)
        .map(|c| {
            let offset = Vector3::new(
                if c & 1 == 1 { 0.25 } else { -0.25 },
                if c & 2 == 2 { 0.25 } else { -0.25 },
                if c & 4 == 4 { 0.25 } else { -0.25 },
            );
            Cell {
                centre: cell.centre + offset * cell.edge,
                edge: cell.edge / 2.0,
                depth: cell.depth + 1,
                points: Vec::new(),
            }
        })
        .collect();
    for &i in &cell.points {
        let d = positions[i as usize] - cell.centre;
        let c = (d.x >= 0.0) as usize | ((d.y >= 0.0) as usize) << 1 | ((d.z >= 0.0) as usize) << 2;
        children[c].points.push(i);
    }
    children.retain(|c| !c.points.is_empty());
    children
}

/// Marching cubes' triangles per grid cell's worth of surface area (area / h²), measured on the
/// bunny (the ten aligned scans, whose area weights sum to 61,658 mm²): 296,308 triangles at 256³
/// (area / h² = 108,245: 2.74) and 1,193,708 at 512³ (432,980: 2.76).
pub const TRIANGLES_PER_AREA_CELL: Real = 2.75;

/// Bytes the finished mesh costs per triangle at its peak: the mesh itself (half a vertex of three f64
/// and a face of three u32, 24 bytes, with room for its vectors' growth) and what the clean-up holds
/// beside it (the components' labels; the self-intersection search's boxes and grid of cells).
pub const BYTES_PER_TRIANGLE: u64 = 160;

/// The memory the sweep will hold at its peak, from the octree before anything is solved: the
/// coarse grid, the solved leaves alive at once (the sweep's own bookkeeping, replayed on the support
/// ranges), one local FFT grid per thread, the planes marching cubes keeps, the samples, and the mesh
/// of `triangles` with its clean-up.
#[allow(clippy::too_many_arguments)]
fn estimate_bytes(
    leaves: &[Cell],
    ranges: &[([usize; 3], [usize; 3])],
    points: usize,
    n: usize,
    h: Real,
    coarse_depth: u32,
    triangles: u64,
) -> u64 {
    // A leaf holds its support's values from the plane it starts on and frees each plane the sweep has
    // passed: on plane k it holds dx·dy·(hi_z − k + 1) f16 values. Summed over the leaves with two
    // difference arrays (constant and slope in k), its peak over the planes.
    let (mut constant, mut slope) = (vec![0i128; n + 1], vec![0i128; n + 1]);
    for (lo, hi) in ranges {
        let row = 2 * ((hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1)) as i128;
        let weights = 4 * (hi[0] - lo[0] + hi[1] - lo[1] + hi[2] - lo[2] + 3) as i128;
        // bytes(k) = row·(hi_z + 1) + weights − row·k for lo_z ≤ k ≤ hi_z.
        constant[lo[2]] += row * (hi[2] as i128 + 1) + weights;
        constant[hi[2] + 1] -= row * (hi[2] as i128 + 1) + weights;
        slope[lo[2]] += row;
        slope[hi[2] + 1] -= row;
    }
    let (mut c, mut b, mut peak) = (0i128, 0i128, 0i128);
    for k in 0..n {
        c += constant[k];
        b += slope[k];
        peak = peak.max(c - b * k as i128);
    }
    let local = leaves
        .iter()
        .map(|c| {
            let local_n = ((2.0 * c.edge / h).round() as usize).max(4);
            IndicatorWork::bytes(local_n)
        })
        .max()
        .unwrap_or(0);
    let threads = rayon::current_num_threads() as u64;
    let coarse = grid_bytes(coarse_depth);
    let planes = 4 * 4 * (n as u64) * (n as u64);
    let samples = 96 * points as u64;
    coarse + peak.max(0) as u64 + threads * local + planes + samples + BYTES_PER_TRIANGLE * triangles
}

/// The fewest samples per surface cell a grid kept by [`AdFftParams::samples_per_cell`] may have:
/// below it the grid is refused up front. A 3,000-point sphere at depth 9 (0.003 per cell) swept for
/// a minute to find no surface; the fused bunny's 31,814 points at depth 9 (0.045) still make one.
pub const MIN_SAMPLES_PER_CELL: Real = 0.01;

/// Cells a surface crosses per unit area, times h²: a plane of unit normal n crosses
/// (|n_x| + |n_y| + |n_z|) / h² cells of a grid of spacing h per unit area, 1.5 / h² over all
/// directions (the mean of |n_x| is 1/2).
const CELLS_CROSSED_PER_AREA: Real = 1.5;

/// The depth to build the grid at, and the samples per cell crossing the surface there: `asked`, or
/// the finest depth below it (not below 6) whose cells on the surface hold at least `samples_per_cell`
/// samples each on average — `points` samples over `area` (their area weights' sum) in a bounding cube
/// of edge `size`. `samples_per_cell` 0 keeps `asked`. See [`AdFftParams::samples_per_cell`].
pub fn supported_depth(asked: u32, points: usize, area: Real, size: Real, samples_per_cell: Real) -> (u32, Real) {
    let per_cell = |d: u32| {
        let h = size / (1u64 << d) as Real;
        if area > 0.0 { points as Real * h * h / (CELLS_CROSSED_PER_AREA * area) } else { Real::INFINITY }
    };
    let mut depth = asked;
    while depth > asked.min(6) && per_cell(depth) < samples_per_cell {
        depth -= 1;
    }
    (depth, per_cell(depth))
}

/// The coarse global χ behind the leaves (step 4), solved once beside the octree and handed to every
/// slab: it answers where no leaf reaches — the empty cells deep inside the object and far outside —
/// and outweighs a leaf in the fringe of its support, where the local solid closes itself with a
/// surface that belongs to no data.
#[derive(Debug, Clone, PartialEq)]
pub struct CoarseChi {
    /// Points per axis, over the same cube as the global grid.
    pub n: usize,
    /// χ at those points, x fastest.
    pub values: Vec<f32>,
    /// Its level: the mean of χ over the samples.
    pub iso: Real,
    /// Its blending weight ([`AdFftParams::coarse_weight`]).
    pub weight: Real,
}

/// The octree and what the sweep needs beside it.
pub(super) struct Plan<'a> {
    pub(super) samples: Samples<'a>,
    pub(super) leaves: Vec<Cell>,
    pub(super) ranges: Vec<([usize; 3], [usize; 3])>,
    pub(super) origin: Point3,
    pub(super) size: Real,
    pub(super) h: Real,
    pub(super) n: usize,
    pub(super) report: AdFftReport,
}

impl Plan<'_> {
    pub(super) fn grid(&self, params: &AdFftParams) -> LeafGrid {
        LeafGrid {
            origin: self.origin.coords.into(),
            h: self.h,
            n: self.n,
            scale: params.scale,
            smoothing_cells: params.smoothing_cells,
        }
    }

    pub(super) fn tasks(&self) -> Vec<LeafTask> {
        self.leaves.iter().map(Cell::task).collect()
    }
}

/// Checks, the samples' weights and tree, the octree (steps 1–2) and the memory check.
pub(super) fn plan<'a>(cloud: rig::CloudRef<'a>, params: &AdFftParams) -> Result<Plan<'a>, ReconstructError> {
    if cloud.is_empty() {
        return Err(ReconstructError::Empty);
    }
    let normals = cloud.normals.ok_or(ReconstructError::NoNormals)?;
    if !(6..=12).contains(&params.depth) || !(3..=7).contains(&params.test_depth) {
        return Err(ReconstructError::Params(format!(
            "AdFFT depth must be 6–12 and test depth 3–7, got {} and {}",
            params.depth, params.test_depth
        )));
    }
    // The fields no option sets (the depth above goes to 12 here, for the memory estimate's benches).
    params.check_fields().map_err(|e| ReconstructError::Params(e.to_string()))?;
    if !(params.samples_per_cell >= 0.0 && params.samples_per_cell.is_finite()) {
        return Err(ReconstructError::Params(format!(
            "AdFFT's samples per cell must be a number ≥ 0, got {}",
            params.samples_per_cell
        )));
    }
    let start = Instant::now();
    let (origin, size) = bounding_cube(cloud.positions, params.padding);
    let tree = PointTree::new(cloud.positions);
    let weights = area_weights_in(cloud.positions, params.area_k, &tree);
    let samples = Samples::with_tree(cloud.positions, normals, weights, tree);
    let area: Real = samples.weights.iter().sum();
    let (depth, per_cell) = supported_depth(params.depth, cloud.len(), area, size, params.samples_per_cell);
    if per_cell < MIN_SAMPLES_PER_CELL {
        return Err(ReconstructError::Params(format!(
            "--samples-per-cell {} keeps AdFFT's grid at depth {depth}, where the surface's cells would hold \
             {per_cell:.1e} samples each: too few to show a surface (leave --samples-per-cell at its default, \
             or lower --depth)",
            params.samples_per_cell
        )));
    }
    let n = 1usize << depth;
    let h = size / n as Real;
    let error = params.error.unwrap_or(0.5 * h);
    let mut report = AdFftReport {
        depth_asked: params.depth,
        depth,
        samples_per_cell: per_cell,
        n,
        cell: h,
        error,
        ..Default::default()
    };
    // Octree: unconditional splits down to the depth where a leaf's local grid is at most 128³ at the
    // finest depth the samples carry (one level finer than the grid at most), then the error test;
    // leaves stop where the local grid would drop below the test's resolution. Leaves are sized by
    // the samples, not by the output's cells: the bunny at depth 8 with leaves of 64 cells (48 mm,
    // 128³ local grids) took 2.3 s and 212 MB for 0.0520 mm; with those of depth 9, 32 cells of
    // depth 8 (24 mm, 64³ local grids), 1.3 s and 120 MB for 0.0536 mm, depth 9's own 0.0538.
    let finest = if params.samples_per_cell > 0.0 {
        supported_depth(12, cloud.len(), area, size, params.samples_per_cell).0
    } else {
        depth
    };
    let max_depth = depth - params.test_depth + 1;
    // Not past the last level the error test runs at.
    let min_depth = finest.clamp(depth, depth + 1).saturating_sub(6).min(max_depth);
    let min_split = (4.0 * params.min_points * cloud.len() as Real).ceil() as usize;
    let root = Cell {
        centre: origin + Vector3::repeat(size / 2.0),
        edge: size,
        depth: 0,
        points: (0..cloud.len() as u32).collect(),
    };
    let mut level = vec![root];
    let mut leaves = Vec::new();
    while !level.is_empty() {
        let decisions: Vec<bool> = level
            .par_iter()
            .map(|c| {
                c.depth < min_depth
                    || (c.depth < max_depth && c.points.len() >= min_split && needs_split(&samples, c, params, error))
            })
            .collect();
        report.tests +=
            level.iter().filter(|c| c.depth >= min_depth && c.depth < max_depth && c.points.len() >= min_split).count();
        let mut next = Vec::new();
        for (cell, split_it) in level.into_iter().zip(decisions) {
            if split_it {
                next.extend(split(&cell, cloud.positions));
            } else {
                leaves.push(cell);
            }
        }
        level = next;
    }
    report.leaves_by_depth = vec![0; max_depth as usize + 1];
    for l in &leaves {
        report.leaves_by_depth[l.depth as usize] += 1;
    }
    report.seconds_octree = start.elapsed().as_secs_f64();
    let ranges: Vec<([usize; 3], [usize; 3])> =
        leaves.iter().map(|c| support_range(&c.task(), params.scale, &origin, h, n)).collect();
    // The mesh's size follows the surface's area over the cell's: at depth 11 it, not the sweep, is
    // most of the memory (the bunny: ≈ 19 M triangles), and left out the estimate let such a run start
    // and exhaust the machine instead of being refused here.
    report.estimated_triangles = (TRIANGLES_PER_AREA_CELL * area / (h * h)).ceil() as u64;
    report.estimated_bytes =
        estimate_bytes(&leaves, &ranges, cloud.len(), n, h, params.coarse_depth.min(depth), report.estimated_triangles);
    check_memory(report.estimated_bytes, n, params.memory_budget, "--method adfft", "lower --depth")?;

    Ok(Plan { samples, leaves, ranges, origin, size, h, n, report })
}

impl Plan<'_> {
    pub(super) fn coarse(&self, params: &AdFftParams) -> CoarseChi {
        let coarse_n = 1usize << params.coarse_depth.min(self.report.depth);
        let cube = Cube { origin: self.origin, size: self.size, n: coarse_n };
        let s = &self.samples;
        let values = indicator(s.positions, s.normals, &s.weights, &cube, 1.0, &mut FftReport::default());
        // In order, not by a parallel sum: every slab must blend the very same level.
        let iso = s.positions.iter().map(|p| sample(&values, coarse_n, self.origin, cube.cell(), p)).sum::<Real>()
            / s.positions.len() as Real;
        CoarseChi { n: coarse_n, values, iso, weight: params.coarse_weight }
    }
}
