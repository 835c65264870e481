//! The global FFT method (Kazhdan 2005; thesis section 5.2.4, eqs. 5.16–5.17).
//!
//! The oriented samples define a vector field `V = Σ_i a_i n_i δ(x − p_i)` (a_i the area a sample
//! stands for). Outward normals make it minus the gradient of the solid's indicator χ, so in Fourier
//! space `χ̂(ω) = i ω·V̂(ω) / |ω|²` — eq. 5.16 with the `F` of eq. 5.17 summed over the samples. On
//! an N³ grid this is three real FFTs of the splatted normal components, one multiply (with a Gaussian
//! low-pass that stands in for the thesis's smoothing filter), and one inverse FFT. The surface is
//! χ's level set at the area-weighted mean of χ over the samples, extracted by marching cubes.
//!
//! Memory is cubic in N: three half spectra (the real grid shares one), 12·N³ bytes (201 MB at 256³, 1.6 GB at
//! 512³); a grid over the budget is refused before anything is allocated.

use super::fft3::RealFft3;
use super::marching_cubes::{GridFrame, marching_cubes};
use crate::kd_tree::PointTree;
use rayon::prelude::*;
use rig::TriMesh;
use rig::math::{Point3, Real, Vector3};
use rustfft::num_complex::Complex32;
use serde::Serialize;
use std::time::Instant;

/// Settings of the global method.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FftParams {
    /// Grid of 2^depth points per axis.
    pub depth: u32,
    /// Empty margin on each side of the points' bounding cube, as a fraction of its edge: the FFT is
    /// periodic, and the solid must not wrap around.
    pub padding: Real,
    /// Standard deviation of the Gaussian low-pass, in grid cells.
    pub smoothing_cells: Real,
    /// Neighbours for each sample's area weight (the disc to its k-th neighbour); 0 weighs all alike.
    pub area_k: usize,
    /// Refuse grids needing more than this many bytes (default 8 GB).
    pub memory_budget: u64,
    /// Components with less than this fraction of the largest component's area are dropped (the
    /// blobs outliers and open scan borders leave).
    pub min_component: Real,
}

impl Default for FftParams {
    fn default() -> Self {
        FftParams {
            depth: 8,
            padding: 0.05,
            smoothing_cells: 0.5,
            area_k: 8,
            memory_budget: 8_000_000_000,
            min_component: 0.01,
        }
    }
}

/// What a reconstruction did.
#[derive(Debug, Clone, Default, Serialize, serde::Deserialize)]
pub struct FftReport {
    /// Grid points per axis.
    pub n: usize,
    /// Grid spacing (the cloud's units).
    pub cell: Real,
    /// Bytes of the grids.
    pub grid_bytes: u64,
    /// The level of χ extracted.
    pub iso: Real,
    /// Output size.
    pub vertices: usize,
    /// Output size.
    pub triangles: usize,
    /// Seconds for area weights and splatting.
    pub seconds_splat: Real,
    /// Seconds for the transforms and the filter.
    pub seconds_fft: Real,
    /// Seconds for marching cubes.
    pub seconds_extract: Real,
    /// Small components dropped.
    pub components_pruned: usize,
}

