//! AdFFT: the FFT method made local by an error-guided octree and partition-of-unity blending
//! (thesis section 5.3), to reach a high global resolution without a global N³ grid.
//!
//! 1. Octree over the points' bounding cube. A cell's local indicator χ is solved by the global
//!    method on a cube of twice its edge centred on it, from the points in the cell scaled by
//!    c = 1.8 about its centre (so the solid's irrelevant closing surface falls outside the cell).
//! 2. Subdivision test: the local χ at 2⁵ points per axis, marching cubes, and the mean distance of 10 %
//!    of the cell's points to that mesh against the user's error. A cell is not split below a minimum
//!    number of points (0.5 % of the input), so noise cannot drive the octree down to empty cells.
//! 3. Every leaf is solved again so all share one global grid spacing (larger leaves at a higher local
//!    resolution), normalised to a unit jump with its own iso-level at 0.
//! 4. Marching cubes over the global grid, plane by plane; at each grid point the leaves' χ are
//!    blended (eqs. 5.19–5.20) with Gaussian weights about the leaf centres, windowed to vanish at the
//!    edge of each leaf's support, together with a coarse (64³) global χ at a small constant weight.
//!    A leaf's χ is solved when the sweep reaches its support and dropped once it has passed, so
//!    memory follows the leaves along one plane, not the whole volume.
//!
//! The global grid is no finer than the samples carry ([`supported_depth`]), as Poisson's octree
//! adapts. The sweep can run in slabs of planes on other machines ([`reconstruct_adfft_slabs`]):
//! each leaf solved once and cut into the parts the slabs it reaches need, each slab marching its own
//! layers, and the slabs' meshes join along their shared planes into the very mesh of the whole sweep.
//!
//! Deviations, each for a reason: the octree spans the bounding *cube* (cells stay cubes, so the local
//! FFT needs no anisotropic scaling, which would also bend the normals); the Gaussian of eq. 5.20 is
//! multiplied by a smooth window that reaches zero at the support's edge, so the blend is continuous
//! where a support ends; leaves at least 2⁻⁶ of the global grid keep each local solve within 128³; the
//! coarse global χ gives the empty cells a side (the thesis polygonises only inside solved cells, which
//! leaves holes where the surface would cross into an empty one, and a shell where inside meets none).

use super::global_fft::{
    Cube, FftReport, IndicatorWork, area_weights_in, bounding_cube, indicator, sample, solve_indicator,
};
use super::marching_cubes::{GridFrame, join_slabs, marching_cubes, marching_cubes_layers};
use super::mesh_distance::MeshDistance;
use crate::kd_tree::PointTree;
use half::f16;
use half::slice::HalfFloatSliceExt;
use rayon::prelude::*;
use rig::TriMesh;
use rig::math::{Point3, Real, Vector3};
use serde::Serialize;
use std::ops::Range;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// Settings of AdFFT.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AdFftParams {
    /// The global grid: 2^depth points per axis over the bounding cube.
    pub depth: u32,
    /// The mean distance (cloud units) of a cell's samples to its local surface above which the cell
    /// is split; `None` takes half the global grid spacing.
    pub error: Option<Real>,
    /// Points within the cell scaled by this about its centre feed its local solution (c = 1.8).
    pub scale: Real,
    /// The subdivision test's local grid: 2^test_depth points per axis (2⁵ in the thesis).
    pub test_depth: u32,
    /// Fraction of a cell's points whose distance is tested (10 % in the thesis).
    pub test_fraction: Real,
    /// A cell holding fewer than 4× this fraction of all points is not split (0.5 % in the thesis).
    pub min_points: Real,
    /// Margin of the bounding cube, as for the global method.
    pub padding: Real,
    /// Gaussian low-pass, in grid cells. On the bunny at 256³ with quadratic levels, 0.5 cells and 8
    /// area neighbours gave a mean of accuracy and completeness of 0.0579 mm, 0.25 cells and 16
    /// neighbours 0.0535 (before the ridge was lightened); with affine levels and 8 neighbours, 0.5 →
    /// 0.25 cells went 0.0667 → 0.0621. Less smoothing hardly helps the global method further (0.0595
    /// at 0.25, 0.0593 at 0.1, 0.0592 at 0).
    pub smoothing_cells: Real,
    /// Neighbours for the area weights. More neighbours give smoother weights, and the weights' noise
    /// is noise in the splatted normal field: on the bunny at 256³, AdFFT went from 0.0621 (8) to
    /// 0.0592 (16) and 0.0588 (32) with affine levels; the global method from 0.0595 (8) to 0.0533 (16,
    /// 32) and 0.0524 (64), at 0.25 cells.
    pub area_k: usize,
    /// Components under this fraction of the largest's area are dropped.
    pub min_component: Real,
    /// The coarse global solution behind the leaves: its grid depth and its blending weight (a leaf's
    /// weight is 1 at its centre). On the bunny at 512³, weights 0.01 / 0.05 / 0.15 / 0.3 gave a mean
    /// of accuracy and completeness of 0.0644 / 0.0628 / 0.0593 / 0.0593 mm: the smooth coarse χ
    /// steadies the level where neighbouring leaves disagree.
    pub coarse_depth: u32,
    /// See `coarse_depth`.
    pub coarse_weight: Real,
    /// Refuse reconstructions estimated to need more than this many bytes (default 8 GB).
    pub memory_budget: u64,
    /// The grid is made no finer than the samples carry: `depth`, or the finest depth below it at
    /// which the cells the surface crosses hold at least this many samples each on average
    /// ([`supported_depth`]); 0 keeps `depth` whatever the samples. Poisson's octree adapts the same
    /// way (PoissonRecon's `--samplesPerNode`): on the bunny's 362,272 points the peers' meshes at
    /// depth 10 have the triangles of depth 9 (Open3D 1.12 M at both, PoissonRecon 1.13 → 1.25 M),
    /// while AdFFT on the full 1024³ grid made 5.0 M triangles of genus 68 in 88 s: cells of 0.19 mm
    /// between samples 0.41 mm apart resolve their noise, not the surface. At 0.25 the bunny keeps
    /// depth 9 (0.56 samples per cell) and stops there (depth 10: 0.14).
    pub samples_per_cell: Real,
}