/// Why a reconstruction was refused.
#[derive(Debug, thiserror::Error)]
pub enum ReconstructError {
    /// The input has no points.
    #[error("the cloud is empty")]
    Empty,
    /// The input has no normals.
    #[error("the cloud has no normals: reconstruction needs oriented points (run `scanrig fuse` first)")]
    NoNormals,
    /// The grid would not fit the memory budget.
    #[error("a {n}³ grid needs {need:.2} GB, over the {budget:.2} GB budget (--memory-budget): {hint}")]
    TooLarge {
        /// Grid size.
        n: usize,
        /// Gigabytes needed.
        need: f64,
        /// Gigabytes allowed.
        budget: f64,
        /// What to do instead.
        hint: &'static str,
    },
    /// A parameter is out of range.
    #[error("{0}")]
    Params(String),
    /// AdFFT's sweep in slabs, done elsewhere ([`super::adfft::reconstruct_adfft_slabs`]), did not
    /// come back whole.
    #[error("sweeping AdFFT's slabs: {0}")]
    Leaves(String),
    /// The reconstruction needs more memory than the machine has.
    #[error(transparent)]
    Memory(#[from] rig::memory::TooLarge),
}

/// Refuses a reconstruction estimated at `need` bytes over `budget` or over what the machine has;
/// `method` names it for the message, `hint` says what to do instead.
pub fn check_memory(
    need: u64,
    n: usize,
    budget: u64,
    method: &str,
    hint: &'static str,
) -> Result<(), ReconstructError> {
    if need > budget {
        return Err(ReconstructError::TooLarge { n, need: need as f64 / 1e9, budget: budget as f64 / 1e9, hint });
    }
    let what = format!("reconstruction on a {n}³ grid ({method})");
    rig::memory::check(Some(need), &what, hint)?;
    Ok(())
}

/// Bytes the global method needs at depth `depth`.
pub fn grid_bytes(depth: u32) -> u64 {
    let n = 1u64 << depth;
    IndicatorWork::bytes(n as usize)
}

/// The cube the grid spans: the points' bounding cube grown by `padding` on each side.
pub fn bounding_cube(points: &[Point3], padding: Real) -> (Point3, Real) {
    let (lo, hi) = points.iter().fold((points[0], points[0]), |(lo, hi), p| (lo.inf(p), hi.sup(p)));
    let edge = (hi - lo).max().max(Real::MIN_POSITIVE);
    let size = edge * (1.0 + 2.0 * padding);
    let centre = lo + (hi - lo) / 2.0;
    (centre - Vector3::repeat(size / 2.0), size)
}

/// The area each sample stands for: the disc out to its k-th neighbour, shared by the k samples in it,
/// at most a few times the median. Evens out overlapping scans, which would otherwise pull the
/// iso-level toward the doubly sampled parts. Where the k nearest lie on one line — a laser scan,
/// dense along each line and sparse across — the disc would measure the spacing along the line only
/// and make each sample a small fraction of its true area (a cap of even samples beside such lines
/// then outweighs the wall); k widens fourfold, up to [`AREA_MAX_WIDENINGS`] times, until the disc
/// reaches the neighbouring lines, where its k samples share it as they share the surface.
pub fn area_weights(points: &[Point3], k: usize) -> Vec<Real> {
    if k == 0 || points.len() <= k {
        return vec![1.0; points.len()];
    }
    area_weights_in(points, k, &PointTree::new(points))
}

/// [`area_weights`] through a k-d tree over `points` the caller already has (the pipeline asks the
/// same tree for the mesh's support and colours).
pub fn area_weights_in(points: &[Point3], k: usize, tree: &PointTree) -> Vec<Real> {
    if k == 0 || points.len() <= k {
        return vec![1.0; points.len()];
    }
    let mut w: Vec<Real> = points
        .par_iter()
        .map(|p| {
            let mut kk = k;
            let (mut nb, mut r2) = tree.nearest_k_unsorted(p, kk + 1);
            for _ in 0..AREA_MAX_WIDENINGS {
                if kk * 4 + 1 > points.len() || !crate::normals::is_line(points, &nb) {
                    break;
                }
                kk *= 4;
                (nb, r2) = tree.nearest_k_unsorted(p, kk + 1);
            }
            std::f64::consts::PI * r2 / kk as Real
        })
        .collect();
    // An isolated point (an outlier) has a huge disc; capped at a few times the median, it cannot
    // outweigh the surface around it.
    let mut sorted = w.clone();
    sorted.sort_by(Real::total_cmp);
    let cap = WEIGHT_CAP * sorted[sorted.len() / 2];
    w.iter_mut().for_each(|x| *x = x.min(cap));
    w
}

/// Times the neighbourhood of [`area_weights`] widens (fourfold each) while it is a line: 8 · 4³ = 512
/// neighbours reach across laser lines a 36-view scan leaves 10° apart.
pub const AREA_MAX_WIDENINGS: usize = 3;

/// Area weights are capped at this multiple of their median.
const WEIGHT_CAP: Real = 4.0;

/// A point's trilinear stencil on the periodic N³ grid: the flat indices of its 8 corners (wrapped,
/// corner c at +(c & 1, c >> 1 & 1, c >> 2 & 1)) and their weights.
type Stencil = ([usize; 8], [Real; 8]);

/// The trilinear stencil of a point at continuous grid coordinates `u`. The corners are wrapped once
/// per axis here, not once per corner and axis where they are used: three integer divisions per corner
/// had made the splat a sixth of an AdFFT run.
fn trilinear(u: Vector3, n: usize) -> Stencil {
    let base = [u.x.floor() as isize, u.y.floor() as isize, u.z.floor() as isize];
    let f = [u.x - base[0] as Real, u.y - base[1] as Real, u.z - base[2] as Real];
    let w = std::array::from_fn(|c| {
        let pick = |axis: usize| if c >> axis & 1 == 1 { f[axis] } else { 1.0 - f[axis] };
        pick(0) * pick(1) * pick(2)
    });
    let wrapped: [[usize; 2]; 3] = std::array::from_fn(|axis| {
        let lo = base[axis].rem_euclid(n as isize) as usize;
        [lo, if lo + 1 == n { 0 } else { lo + 1 }]
    });
    let at = std::array::from_fn(|c| wrapped[0][c & 1] + n * (wrapped[1][c >> 1 & 1] + n * wrapped[2][c >> 2 & 1]));
    (at, w)
}

/// Points bucketed by the grid plane their trilinear corners start in, for splatting z-slabs of the
/// grid in parallel: each slab's points write its own planes, all but the spill of its last plane's
/// points into the next slab, which is added after.
struct ZSlabs {
    /// Point indices ordered by their lower corner's (wrapped) z plane.
    order: Vec<u32>,
    /// Where each plane's points start in `order` (n + 1 entries).
    starts: Vec<usize>,
    n: usize,
    /// Planes per slab.
    thickness: usize,
}

impl ZSlabs {
    fn new(corners: &[Stencil], n: usize) -> Self {
        // The lower corner's plane.
        let plane = |at: &[usize; 8]| at[0] / (n * n);
        let mut starts = vec![0usize; n + 1];
        for (at, _) in corners {
            starts[plane(at) + 1] += 1;
        }
        for z in 0..n {
            starts[z + 1] += starts[z];
        }
        let mut next = starts.clone();
        let mut order = vec![0u32; corners.len()];
        for (i, (at, _)) in corners.iter().enumerate() {
            let z = plane(at);
            order[next[z]] = i as u32;
            next[z] += 1;
        }
        // 32 slabs, whatever the threads: enough to share uneven slabs (a base, a cap) out evenly,
        // and the same sums in the same order on every machine.
        let thickness = n.div_ceil(32).max(1);
        ZSlabs { order, starts, n, thickness }
    }

    /// `grid = Σ_i value(i) · trilinear weights of point i` (eq. 5.16's splat of V).
    /// `min_len`: the fewest slabs a rayon job takes (`usize::MAX`: all on this thread).
    fn splat(&self, grid: &mut [f32], corners: &[Stencil], min_len: usize, value: impl Fn(usize) -> Real + Sync) {
        let (n, t) = (self.n, self.thickness);
        let plane_len = n * n;
        let spills: Vec<(usize, Vec<f32>)> = grid
            .par_chunks_mut(t * plane_len)
            .enumerate()
            .with_min_len(min_len)
            .map(|(s, slab)| {
                slab.fill(0.0);
                let (z0, z1) = (s * t, ((s + 1) * t).min(n));
                let spill_plane = z1 % n;
                let mut spill = vec![0f32; plane_len];
                // The slab's and the spill plane's points, as flat indices.
                let (lo, hi, spill_start) = (z0 * plane_len, z1 * plane_len, spill_plane * plane_len);
                for &i in &self.order[self.starts[z0]..self.starts[z1]] {
                    let i = i as usize;
                    let (at, w) = &corners[i];
                    let v = value(i);
                    for (&a, wc) in at.iter().zip(w) {
                        let add = (v * wc) as f32;
                        if (lo..hi).contains(&a) {
                            slab[a - lo] += add;
                        } else {
                            spill[a - spill_start] += add;
                        }
                    }
                }
                (spill_plane, spill)
            })
            .collect();
        for (z, spill) in spills {
            for (g, s) in grid[z * plane_len..(z + 1) * plane_len].iter_mut().zip(spill) {
                *g += s;
            }
        }
    }
}

/// An N³ grid over a cube: point (i, j, k) at `origin + cell·(i, j, k)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cube {
    /// The corner with the smallest coordinates.
    pub origin: Point3,
    /// Edge length.
    pub size: Real,
    /// Points per axis.
    pub n: usize,
}