impl Default for AdFftParams {
    fn default() -> Self {
        AdFftParams {
            depth: 9,
            error: None,
            scale: 1.8,
            test_depth: 5,
            test_fraction: 0.1,
            min_points: 0.005,
            padding: 0.05,
            smoothing_cells: 0.25,
            area_k: 16,
            min_component: 0.01,
            coarse_depth: 6,
            coarse_weight: 0.15,
            memory_budget: 8_000_000_000,
            samples_per_cell: 0.25,
        }
    }
}

/// What AdFFT did.
#[derive(Debug, Clone, Default, Serialize, serde::Deserialize)]
pub struct AdFftReport {
    /// The depth asked for ([`AdFftParams::depth`]).
    #[serde(default)]
    pub depth_asked: u32,
    /// The depth the grid was built at: the one asked, or less where the samples carry no finer
    /// detail ([`supported_depth`]).
    #[serde(default)]
    pub depth: u32,
    /// The samples per cell crossing the surface at that depth, on average.
    #[serde(default)]
    pub samples_per_cell: Real,
    /// Global grid points per axis.
    pub n: usize,
    /// Global grid spacing.
    pub cell: Real,
    /// The memory the reconstruction was estimated to need before it started (bytes).
    #[serde(default)]
    pub estimated_bytes: u64,
    /// The triangles the mesh was estimated to have before it started (from the samples' area; see
    /// [`TRIANGLES_PER_AREA_CELL`]).
    #[serde(default)]
    pub estimated_triangles: u64,
    /// The extracted surface's pull onto its samples ([`super::fit`]).
    #[serde(default)]
    pub fit: super::fit::FitReport,
    /// Self-intersections where blended leaves folded the surface, and their repair.
    #[serde(default)]
    pub self_intersections: super::self_intersect::RepairReport,
    /// The error the subdivision aimed for.
    pub error: Real,
    /// Leaves solved (the patches blended), by octree depth.
    pub leaves_by_depth: Vec<usize>,
    /// Cells whose subdivision was tested.
    pub tests: usize,
    /// Most leaves held in memory at once during the sweep (0 when swept in slabs elsewhere).
    pub peak_active_leaves: usize,
    /// Output size.
    pub vertices: usize,
    /// Output size.
    pub triangles: usize,
    /// Small components dropped.
    pub components_pruned: usize,
    /// Seconds building and testing the octree.
    pub seconds_octree: Real,
    /// Seconds solving leaves, blending and extracting.
    pub seconds_extract: Real,
}

impl AdFftReport {
    /// Leaves (patches) in all.
    pub fn leaves(&self) -> usize {
        self.leaves_by_depth.iter().sum()
    }

    /// What to tell the user when the grid was built shallower than asked
    /// ([`AdFftParams::samples_per_cell`]), `None` when it was built as asked: a depth asked and a
    /// coarser mesh made, unexplained, reads as a defect.
    pub fn shallower_than_asked(&self) -> Option<String> {
        (self.depth < self.depth_asked).then(|| {
            format!(
                "depth {} asked; built at depth {}, where the surface's cells hold {:.2} samples each: the samples \
                 carry no finer detail (--samples-per-cell 0 keeps depth {})",
                self.depth_asked, self.depth, self.samples_per_cell, self.depth_asked
            )
        })
    }

    /// What to tell the user when many vertices were further from their samples' plane than the fit
    /// may move them ([`super::fit`], half a cell): over 5 % of those moved. `None` otherwise (the
    /// bunny at depth 9: 0.3 %). On a grid no finer than the default builds, it says the indicator's
    /// surface and the samples disagree — normals turned the wrong way, or scans out of alignment. On
    /// a grid finer than that (`--samples-per-cell 0`, or a sparse cloud at the depth-6 floor), it says so: there
    /// the surface strays between samples further apart than its cells, and the remedy is the grid
    /// (bun_zipper_res2's 5,923 fused points forced onto 128³, 0.15 samples per cell: 9.7 % held;
    /// the default's 64³, 0.60 per cell: 3.7 %).
    pub fn far_from_samples(&self) -> Option<String> {
        let f = &self.fit;
        if !(f.moved > 0 && f.limited as Real > 0.05 * f.moved as Real) {
            return None;
        }
        let held = format!(
            "{:.1} % of the vertices were more than half a cell ({}) from their samples' plane and moved only that far",
            100.0 * f.limited as Real / f.moved as Real,
            three_digits(0.5 * self.cell)
        );
        let default = AdFftParams::default().samples_per_cell;
        Some(if self.samples_per_cell > 0.0 && self.samples_per_cell < default {
            format!(
                "{held}: the grid is finer than the samples carry ({:.2} samples per cell on the surface, fewer than \
                 the default's {default}), so the surface strays between them (a lower --depth keeps it to what the \
                 samples show)",
                self.samples_per_cell
            )
        } else {
            format!(
                "{held}: the surface and the samples disagree there (normals turned the wrong way, or scans out of \
                 alignment?)"
            )
        })
    }
}