impl Cube {
    /// Grid spacing.
    pub fn cell(&self) -> Real {
        self.size / self.n as Real
    }
}

/// χ on the cube's grid from oriented, area-weighted points (eqs. 5.16–5.17), with the report's splat
/// and FFT timings filled in. χ jumps by about 1 from outside to inside (its mean over the cube is 0,
/// as the DC term is dropped); areas in the cloud's units squared make that scale physical.
pub fn indicator(
    points: &[Point3],
    normals: &[Vector3],
    weights: &[Real],
    cube: &Cube,
    smoothing_cells: Real,
    report: &mut FftReport,
) -> Vec<f32> {
    let mut work = IndicatorWork::new(cube.n);
    solve_indicator(points, normals, weights, cube, smoothing_cells, report, &mut work);
    // The other two spectra go before χ is copied out of the third.
    let IndicatorWork { fft, chi_hat, buffer, scratch } = work;
    drop((buffer, scratch));
    fft.real_view(&chi_hat).to_vec()
}

/// The buffers of one χ solve on an N³ grid: three half spectra, the splat's real grid sharing one and
/// χ left in another. AdFFT keeps them from one leaf to the next ([`solve_indicator`]), where each
/// solve at 128³ had allocated and faulted in 34 MB of fresh memory.
pub struct IndicatorWork {
    fft: RealFft3,
    buffer: Vec<Complex32>,
    scratch: Vec<Complex32>,
    chi_hat: Vec<Complex32>,
}

impl IndicatorWork {
    /// Buffers for an `n`³ grid (`n` even).
    pub fn new(n: usize) -> Self {
        let fft = RealFft3::new(n);
        let len = fft.spectrum_len();
        let zeros = || vec![Complex32::default(); len];
        IndicatorWork { buffer: zeros(), scratch: zeros(), chi_hat: zeros(), fft }
    }

    /// Grid points per axis.
    pub fn n(&self) -> usize {
        self.fft.n()
    }

    /// Whether a solve spreads over rayon's threads (the default) or stays on the caller's, as a solve
    /// among others run side by side should: a thread waiting inside a solve's parallel loop would
    /// start another solve, and hold its buffers too.
    pub fn set_parallel(&mut self, parallel: bool) {
        self.fft.set_parallel(parallel);
    }

    /// χ of the last [`solve_indicator`] (N³ values, x fastest).
    pub fn chi(&self) -> &[f32] {
        self.fft.real_view(&self.chi_hat)
    }

    /// Bytes the buffers hold for an `n`³ grid.
    pub fn bytes(n: usize) -> u64 {
        3 * 8 * (n as u64 / 2 + 1) * (n as u64).pow(2)
    }
}

/// [`indicator`] into `work` (its grid is the cube's), where [`IndicatorWork::chi`] reads χ after.
pub fn solve_indicator(
    points: &[Point3],
    normals: &[Vector3],
    weights: &[Real],
    cube: &Cube,
    smoothing_cells: Real,
    report: &mut FftReport,
    work: &mut IndicatorWork,
) {
    let t = Instant::now();
    let Cube { origin, size, n } = *cube;
    assert_eq!(work.n(), n, "the work's grid is the cube's");
    let cell = cube.cell();
    let IndicatorWork { fft, buffer, scratch, chi_hat } = work;
    let min_len = fft.min_len();
    let corners: Vec<Stencil> =
        points.par_iter().with_min_len(min_len).map(|p| trilinear((p - origin) / cell, n)).collect();
    let two_pi_over_size = std::f64::consts::TAU / size;
    let sigma = smoothing_cells * cell;
    // ω per index, and the low-pass G(ω) = exp(−σ²|ω|²/2) as one factor per axis: a table of n
    // factors replaces an exp per frequency and axis (a fifth of a leaf's solve in AdFFT). The
    // Nyquist index has no signed frequency; its factor is 0, dropping those planes (their content
    // is below the filter).
    let signed = |k: usize| if k <= n / 2 { k as Real } else { k as Real - n as Real };
    let omega: Vec<f32> = (0..n).map(|k| (signed(k) * two_pi_over_size) as f32).collect();
    let low_pass: Vec<f32> = (0..n)
        .map(|k| if k == n / 2 { 0.0 } else { (-0.5 * (signed(k) * two_pi_over_size * sigma).powi(2)).exp() as f32 })
        .collect();
    let slabs = ZSlabs::new(&corners, n);
    let mut splat_seconds = t.elapsed().as_secs_f64();
    let mut fft_seconds = 0.0;
    let mut splat = |axis: usize, grid: &mut [Complex32]| {
        let t = Instant::now();
        slabs.splat(fft.real_part(grid), &corners, min_len, |i| normals[i][axis] * weights[i]);
        splat_seconds += t.elapsed().as_secs_f64();
    };
    // χ̂ = i·G(ω)/|ω|² · Σ ω_axis·V̂_axis. The transform is linear and ω_x, ω_y are constant along
    // the lines the z transform takes, so ω_x·V̂_x + ω_y·V̂_y is summed after the x and y transforms
    // (in `chi_hat`, planes) and transformed along z once: two transforms along z, not three.
    let h = fft.half();
    splat(0, buffer);
    let t = Instant::now();
    fft.forward_planes(buffer, chi_hat, &|out, plane| {
        for (kx, (out, plane)) in out.chunks_mut(n).zip(plane.chunks(n)).enumerate() {
            out.iter_mut().zip(plane).for_each(|(o, v)| *o = v * omega[kx]);
        }
    });
    fft_seconds += t.elapsed().as_secs_f64();
    splat(1, buffer);
    let t = Instant::now();
    fft.forward_planes(buffer, chi_hat, &|out, plane| {
        for (out, plane) in out.chunks_mut(n).zip(plane.chunks(n)) {
            out.iter_mut().zip(plane).zip(&omega).for_each(|((o, v), w)| *o += v * w);
        }
    });
    fft.forward_z(chi_hat, buffer);
    fft_seconds += t.elapsed().as_secs_f64();
    splat(2, chi_hat);
    let t = Instant::now();
    fft.forward_planes(chi_hat, scratch, &|out, plane| out.copy_from_slice(plane));
    fft.forward_z(scratch, chi_hat);
    // χ̂ = i·gain·(Â + ω_z·V̂_z), gain = G/|ω|², a kx-plane of the spectrum (z fastest,
    // [`RealFft3::spectrum_index`]) per job.
    debug_assert_eq!(chi_hat.len(), h * n * n);
    chi_hat.par_chunks_mut(n * n).zip(buffer.par_chunks(n * n)).enumerate().with_min_len(min_len).for_each(
        |(kx, (acc, xy))| {
            for ky in 0..n {
                let (wx, wy) = (omega[kx], omega[ky]);
                let (g_xy, w2_xy) = (low_pass[kx] * low_pass[ky], wx * wx + wy * wy);
                let (acc, xy) = (&mut acc[ky * n..][..n], &xy[ky * n..][..n]);
                for kz in 0..n {
                    let wz = omega[kz];
                    // At ω = 0 the sum is 0 too: the DC term is dropped.
                    let gain = g_xy * low_pass[kz] / (w2_xy + wz * wz).max(f32::MIN_POSITIVE);
                    let v = (xy[kz] + acc[kz] * wz) * gain;
                    acc[kz] = Complex32::new(-v.im, v.re); // i·v
                }
            }
        },
    );
    fft_seconds += t.elapsed().as_secs_f64();
    let t = Instant::now();
    fft.inverse(chi_hat, scratch);
    // The unnormalised inverse DFT is the Fourier series times the cube's volume (the splat puts
    // V's integral, not its density, in each cell): dividing gives χ in physical units, a jump of
    // about 1 across the surface, so local solutions on different cubes (AdFFT) agree in scale.
    let volume = (size * size * size) as f32;
    fft.real_part(chi_hat).par_iter_mut().with_min_len(min_len.max(4096)).for_each(|v| *v /= volume);
    fft_seconds += t.elapsed().as_secs_f64();
    report.seconds_splat += splat_seconds;
    report.seconds_fft += fft_seconds;
}