/// `x` to three significant digits: a half cell of a cloud in metres (0.000291) is not "0.000".
fn three_digits(x: Real) -> String {
    let decimals = if x.is_finite() && x != 0.0 { (2 - x.abs().log10().floor() as i32).max(0) as usize } else { 3 };
    format!("{x:.decimals$}")
}

/// An octree cell: its centre, edge and depth, and the indices of the points inside it.
#[derive(Debug, Clone)]
struct Cell {
    centre: Point3,
    edge: Real,
    depth: u32,
    points: Vec<u32>,
}

impl Cell {
    /// What solving this cell as a leaf needs of it.
    fn task(&self) -> LeafTask {
        LeafTask { centre: self.centre.coords.into(), edge: self.edge }
    }
}

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
    pub scale: Real,
    /// [`AdFftParams::smoothing_cells`].
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
        // The same ranges as the library's own entry ([`crate::limits::check_adfft_fields`]): these
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
pub struct LeafSolver<'a> {
    samples: Samples<'a>,
}

impl<'a> LeafSolver<'a> {
    /// A solver over the oriented samples and their area weights (as [`reconstruct_adfft_slabs`]
    /// hands them out in its [`SlabJob`]).
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
struct Samples<'a> {
    positions: &'a [Point3],
    normals: &'a [Vector3],
    weights: Vec<Real>,
    tree: PointTree,
    /// Local solves' buffers, handed from one leaf to the next ([`Samples::solve_in_work`]): at most
    /// one per thread, so no more than the solves running at once hold.
    works: Mutex<Vec<IndicatorWork>>,
}

impl<'a> Samples<'a> {
    fn new(positions: &'a [Point3], normals: &'a [Vector3], weights: Vec<Real>) -> Self {
        Self::with_tree(positions, normals, weights, PointTree::new(positions))
    }