/// χ at continuous position `p` by trilinear interpolation.
pub fn sample(chi: &[f32], n: usize, origin: Point3, cell: Real, p: &Point3) -> Real {
    let (at, w) = trilinear((p - origin) / cell, n);
    (0..8).map(|c| chi[at[c]] as Real * w[c]).sum()
}

/// The level of χ the surface passes through: χ's mean over the samples, each weighed by the area it
/// stands for (as it was splatted), so a densely sampled part — a cap of even samples beside sparse
/// laser lines, a region two scans overlap — does not pull the whole surface toward its own level.
pub fn iso_level(chi: &[f32], cube: &Cube, points: &[Point3], weights: &[Real]) -> Real {
    let (sum, total) = points
        .par_iter()
        .zip(weights)
        .map(|(p, &w)| (w * sample(chi, cube.n, cube.origin, cube.cell(), p), w))
        .reduce(|| (0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    if total > 0.0 { sum / total } else { 0.0 }
}

/// Reconstructs a watertight mesh from an oriented cloud by the global FFT method.
pub fn reconstruct_fft<'a>(
    cloud: impl Into<rig::CloudRef<'a>>,
    params: &FftParams,
) -> Result<(TriMesh, FftReport), ReconstructError> {
    reconstruct_fft_in(cloud, params, None)
}

/// [`reconstruct_fft`] with a k-d tree over the cloud's positions the caller already has, for the
/// area weights (`None`: one is built).
pub fn reconstruct_fft_in<'a>(
    cloud: impl Into<rig::CloudRef<'a>>,
    params: &FftParams,
    tree: Option<&PointTree>,
) -> Result<(TriMesh, FftReport), ReconstructError> {
    fft_of(cloud.into(), params, tree)
}

/// [`reconstruct_fft_in`]'s body, compiled once here rather than into every caller's crate.
fn fft_of(
    cloud: rig::CloudRef<'_>,
    params: &FftParams,
    tree: Option<&PointTree>,
) -> Result<(TriMesh, FftReport), ReconstructError> {
    if cloud.is_empty() {
        return Err(ReconstructError::Empty);
    }
    let normals = cloud.normals.ok_or(ReconstructError::NoNormals)?;
    if !(2..=11).contains(&params.depth) {
        return Err(ReconstructError::Params(format!("depth must be 2–11, got {}", params.depth)));
    }
    crate::limits::check_padding(params.padding).map_err(|e| ReconstructError::Params(e.to_string()))?;
    let need = grid_bytes(params.depth);
    let n = 1usize << params.depth;
    // AdFFT holds only the leaves near the surface: the way past this grid's size.
    check_memory(need, n, params.memory_budget, "--method fft", "lower --depth, or use --method adfft")?;
    let (origin, size) = bounding_cube(cloud.positions, params.padding);
    let cell = size / n as Real;
    let mut report = FftReport { n, cell, grid_bytes: need, ..Default::default() };
    let t = Instant::now();
    let weights = match tree {
        Some(tree) => area_weights_in(cloud.positions, params.area_k, tree),
        None => area_weights(cloud.positions, params.area_k),
    };
    report.seconds_splat += t.elapsed().as_secs_f64();
    let cube = Cube { origin, size, n };
    let chi = indicator(cloud.positions, normals, &weights, &cube, params.smoothing_cells, &mut report);
    let t = Instant::now();
    let iso = iso_level(&chi, &cube, cloud.positions, &weights);
    report.iso = iso;
    let frame = GridFrame { dims: [n; 3], origin, spacing: cell };
    // The grid's outer layer counts as outside, so the surface is closed even where an open scan lets
    // χ exceed the level at the border.
    let mut mesh = marching_cubes(&frame, iso as f32, |i, j, k| {
        if [i, j, k].iter().any(|&c| c == 0 || c == n - 1) { f32::NEG_INFINITY } else { chi[i + n * (j + n * k)] }
    });
    report.components_pruned = super::prune::prune_small_components(&mut mesh, params.min_component);
    report.seconds_extract = t.elapsed().as_secs_f64();
    report.vertices = mesh.vertices.len();
    report.triangles = mesh.faces.len();
    Ok((mesh, report))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use rig::PointCloud;
    use rig::topology::topology;

    /// Points on a sphere of radius r (Fibonacci lattice) with outward normals.
    pub(crate) fn sphere(count: usize, r: Real) -> PointCloud {
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let normals: Vec<Vector3> = (0..count)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as Real + 0.5) / count as Real;
                let rho = (1.0 - z * z).sqrt();
                let a = golden * i as Real;
                Vector3::new(rho * a.cos(), rho * a.sin(), z)
            })
            .collect();
        PointCloud {
            positions: normals.iter().map(|n| Point3::from(n * r)).collect(),
            normals: Some(normals),
            ..Default::default()
        }
    }

    #[test]
    fn a_sampled_sphere_comes_back_closed_and_within_a_cell() {
        let cloud = sphere(20_000, 40.0);
        let (mesh, report) = reconstruct_fft(&cloud, &FftParams { depth: 6, ..Default::default() }).unwrap();
        let t = topology(&mesh);
        assert!(t.is_closed_oriented_manifold(), "{t:?}");
        assert_eq!((t.genus(), t.components), (Some(0), 1));
        let worst = mesh.vertices.iter().map(|p| (p.coords.norm() - 40.0).abs()).fold(0.0, Real::max);
        assert!(worst <= report.cell, "Hausdorff {worst} vs cell {}", report.cell);
    }

    #[test]
    fn chi_jumps_by_one_across_the_surface_whatever_the_cube() {
        // The same sphere in two cubes of different size and resolution: χ(inside) − χ(outside) ≈ 1
        // in both, which is what lets AdFFT blend local solutions.
        let cloud = sphere(20_000, 10.0);
        let normals = cloud.normals.as_ref().unwrap();
        let weights = area_weights(&cloud.positions, 8);
        for (size, n) in [(30.0, 64), (60.0, 32)] {
            let cube = Cube { origin: Point3::new(-size / 2.0, -size / 2.0, -size / 2.0), size, n };
            let mut report = FftReport::default();
            let chi = indicator(&cloud.positions, normals, &weights, &cube, 0.5, &mut report);
            let at = |p: Point3| sample(&chi, n, cube.origin, cube.cell(), &p);
            let jump = at(Point3::origin()) - at(Point3::new(0.0, 0.0, 13.5));
            assert!((jump - 1.0).abs() < 0.08, "cube {size}: jump {jump}");
        }
    }

    #[test]
    fn bad_input_is_refused_with_the_reason() {
        let mut cloud = sphere(100, 1.0);
        let huge = FftParams { depth: 11, memory_budget: 1 << 30, ..Default::default() };
        assert!(matches!(reconstruct_fft(&cloud, &huge), Err(ReconstructError::TooLarge { n: 2048, .. })));
        cloud.normals = None;
        assert!(matches!(reconstruct_fft(&cloud, &FftParams::default()), Err(ReconstructError::NoNormals)));
        assert!(matches!(reconstruct_fft(&PointCloud::default(), &FftParams::default()), Err(ReconstructError::Empty)));
    }
}