    fn with_tree(positions: &'a [Point3], normals: &'a [Vector3], weights: Vec<Real>, tree: PointTree) -> Self {
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
    fn release_works(&self) {
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
    fn local_chi(
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
struct Level {
    coefficients: nalgebra::SVector<Real, 10>,
    centre: Point3,
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
    fn fit(points: &[Point3], values: &[Real], centre: Point3) -> Level {
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

    fn at(&self, p: &Point3) -> Real {
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
fn split(cell: &Cell, positions: &[Point3]) -> Vec<Cell> {
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

/// A solved leaf as the sweep holds it: its values plane by plane, each freed once the sweep has
/// passed it, so a leaf costs memory only for the part of its support still ahead; and in 16-bit
/// floats, half the bytes again. The values are χ − iso, within a few units of 0, where f16 keeps
/// 11 significant bits: a zero crossing moves by ~10⁻⁴ of a cell (the bunny at 512³: the mean of
/// accuracy and completeness 0.053765 mm with f32 values, 0.053761 with f16). Planes freed and f16
/// took AdFFT's peak there from 510–620 MiB to 350–380 MiB (issue 42: PoissonRecon's is ~372).
struct ActiveLeaf {
    /// The leaf's index in the octree's list: the blend sums the leaves in this order wherever a plane
    /// is computed (the local sweep or a slab of a distributed one), so its value is the same bits.
    id: usize,
    lo: [usize; 3],
    dims: [usize; 3],
    /// χ − iso on each plane of the support (x fastest), empty once swept.
    planes: Vec<Vec<f16>>,
    weight: [Vec<f32>; 3],
}

/// The largest magnitude a leaf's value is kept at (f16's largest finite value).
const F16_LIMIT: f32 = 65504.0;

impl ActiveLeaf {
    fn new(id: usize, s: SolvedLeaf) -> Self {
        let planes = s
            .values
            .chunks(s.dims[0] * s.dims[1])
            .map(|plane| {
                let mut half = vec![f16::ZERO; plane.len()];
                half.convert_from_f32_slice(plane);
                half
            })
            .collect();
        ActiveLeaf { id, lo: s.lo, dims: s.dims, planes, weight: s.weight }
    }
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
    let coarse = super::global_fft::grid_bytes(coarse_depth);
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

/// The global grid index range a leaf's support covers, clamped to the grid.
fn support_range(cell: &LeafTask, scale: Real, origin: &Point3, h: Real, n: usize) -> ([usize; 3], [usize; 3]) {
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
fn solve_leaf(samples: &Samples, cell: &LeafTask, grid: &LeafGrid, parallel: bool) -> Solved {
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

/// Reconstructs a watertight mesh by AdFFT.
pub fn reconstruct_adfft<'a>(
    cloud: impl Into<rig::CloudRef<'a>>,
    params: &AdFftParams,
) -> Result<(TriMesh, AdFftReport), super::global_fft::ReconstructError> {
    reconstruct_adfft_counting(cloud, params, &AtomicUsize::new(0))
}

/// [`reconstruct_adfft`], counting in `planes` the sweep's planes done (up to 2^depth), for a
/// progress display ([`crate::pipeline::watch`]): at depth 10 the sweep runs for minutes.
pub fn reconstruct_adfft_counting<'a>(
    cloud: impl Into<rig::CloudRef<'a>>,
    params: &AdFftParams,
    planes: &AtomicUsize,
) -> Result<(TriMesh, AdFftReport), super::global_fft::ReconstructError> {
    adfft_of(cloud.into(), params, planes)
}

/// [`reconstruct_adfft_counting`]'s body, compiled once here: generic over the caller's cloud type,
/// the whole reconstruction was compiled again into every crate that called it.
fn adfft_of(
    cloud: rig::CloudRef<'_>,
    params: &AdFftParams,
    planes: &AtomicUsize,
) -> Result<(TriMesh, AdFftReport), super::global_fft::ReconstructError> {
    let plan = plan(cloud, params)?;
    let t = Instant::now();
    let (grid, leaves, coarse) = (plan.grid(params), plan.tasks(), plan.coarse(params));
    // The sweep: leaves ordered by where their support starts in z, each solved when the sweep reaches
    // it, those starting on one plane in parallel (cut into planes as each is solved: one thread's
    // leaf at a time is held whole).
    let mut order: Vec<usize> = (0..leaves.len()).collect();
    order.sort_by_key(|&l| plan.ranges[l].0[2]);
    let mut next = 0;
    let step = 1usize << (plan.report.depth_asked - plan.report.depth);
    let samples = &plan.samples;
    let (mesh, peak) = extract(&grid, &coarse, 0..grid.n - 1, planes, step, |k| {
        let starting: Vec<usize> = order[next..].iter().copied().take_while(|&l| plan.ranges[l].0[2] <= k).collect();
        next += starting.len();
        // Fewer leaves than threads: each solve spreads over them; more: a solve per thread.
        let parallel = starting.len() < rayon::current_num_threads();
        starting.par_iter().map(|&l| ActiveLeaf::new(l, solve_leaf(samples, &leaves[l], &grid, parallel))).collect()
    });
    let Plan { samples, mut report, .. } = plan;
    report.peak_active_leaves = peak;
    samples.release_works();
    // The sweep freed its leaves a plane at a time, in small blocks the allocator keeps resident;
    // handed back, the clean-up's peak starts from the mesh, not from the sweep's high-water mark.
    crate::pipeline::memory::release_freed();
    Ok(clean(mesh, &samples, params, report, t))
}

/// A sweep to be done in slabs of cube layers, on other machines say ([`reconstruct_adfft_slabs`]):
/// every leaf is solved once, somewhere ([`LeafSolver`]), and cut into the parts the slabs its
/// support reaches need ([`slab_part`]); each slab is then swept from its parts ([`sweep_slab`]).
#[derive(Debug, Clone)]
pub struct SlabJob<'a> {
    /// Every leaf, in the octree's order (a leaf's index is its id in [`sweep_slab`]).
    pub tasks: Vec<LeafTask>,
    /// The global grid.
    pub grid: LeafGrid,
    /// The samples' area weights, as the leaf solves need them.
    pub weights: &'a [Real],
    /// The coarse χ behind the leaves.
    pub coarse: CoarseChi,
    /// Each slab's cube layers (layer k: the cubes between planes k and k + 1), in order, covering
    /// 0..n − 1; balanced by the blend's work (the grid's plane plus the supports crossing it).
    pub layers: Vec<Range<usize>>,
}

/// [`reconstruct_adfft`] with its sweep done in `slabs` slabs by `sweep_all`: given the [`SlabJob`],
/// it returns each slab's mesh, in order, as [`sweep_slab`] makes it. The octree, the coarse χ and
/// the clean-up run here, and nothing else of the sweep: the solved leaves never come here. The
/// slabs' meshes joined along their shared planes are the whole sweep's, so the mesh is the one
/// [`reconstruct_adfft`] makes.
pub fn reconstruct_adfft_slabs<'a>(
    cloud: impl Into<rig::CloudRef<'a>>,
    params: &AdFftParams,
    slabs: usize,
    sweep_all: impl FnOnce(&SlabJob) -> Result<Vec<TriMesh>, String>,
) -> Result<(TriMesh, AdFftReport), super::global_fft::ReconstructError> {
    use super::global_fft::ReconstructError;
    let cloud = cloud.into();
    let plan = plan(cloud, params)?;
    let t = Instant::now();
    let layers = slab_layers(&plan.ranges, plan.n, slabs.max(1));
    let job = SlabJob {
        tasks: plan.tasks(),
        grid: plan.grid(params),
        weights: &plan.samples.weights,
        coarse: plan.coarse(params),
        layers,
    };
    let meshes = sweep_all(&job).map_err(ReconstructError::Leaves)?;
    if meshes.len() != job.layers.len() {
        return Err(ReconstructError::Leaves(format!("{} slabs swept of {}", meshes.len(), job.layers.len())));
    }
    for (s, m) in meshes.iter().enumerate() {
        let bad = m.faces.iter().flatten().any(|&v| v as usize >= m.vertices.len())
            || m.vertices.iter().any(|p| !p.coords.iter().all(|c| c.is_finite()));
        if bad {
            return Err(ReconstructError::Leaves(format!("slab {s} came back with a broken mesh")));
        }
    }
    let frame = GridFrame { dims: [plan.n; 3], origin: plan.origin, spacing: plan.h };
    let boundaries: Vec<usize> = job.layers.iter().map(|l| l.end).collect();
    let mesh = join_slabs(meshes, &frame, &boundaries[..boundaries.len() - 1]);
    drop(job);
    let Plan { samples, report, .. } = plan;
    Ok(clean(mesh, &samples, params, report, t))
}

/// Cube layers 0..n − 1 cut into `slabs` runs of about equal blending work: each plane costs its n²
/// points (the coarse χ and marching cubes) plus the points of every support crossing it.
fn slab_layers(ranges: &[([usize; 3], [usize; 3])], n: usize, slabs: usize) -> Vec<Range<usize>> {
    let mut change = vec![0i64; n + 1];
    for (lo, hi) in ranges {
        let area = ((hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1)) as i64;
        change[lo[2]] += area;
        change[hi[2] + 1] -= area;
    }
    let mut cost = Vec::with_capacity(n);
    let mut running = 0i64;
    for c in change.iter().take(n) {
        running += c;
        cost.push((n * n) as i64 + running);
    }
    let total: i64 = cost.iter().sum();
    let mut layers = Vec::new();
    let (mut start, mut done) = (0, 0i64);
    for (k, c) in cost.iter().enumerate().take(n - 1) {
        done += c;
        let wanted = total * (layers.len() as i64 + 1) / slabs as i64;
        // Every slab keeps at least one layer, the last included.
        if done >= wanted && layers.len() + 1 < slabs && k + 1 < n - 1 {
            layers.push(start..k + 1);
            start = k + 1;
        }
    }
    layers.push(start..n - 1);
    layers
}

/// The part of a solved leaf a slab of `layers` blends: its planes from one below the first layer
/// to one above the last (the planes [`marching_cubes_layers`] reads), `None` where it has none.
pub fn slab_part(solved: &SolvedLeaf, layers: &Range<usize>, n: usize) -> Option<SolvedLeaf> {
    let first = layers.start.saturating_sub(1).max(solved.lo[2]);
    let last = (layers.end + 1).min(n - 1).min(solved.lo[2] + solved.dims[2] - 1);
    if first > last {
        return None;
    }
    let plane = solved.dims[0] * solved.dims[1];
    let (a, b) = (first - solved.lo[2], last - solved.lo[2] + 1);
    Some(SolvedLeaf {
        lo: [solved.lo[0], solved.lo[1], first],
        dims: [solved.dims[0], solved.dims[1], b - a],
        values: solved.values[a * plane..b * plane].to_vec(),
        weight: [solved.weight[0].clone(), solved.weight[1].clone(), solved.weight[2][a..b].to_vec()],
    })
}

/// One slab of a distributed sweep: marching cubes over the blend (eqs. 5.19–5.20) of `layers`,
/// from the parts of every leaf whose support reaches them (`(id, part)`: the leaf's index in
/// [`SlabJob::tasks`] and [`slab_part`] of its solve) and the coarse χ. A part that does not fit
/// the grid is refused, naming the leaf.
pub fn sweep_slab(
    mut parts: Vec<(usize, SolvedLeaf)>,
    coarse: &CoarseChi,
    grid: &LeafGrid,
    layers: Range<usize>,
) -> Result<TriMesh, String> {
    grid.check(std::slice::from_ref(&layers))?;
    let n = grid.n;
    if coarse.n == 0 || coarse.values.len() != coarse.n.pow(3) {
        return Err(format!("coarse χ of {} values for {}³ points", coarse.values.len(), coarse.n));
    }
    for (id, p) in &parts {
        let fits = (0..3).all(|d| p.dims[d] > 0 && p.lo[d] + p.dims[d] <= n && p.weight[d].len() == p.dims[d])
            && p.values.len() == p.dims.iter().product::<usize>();
        if !fits {
            return Err(format!("leaf {id}: its part does not fit the grid"));
        }
    }
    parts.sort_by_key(|(id, p)| (p.lo[2], *id));
    let mut parts = parts.into_iter().peekable();
    let (mesh, _) = extract(grid, coarse, layers, &AtomicUsize::new(0), 1, |k| {
        let mut starting = Vec::new();
        while let Some((id, part)) = parts.next_if(|(_, p)| p.lo[2] <= k) {
            starting.push(ActiveLeaf::new(id, part));
        }
        starting
    });
    Ok(mesh)
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
struct Plan<'a> {
    samples: Samples<'a>,
    leaves: Vec<Cell>,
    ranges: Vec<([usize; 3], [usize; 3])>,
    origin: Point3,
    size: Real,
    h: Real,
    n: usize,
    report: AdFftReport,
}

impl Plan<'_> {
    fn grid(&self, params: &AdFftParams) -> LeafGrid {
        LeafGrid {
            origin: self.origin.coords.into(),
            h: self.h,
            n: self.n,
            scale: params.scale,
            smoothing_cells: params.smoothing_cells,
        }
    }

    fn tasks(&self) -> Vec<LeafTask> {
        self.leaves.iter().map(Cell::task).collect()
    }
}

/// Checks, the samples' weights and tree, the octree (steps 1–2) and the memory check.
fn plan<'a>(cloud: rig::CloudRef<'a>, params: &AdFftParams) -> Result<Plan<'a>, super::global_fft::ReconstructError> {
    use super::global_fft::ReconstructError;
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
    crate::limits::check_adfft_fields(params).map_err(|e| ReconstructError::Params(e.to_string()))?;
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
    super::global_fft::check_memory(
        report.estimated_bytes,
        n,
        params.memory_budget,
        "--method adfft",
        "lower --depth",
    )?;

    Ok(Plan { samples, leaves, ranges, origin, size, h, n, report })
}

impl Plan<'_> {
    fn coarse(&self, params: &AdFftParams) -> CoarseChi {
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

/// Eq. 5.19 plane by plane: Σ w_i f_i / Σ w_i over the leaves whose support holds a point, with the
/// coarse χ at its small constant weight.
struct Blend<'a> {
    coarse: &'a CoarseChi,
    n: usize,
    /// Trilinear interpolation is linear along each axis in turn, so a plane interpolates the coarse
    /// grid once in z, a row once in y, and each point once in x (eight lookups per point had been a
    /// sixth of the run). `taps[i]`: the two coarse planes about fine index i (the coarse grid wraps,
    /// as `sample` reads it) and the weight of the second.
    taps: Vec<(usize, usize, Real)>,
}

impl<'a> Blend<'a> {
    fn new(coarse: &'a CoarseChi, n: usize) -> Self {
        // Both grids span the same cube: a fine index i is at coarse index i·coarse_n/n.
        let ratio = coarse.n as Real / n as Real;
        let taps = (0..n)
            .map(|i| {
                let u = i as Real * ratio;
                let b = u.floor();
                let wrap = |v: Real| (v as isize).rem_euclid(coarse.n as isize) as usize;
                (wrap(b), wrap(b + 1.0), u - b)
            })
            .collect();
        Blend { coarse, n, taps }
    }

    /// Plane k of the blend over `active` (which must be in id order; the border stays outside).
    fn plane(&self, k: usize, active: &[ActiveLeaf]) -> Vec<f32> {
        let (n, cn, taps) = (self.n, self.coarse.n, &self.taps);
        let (coarse, eps, coarse_iso) = (&self.coarse.values, self.coarse.weight as f32, self.coarse.iso);
        // The coarse χ interpolated to this plane (cn² values, x fastest).
        let (z0, z1, fz) = taps[k];
        let slice: Vec<Real> = (0..cn * cn)
            .map(|xy| {
                let at = |z: usize| coarse[xy + cn * cn * z] as Real;
                (1.0 - fz) * at(z0) + fz * at(z1)
            })
            .collect();
        let mut plane = vec![f32::NAN; n * n];
        plane.par_chunks_mut(n).enumerate().for_each(|(j, row)| {
            if j == 0 || j == n - 1 || k == 0 || k == n - 1 {
                return; // the border stays outside, closing the surface
            }
            let (y0, y1, fy) = taps[j];
            let line: Vec<Real> = (0..cn).map(|x| (1.0 - fy) * slice[x + cn * y0] + fy * slice[x + cn * y1]).collect();
            let mut num: Vec<f32> = taps
                .iter()
                .map(|&(x0, x1, fx)| eps * ((1.0 - fx) * line[x0] + fx * line[x1] - coarse_iso) as f32)
                .collect();
            let mut den = vec![eps; n];
            let mut values = Vec::new();
            for s in active {
                if j < s.lo[1] || j >= s.lo[1] + s.dims[1] || k < s.lo[2] {
                    continue;
                }
                let (y, z) = (j - s.lo[1], k - s.lo[2]);
                let wyz = s.weight[1][y] * s.weight[2][z];
                values.resize(s.dims[0], 0f32);
                s.planes[z][s.dims[0] * y..s.dims[0] * (y + 1)].convert_to_f32_slice(&mut values);
                for (x, v) in values.iter().enumerate() {
                    let w = wyz * s.weight[0][x];
                    num[s.lo[0] + x] += w * v;
                    den[s.lo[0] + x] += w;
                }
            }
            for i in 1..n - 1 {
                row[i] = num[i] / den[i];
            }
        });
        plane
    }
}

/// Marching cubes over the blend of the cube layers `layers` (steps 3–4): `start(k)` hands over the
/// leaves whose values begin at plane k (or before, not yet handed over), which are held until the
/// sweep has passed them, a plane at a time. Each plane adds `step` to `planes`. Returns the mesh and
/// the most leaves held at once.
fn extract(
    grid: &LeafGrid,
    coarse: &CoarseChi,
    layers: Range<usize>,
    planes: &AtomicUsize,
    step: usize,
    mut start: impl FnMut(usize) -> Vec<ActiveLeaf> + Send,
) -> (TriMesh, usize) {
    let n = grid.n;
    let frame = GridFrame { dims: [n; 3], origin: Point3::from(grid.origin), spacing: grid.h };
    let blend = Blend::new(coarse, n);
    let mut active: Vec<ActiveLeaf> = Vec::new();
    let mut peak = 0;
    let mesh = marching_cubes_layers(&frame, 0.0, layers, |k| {
        active.extend(start(k));
        active.retain(|s| s.lo[2] + s.dims[2] > k);
        active.sort_by_key(|s| s.id);
        peak = peak.max(active.len());
        let plane = blend.plane(k, &active);
        // This plane of every leaf is done with.
        for s in &mut active {
            s.planes[k - s.lo[2]] = Vec::new();
        }
        planes.fetch_add(step, Ordering::Relaxed);
        plane
    });
    (mesh, peak)
}

/// The clean-up of the swept mesh: components too small or away from the data dropped, the rest
/// drawn onto the samples, folds where blended leaves crossed (or the pull made) repaired; the report
/// completed (`t`: when the sweep began).
fn clean(
    mut mesh: TriMesh,
    samples: &Samples,
    params: &AdFftParams,
    mut report: AdFftReport,
    t: Instant,
) -> (TriMesh, AdFftReport) {
    report.components_pruned =
        super::prune::prune_small_or_away(&mut mesh, params.min_component, &samples.tree, 4.0 * report.cell);
    let area: Real = samples.weights.iter().sum();
    let radius = super::fit::radius(samples.positions.len(), area, report.cell);
    report.fit = super::fit::fit_to_samples(&mut mesh, samples.positions, samples.normals, radius, 0.5 * report.cell);
    report.self_intersections = super::self_intersect::repair(&mut mesh, 8);
    report.seconds_extract = t.elapsed().as_secs_f64();
    report.vertices = mesh.vertices.len();
    report.triangles = mesh.faces.len();
    (mesh, report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::topology::topology;

    #[test]
    fn a_sphere_comes_back_closed_and_on_its_radius() {
        let cloud = crate::reconstruct::global_fft::tests::sphere(40_000, 40.0);
        let (mesh, report) = reconstruct_adfft(&cloud, &AdFftParams { depth: 7, ..Default::default() }).unwrap();
        let t = topology(&mesh);
        assert!(t.is_closed_oriented_manifold(), "{t:?}");
        assert_eq!((t.genus(), t.components), (Some(0), 1), "{report:?}");
        let worst = mesh.vertices.iter().map(|p| (p.coords.norm() - 40.0).abs()).fold(0.0, Real::max);
        assert!(worst <= report.cell, "Hausdorff {worst} vs cell {}; {report:?}", report.cell);
        assert!(report.leaves() > 1);
        // The progress count reaches every plane of the sweep, and the counted run makes the same mesh.
        let planes = AtomicUsize::new(0);
        let (counted, _) =
            reconstruct_adfft_counting(&cloud, &AdFftParams { depth: 7, ..Default::default() }, &planes).unwrap();
        assert_eq!(planes.load(Ordering::Relaxed), 128);
        assert_eq!(counted, mesh);
    }

    /// The library's entry refuses a field no option sets, by name, before any work: a NaN margin
    /// went into the bounding cube's size unchecked.
    #[test]
    fn a_field_out_of_its_range_is_refused_by_name() {
        let cloud = crate::reconstruct::global_fft::tests::sphere(2_000, 40.0);
        for (p, field) in [
            (AdFftParams { depth: 6, padding: Real::NAN, ..Default::default() }, "padding"),
            (AdFftParams { depth: 6, scale: 0.9, ..Default::default() }, "scale"),
        ] {
            let e = reconstruct_adfft(&cloud, &p).unwrap_err().to_string();
            assert!(e.contains(field), "{e}");
        }
        let p = crate::reconstruct::global_fft::FftParams { depth: 5, padding: -1.0, ..Default::default() };
        let e = crate::reconstruct::global_fft::reconstruct_fft(&cloud, &p).unwrap_err().to_string();
        assert!(e.contains("padding"), "{e}");
    }

    /// A grid built shallower than asked says so, naming the depths and the option that keeps the
    /// asked one; one built as asked says nothing.
    #[test]
    fn a_shallower_grid_is_said_with_its_remedy() {
        let r = AdFftReport { depth_asked: 10, depth: 9, samples_per_cell: 0.558, ..Default::default() };
        let why = r.shallower_than_asked().unwrap();
        assert!(
            why.contains("depth 10 asked; built at depth 9")
                && why.contains("0.56 samples")
                && why.contains("--samples-per-cell 0 keeps depth 10"),
            "{why}"
        );
        let r = AdFftReport { depth_asked: 9, depth: 9, ..Default::default() };
        assert_eq!(r.shallower_than_asked(), None);
    }

    /// A fit that had to stop many vertices at its limit is said; one that moved few that far is not.
    #[test]
    fn a_fit_held_at_its_limit_is_said() {
        let fit = |moved, limited| super::super::fit::FitReport { moved, limited, ..Default::default() };
        let r = AdFftReport { cell: 0.5, fit: fit(1000, 200), ..Default::default() };
        let why = r.far_from_samples().unwrap();
        assert!(why.contains("20.0 %") && why.contains("(0.250)") && !why.contains("  "), "{why}");
        assert!(why.contains("scans out of alignment"), "{why}");
        // On a grid finer than the samples carry, the grid is named and the remedy given, not the scans.
        let fine = AdFftReport { cell: 0.000_582, samples_per_cell: 0.15, ..r.clone() }.far_from_samples().unwrap();
        assert!(
            fine.contains("(0.000291)")
                && fine.contains("finer than the samples carry (0.15 samples per cell")
                && fine.contains("a lower --depth")
                && !fine.contains("alignment")
                && !fine.contains("  "),
            "{fine}"
        );
        assert_eq!(AdFftReport { fit: fit(1000, 3), ..r.clone() }.far_from_samples(), None);
        assert_eq!(AdFftReport { fit: fit(0, 0), ..r }.far_from_samples(), None);
    }

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

    /// Slabs cover every layer once, in order, none empty, however many are asked for.
    #[test]
    fn slab_layers_cover_the_grid() {
        let ranges = vec![([0, 0, 2], [5, 5, 9]), ([0, 0, 20], [5, 5, 30])];
        for slabs in [1, 2, 3, 7, 31, 32, 100] {
            let layers = slab_layers(&ranges, 32, slabs);
            assert!(layers.len() <= slabs.min(31) && !layers.is_empty(), "{slabs}: {layers:?}");
            assert_eq!((layers[0].start, layers[layers.len() - 1].end), (0, 31));
            assert!(layers.iter().all(|l| !l.is_empty()) && layers.windows(2).all(|w| w[0].end == w[1].start));
        }
        assert_eq!(slab_layers(&ranges, 32, 2).len(), 2);
    }

    /// The bunny's figures (362,272 samples over 61,658 mm² in a 193.2 mm cube): 0.56 samples per
    /// surface cell at depth 9, 0.14 at 10, so any depth past 9 is built at 9; 0 keeps the depth
    /// asked; a sparse cloud stops no lower than depth 6, and a depth asked below 6 is kept.
    #[test]
    fn the_grid_stops_at_the_depth_the_samples_carry() {
        let bunny = |asked, per_cell| supported_depth(asked, 362_272, 61_658.0, 193.22, per_cell);
        for asked in [9, 10, 11, 12] {
            let (depth, per_cell) = bunny(asked, 0.25);
            assert_eq!(depth, 9);
            assert!((0.55..0.57).contains(&per_cell), "{per_cell}");
        }
        assert_eq!(bunny(8, 0.25).0, 8);
        assert_eq!(bunny(11, 0.0).0, 11);
        assert!((0.13..0.15).contains(&bunny(10, 0.0).1));
        assert_eq!(supported_depth(11, 100, 61_658.0, 193.22, 0.25).0, 6);
        assert_eq!(supported_depth(5, 100, 61_658.0, 193.22, 0.25).0, 5);
        assert_eq!(supported_depth(9, 100, 0.0, 193.22, 0.25).0, 9);
        // Kept at a depth far finer than the samples, the grid is refused before any work, by name.
        let cloud = crate::reconstruct::global_fft::tests::sphere(3_000, 20.0);
        let forced = AdFftParams { depth: 9, samples_per_cell: 0.0, ..Default::default() };
        let said = reconstruct_adfft(&cloud, &forced).unwrap_err().to_string();
        assert!(said.contains("--samples-per-cell 0 keeps AdFFT's grid at depth 9"), "{said}");
    }

    /// A sweep in slabs — each slab's leaves solved by a `LeafSolver` of its own, as a worker builds
    /// one from the samples and weights it is sent, and cut to the slab — joins into the very mesh
    /// the local sweep makes; a slab's part that does not fit is refused, and so is a slab missing.
    #[test]
    fn a_sweep_in_slabs_gives_the_same_mesh_and_bad_parts_are_refused() {
        let cloud = crate::reconstruct::global_fft::tests::sphere(20_000, 40.0);
        let params = AdFftParams { depth: 7, ..Default::default() };
        let (local, local_report) = reconstruct_adfft(&cloud, &params).unwrap();
        let normals = cloud.normals.as_deref().unwrap();
        for slabs in [1, 2, 3] {
            let (joined, report) = reconstruct_adfft_slabs(&cloud, &params, slabs, |job| {
                assert_eq!(job.layers.len(), slabs);
                assert_eq!((job.layers[0].start, job.layers[slabs - 1].end), (0, job.grid.n - 1));
                let solver = LeafSolver::new(&cloud.positions, normals, job.weights.to_vec());
                job.layers
                    .iter()
                    .map(|layers| {
                        let parts = (job.tasks.iter().enumerate())
                            .filter_map(|(id, t)| {
                                slab_part(&solver.solve(t, &job.grid), layers, job.grid.n).map(|p| (id, p))
                            })
                            .collect();
                        sweep_slab(parts, &job.coarse, &job.grid, layers.clone())
                    })
                    .collect()
            })
            .unwrap();
            assert!(report.leaves() > 1);
            assert_eq!(report.triangles, local_report.triangles);
            assert_eq!(joined, local, "{slabs} slabs: the mesh differs from the local sweep's");
        }
        let broken = reconstruct_adfft_slabs(&cloud, &params, 2, |job| {
            let solver = LeafSolver::new(&cloud.positions, normals, job.weights.to_vec());
            let mut part =
                slab_part(&solver.solve(&job.tasks[0], &job.grid), &(0..job.grid.n - 1), job.grid.n).unwrap();
            part.values.pop();
            sweep_slab(vec![(0, part)], &job.coarse, &job.grid, job.layers[0].clone()).map(|m| vec![m])
        });
        let err = broken.unwrap_err().to_string();
        assert!(err.contains("leaf 0: its part does not fit the grid"), "{err}");
        let short = reconstruct_adfft_slabs(&cloud, &params, 2, |_| Ok(Vec::new())).unwrap_err().to_string();
        assert!(short.contains("0 slabs swept of 2"), "{short}");
    }
}
