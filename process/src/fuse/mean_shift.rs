//! Mean-shift fusion of a registered point cloud (thesis ch. 3): noise removed by moving every sample
//! to a maximum of a likelihood built from anisotropic local kernels, samples that reach the same
//! maximum clustered into one representative, and outliers removed by their low density.
//!
//! - Kernels (eqs. 3.2–3.3, adaptive size of section 3.2.3): over each sample's k nearest neighbours,
//!   the χ-weighted centre `c_i` and covariance `C_i`; its eigenvectors give the fitting plane's normal
//!   `n_i` (smallest eigenvalue) and the ellipsoid `E_i` the anisotropic Gaussian Φ_i follows.
//! - Likelihood (eqs. 3.4–3.5): `L(x) = Σ w_i·Φ_i(x − c_i)·(h² − ((x − c_i)·n_i)²)`, `w_i` the sample's
//!   confidence.
//! - Iteration (eqs. 3.6–3.9, with the adaptive step of eq. 3.7): `p ← p − m`, `m = Σ w_j Φ_j
//!   ((p − c_j)·n_j) n_j / Σ w_j Φ_j`, stopping by eq. 3.10 when a step is below 1e-4·h.
//! - Outliers and clustering: a sample where the normalised kernel density at its *start* is a small
//!   fraction of the median is removed before clustering (the adaptive step would otherwise carry it
//!   onto the surface); the rest that end within `merge` of each other become one point, and a
//!   representative whose k-th neighbour is far farther than typical is an outlier too (the isolated
//!   maxima of section 3.3.1).

use crate::cell_grid::{CellGrid, kth_distance};
use crate::kd_tree::PointTree;
use rayon::prelude::*;
use rig::PointCloud;
use rig::math::{Matrix3, Point3, Real, Vector3};
use serde::Serialize;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Mean-shift settings; lengths in the cloud's units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MeanShiftParams {
    /// Neighbours per kernel (the adaptive kernel size of section 3.2.3).
    pub k: usize,
    /// Kernels consulted per step (the nearest kernel centres to the moving sample).
    pub kernels_per_step: usize,
    /// The anisotropic Gaussian's extent in standard deviations of the kernel's point distribution.
    pub kernel_scale: Real,
    /// Floor on the ellipsoid's smallest axis relative to its largest, so flat kernels stay invertible.
    pub min_axis_ratio: Real,
    /// Most iterations per sample.
    pub max_iterations: usize,
    /// Samples ending closer than this fraction of their kernel size are one cluster.
    pub merge: Real,
    /// A sample whose kernel density `Σ w_j Φ_j / √det C_j` at its starting position is below this
    /// fraction of the median is an outlier: no surface kernel reaches it, and the wide kernels built
    /// over scattered outliers are thin densities.
    pub min_support: Real,
    /// A representative whose distance to its `density_k`-th neighbour exceeds `outlier_factor` times
    /// the median such distance is an outlier too (isolated maxima, section 3.3.1).
    pub outlier_factor: Real,
    /// Neighbour rank for the density test.
    pub density_k: usize,
    /// Kernels are built at one sample per grid cell of this fraction of the typical kernel radius
    /// (the distance to the `k`-th neighbour), each weighted by the samples its cell holds; 0 builds
    /// one per sample. Where many views overlap, samples closer than a fraction of the kernel's
    /// reach fit the same plane from the same neighbours: one kernel stands for them all.
    pub kernel_spacing: Real,
}

impl Default for MeanShiftParams {
    fn default() -> Self {
        MeanShiftParams {
            k: 64,
            kernels_per_step: 16,
            kernel_scale: 2.25,
            min_axis_ratio: 0.05,
            max_iterations: 30,
            merge: 0.05,
            min_support: 0.05,
            outlier_factor: 3.0,
            density_k: 8,
            kernel_spacing: 0.0,
        }
    }
}

/// What fusion did.
#[derive(Debug, Clone, Default, Serialize, serde::Deserialize)]
pub struct MeanShiftReport {
    /// Samples in.
    pub points_in: usize,
    /// Clusters (representatives) before outlier removal.
    pub clusters: usize,
    /// Samples removed before clustering: unsupported, or off their neighbours' plane.
    pub strays: usize,
    /// Representatives removed as isolated (low density of representatives).
    pub outliers_removed: usize,
    /// Points out.
    pub points_out: usize,
    /// Mean iterations per sample.
    pub mean_iterations: Real,
    /// Samples that stopped at `max_iterations` without meeting eq. 3.10.
    pub hit_iteration_limit: usize,
    /// Seconds building kernels.
    pub seconds_kernels: Real,
    /// Seconds iterating.
    pub seconds_shift: Real,
    /// Seconds clustering and removing outliers.
    pub seconds_cluster: Real,
}

/// A sample after its iterations: where it ended, after how many, the kernel nearest its start, and
/// the kernel density there (its support).
#[derive(Debug, Clone, Copy)]
struct Moved {
    p: Point3,
    iterations: u32,
    nearest: u32,
    support: Real,
}

/// Representatives whose `density_k`-th neighbour is the median such distance times this many at
/// most are asked of a sample of at most this many representatives: the median of 20,000 evenly
/// spread through the cloud (its Morton order) is the whole cloud's to a fraction of a per cent.
const MEDIAN_SAMPLE: usize = 20_000;

/// Which representatives to keep by section 3.3.1's test: a representative whose `density_k`-th
/// neighbouring representative lies farther than `outlier_factor` times the median such distance
/// is isolated. Asked as "are there `density_k` others within that distance", which a grid answers
/// from the representative's own cell for nearly all of them, with the median from a sample.
fn isolated_test(positions: &[Point3], params: &MeanShiftParams, median_h: Real) -> Vec<bool> {
    let k = params.density_k;
    // Cells of the kernels' size: a few times the k-th neighbour distance on a surface, so the
    // distance asked about is about a cell.
    let Some(grid) = CellGrid::new(positions, median_h) else {
        return isolated_test_by_tree(positions, params);
    };
    let stride = positions.len().div_ceil(MEDIAN_SAMPLE).max(1);
    let mut kth: Vec<Real> = positions
        .par_iter()
        .step_by(stride)
        // Distances past 16 kernel sizes are capped there: only their rank (above the median) counts.
        .map_init(Vec::new, |scratch, p| {
            kth_distance(&grid, p, k, 0.25 * median_h, 16.0 * median_h, scratch).unwrap_or(0.0)
        })
        .collect();
    let half = kth.len() / 2;
    let median = *kth.select_nth_unstable_by(half, Real::total_cmp).1;
    let reach = params.outlier_factor * median;
    positions.par_iter().map(|p| grid.at_least_within(p, reach, k + 1)).collect()
}

/// [`isolated_test`] through a k-d tree, every representative's distance measured: for clouds a grid
/// cannot hold (spread over more than 2²¹ cells along an axis).
fn isolated_test_by_tree(positions: &[Point3], params: &MeanShiftParams) -> Vec<bool> {
    let rep_tree = PointTree::new(positions);
    let kth: Vec<Real> = positions
        .par_iter()
        .map(|p| {
            let nb = rep_tree.nearest_k(p, params.density_k + 1);
            (positions[*nb.last().unwrap()] - p).norm()
        })
        .collect();
    let median = {
        let mut s = kth.clone();
        let half = s.len() / 2;
        *s.select_nth_unstable_by(half, Real::total_cmp).1
    };
    kth.iter().map(|&d| d <= params.outlier_factor * median).collect()
}

/// One anisotropic kernel: centre, normal, inverse of the scaled covariance, and size h.
#[derive(Debug, Clone, Copy)]
struct Kernel {
    centre: Point3,
    normal: Vector3,
    inv: Matrix3,
    h: Real,
    /// 1/√det of the kernel's covariance (up to a constant): Φ's peak as a probability density.
    density: Real,
}

/// A neighbourhood whose second axis is below this fraction of its first is a line, not a patch of
/// surface: a laser view's profile where the next view's lies farther than `k` neighbours reach.
const LINE_AXIS_RATIO: Real = 0.1;

/// One kernel per sample in `at` (indices into `points`), over its neighbours among all the points.
fn build_kernels(
    points: &[Point3],
    at: &[usize],
    normals: Option<&[Vector3]>,
    tree: &PointTree,
    p: &MeanShiftParams,
) -> Vec<Kernel> {
    at.par_iter()
        .map(|&i| {
            let pi = &points[i];
            let nb = tree.nearest_k(pi, p.k);
            // χ: a Gaussian of the distance to p_i over the neighbourhood's radius (eq. 3.2).
            let radius = (points[*nb.last().unwrap()] - pi).norm().max(1e-12);
            let chi: Vec<Real> = nb.iter().map(|&j| (-((points[j] - pi).norm() / radius).powi(2)).exp()).collect();
            let sw: Real = chi.iter().sum();
            let centre = nb.iter().zip(&chi).fold(Vector3::zeros(), |a, (&j, w)| a + points[j].coords * *w) / sw;
            let cov = nb.iter().zip(&chi).fold(Matrix3::zeros(), |a, (&j, w)| {
                let d = points[j].coords - centre;
                a + d * d.transpose() * *w
            }) / sw;
            let eig = cov.symmetric_eigen();
            let order = {
                let mut o = [0usize, 1, 2];
                o.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
                o
            };
            let largest = eig.eigenvalues[order[0]].max(1e-24);
            let mut inv = Matrix3::zeros();
            // The Gaussian's normalisation 1/√det: a kernel spread over a big blob of scattered points
            // (outliers' kernels) is a far lower density than a flat surface kernel of the same peak.
            let mut density = 1.0;
            for &l in &order {
                let v = eig.eigenvectors.column(l).into_owned();
                let lambda = eig.eigenvalues[l].max(largest * p.min_axis_ratio * p.min_axis_ratio);
                inv += v * v.transpose() / (lambda * p.kernel_scale * p.kernel_scale);
                density /= lambda.sqrt() * p.kernel_scale;
            }
            let mut normal = eig.eigenvectors.column(order[2]).into_owned();
            // On a line the covariance's smallest axis turns freely about it and says nothing of the
            // surface: the input's normals (estimated across views when the cloud was merged) do.
            if let Some(ns) = normals
                && eig.eigenvalues[order[1]] < LINE_AXIS_RATIO * LINE_AXIS_RATIO * largest
            {
                let own = ns[i];
                let mean = nb.iter().zip(&chi).fold(Vector3::zeros(), |a, (&j, w)| {
                    let n = ns[j];
                    a + if n.dot(&own) < 0.0 { -n } else { n } * *w
                }) / sw;
                if mean.norm() > 0.5 {
                    normal = mean.normalize();
                }
            }
            let h = p.kernel_scale * largest.sqrt();
            Kernel { centre: Point3::from(centre), normal, inv, h, density }
        })
        .collect()
}

/// The samples kernels are built at, and how many samples each stands for: every sample, or with
/// `kernel_spacing` the first (in the cloud's order) of each grid cell of that fraction of the
/// median kernel radius.
fn kernel_sites(points: &[Point3], tree: &PointTree, p: &MeanShiftParams) -> Sites {
    let every = || Sites { at: (0..points.len()).collect(), counts: vec![1.0; points.len()], of: Vec::new() };
    if p.kernel_spacing <= 0.0 {
        return every();
    }
    let stride = points.len().div_ceil(2000).max(1);
    let mut radii: Vec<Real> = (0..points.len())
        .step_by(stride)
        .map(|i| (points[*tree.nearest_k(&points[i], p.k).last().unwrap()] - points[i]).norm())
        .collect();
    // Thinning is for surfaces sampled over and over (overlapping range grids); laser lines, where a
    // neighbourhood is a stretch of one line, need every kernel to span the gaps between lines.
    // Eight neighbours: along a laser line they are its next rows, while a range grid's are a patch.
    let lines = (0..points.len())
        .step_by(stride)
        .filter(|&i| crate::normals::is_line(points, &tree.nearest_k(&points[i], 8)))
        .count();
    if lines * 50 > radii.len() {
        return every();
    }
    radii.sort_by(Real::total_cmp);
    let cell = p.kernel_spacing * radii[radii.len() / 2];
    if !(cell > 0.0 && cell.is_finite()) {
        return every();
    }
    let mut site_of_cell: rustc_hash::FxHashMap<[i64; 3], u32> = Default::default();
    let (mut at, mut counts, mut of) = (Vec::new(), Vec::new(), Vec::with_capacity(points.len()));
    for (i, q) in points.iter().enumerate() {
        let key = [0, 1, 2].map(|k| (q[k] / cell).floor() as i64);
        let s = *site_of_cell.entry(key).or_insert_with(|| {
            at.push(i);
            counts.push(0.0);
            (at.len() - 1) as u32
        });
        counts[s as usize] += 1.0;
        of.push(s);
    }
    Sites { at, counts, of }
}

/// Where kernels are built ([`kernel_sites`]).
struct Sites {
    /// The samples kernels are built at.
    at: Vec<usize>,
    /// How many samples each kernel stands for.
    counts: Vec<Real>,
    /// Each sample's kernel (its cell's), when thinned; empty when every sample has its own.
    of: Vec<u32>,
}

/// The outcome of fusion.
#[derive(Debug, Clone)]
pub struct MeanShiftResult {
    /// The filtered, clustered, outlier-free points with normals (the kernel normal at each
    /// representative, oriented like the input normals where the input has them).
    pub cloud: PointCloud,
    /// Per input sample: whether the cluster it converged to was kept (false: removed as an outlier).
    pub kept: Vec<bool>,
    /// What was done.
    pub report: MeanShiftReport,
}

/// How many samples [`mean_shift_owned_counting`] adds to its counter at once.
const PROGRESS_BLOCK: usize = 1024;

/// Fuses a cloud (see the module doc).
pub fn mean_shift<'a>(cloud: impl Into<rig::CloudRef<'a>>, params: &MeanShiftParams) -> MeanShiftResult {
    let cloud = cloud.into();
    // Every step is per-point neighbourhood work: in Morton order it stays cache-local, so time
    // grows linearly with the cloud (BENCHMARKS.md, mean shift scaling). The ordered copy is made
    // from the borrowed arrays directly: a caller's buffers are read once, not copied first.
    let order = crate::fuse::spatial_order::morton_order(cloud.positions);
    in_input_order(mean_shift_in_order(&cloud.select(&order), params, None), &order)
}

/// [`mean_shift`] on a cloud the caller no longer needs: its Morton-ordered copy replaces it, so a
/// pipeline holds one copy of the input, not two.
pub fn mean_shift_owned(cloud: PointCloud, params: &MeanShiftParams) -> MeanShiftResult {
    mean_shift_owned_counting(cloud, params, &AtomicUsize::new(0))
}

/// [`mean_shift_owned`], adding to `moved` as the samples start their shift (eqs. 3.8–3.10), a block at
/// a time, so a caller can show how far it is (the shift is most of the time; `moved` reaches the
/// cloud's size).
pub fn mean_shift_owned_counting(cloud: PointCloud, params: &MeanShiftParams, moved: &AtomicUsize) -> MeanShiftResult {
    let order = crate::fuse::spatial_order::morton_order(&cloud.positions);
    let ordered = cloud.select(&order);
    drop(cloud);
    in_input_order(mean_shift_in_order(&ordered, params, Some(moved)), &order)
}

/// `kept` back in the input's order from the Morton order `order` the fusion ran in.
fn in_input_order(mut result: MeanShiftResult, order: &[usize]) -> MeanShiftResult {
    let mut kept = vec![false; order.len()];
    for (&i, &k) in order.iter().zip(&result.kept) {
        kept[i] = k;
    }
    result.kept = kept;
    result
}

fn mean_shift_in_order(cloud: &PointCloud, params: &MeanShiftParams, moved: Option<&AtomicUsize>) -> MeanShiftResult {
    let mut report = MeanShiftReport { points_in: cloud.len(), ..Default::default() };
    if cloud.len() < params.k.max(params.density_k) + 1 {
        report.points_out = cloud.len();
        return MeanShiftResult { cloud: cloud.clone(), kept: vec![true; cloud.len()], report };
    }
    let t = std::time::Instant::now();
    let field = Field::new(cloud, params);
    report.seconds_kernels = t.elapsed().as_secs_f64();

    let t = std::time::Instant::now();
    let coloured = cloud.colors.is_some();
    let (shifted, colours): (Vec<Moved>, Vec<[f32; 3]>) =
        (0..cloud.len()).into_par_iter().map(|i| field.shift(cloud, params, i, moved)).unzip();
    // A cloud without colours holds no per-sample colour (the moved samples are the fusion's largest array).
    let colours = if coloured { colours } else { Vec::new() };
    report.mean_iterations = shifted.iter().map(|m| m.iterations as Real).sum::<Real>() / shifted.len() as Real;
    report.hit_iteration_limit = shifted.iter().filter(|m| m.iterations as usize >= params.max_iterations).count();
    report.seconds_shift = t.elapsed().as_secs_f64();
    let Field { kernels, sites, centre_tree, .. } = field;
    drop(centre_tree);

    let t = std::time::Instant::now();
    // Strays first: a sample where the kernel density at its start is low is an outlier whatever
    // maximum it reaches — eq. 3.7's adaptive step can carry it onto the surface, where it would
    // otherwise join (and bias) a surface cluster.
    let median_support = {
        let mut s: Vec<Real> = shifted.iter().map(|m| m.support).collect();
        let half = s.len() / 2;
        *s.select_nth_unstable_by(half, Real::total_cmp).1
    };
    let stray: Vec<bool> = shifted.iter().map(|m| m.support < params.min_support * median_support).collect();
    report.strays = stray.iter().filter(|&&s| s).count();
    let median_h = {
        let mut hs: Vec<Real> = kernels.iter().map(|k| k.h).collect();
        let half = hs.len() / 2;
        *hs.select_nth_unstable_by(half, Real::total_cmp).1
    };
    let clusters = Clusters::of(shifted, colours, &stray, params.merge * median_h);
    report.clusters = clusters.positions.len();
    // Section 3.3.1: groups of outliers converge to points sparsely spread around the surface, so a
    // representative whose `density_k`-th neighbouring representative is far farther than typical goes.
    let keep: Vec<bool> = if clusters.positions.len() > params.density_k {
        isolated_test(&clusters.positions, params, median_h)
    } else {
        vec![true; clusters.positions.len()]
    };
    let out = clusters.representatives(cloud, &keep, &kernels, &sites);
    report.outliers_removed = clusters.positions.len() - out.len();
    report.points_out = out.len();
    report.seconds_cluster = t.elapsed().as_secs_f64();
    let kept = clusters.cluster_of.iter().map(|&c| c != Clusters::NONE && keep[c as usize]).collect();
    MeanShiftResult { cloud: out, kept, report }
}

/// The field the samples climb: the kernels (eq. 3.4) at their sites, and for each site the
/// kernels its samples move under.
struct Field {
    /// The sample each kernel stands at.
    sites: Vec<usize>,
    /// The samples each kernel stands for.
    counts: Vec<Real>,
    /// Each sample's site (empty: every sample is its own).
    site_of: Vec<u32>,
    kernels: Vec<Kernel>,
    centre_tree: PointTree,
    /// Per site, its `kps` nearest kernels (u32::MAX: an empty slot).
    site_near: Vec<u32>,
    kps: usize,
}

impl Field {
    fn new(cloud: &PointCloud, params: &MeanShiftParams) -> Field {
        let tree = PointTree::new(&cloud.positions);
        let Sites { at: sites, counts, of: site_of } = kernel_sites(&cloud.positions, &tree, params);
        let kernels = build_kernels(&cloud.positions, &sites, cloud.normals.as_deref(), &tree, params);
        drop(tree);
        let centres: Vec<Point3> = kernels.iter().map(|k| k.centre).collect();
        let centre_tree = PointTree::new(&centres);
        // Thinned, the samples of one cell share the kernels nearest their cell's site: the cell is a
        // fraction of a kernel's reach, so they would pick (nearly) the same ones, at a third of the queries.
        let kps = params.kernels_per_step.max(1);
        let site_near: Vec<u32> = if site_of.is_empty() {
            Vec::new()
        } else {
            sites
                .par_iter()
                .flat_map_iter(|&i| {
                    let mut near: Vec<u32> =
                        centre_tree.nearest_k(&cloud.positions[i], kps).into_iter().map(|j| j as u32).collect();
                    // Fewer kernels than asked for (a tiny cloud): the rest of the slots marked empty.
                    near.resize(kps, u32::MAX);
                    near
                })
                .collect()
        };
        Field { sites, counts, site_of, kernels, centre_tree, site_near, kps }
    }

    /// Kernel j's weight: its sample's confidence, times the samples it stands for.
    fn weight(&self, cloud: &PointCloud, j: usize) -> Real {
        self.counts[j] * cloud.confidence.as_ref().map_or(1.0, |c| c[self.sites[j]] as Real)
    }

    /// Kernel j's φ at `p` (eq. 3.8).
    fn phi(&self, cloud: &PointCloud, j: usize, p: &Point3) -> Real {
        let k = &self.kernels[j];
        let y = p - k.centre;
        self.weight(cloud, j) * (-0.5 * y.dot(&(k.inv * y))).exp()
    }

    /// Eqs. 3.8–3.10 for sample `i`, independently of the others: where it converged, and its colour
    /// (the kernels' colours under the weights of its last step, so colour is averaged exactly as
    /// position is). `counter` counts the samples begun, a block at a time.
    fn shift(
        &self,
        cloud: &PointCloud,
        params: &MeanShiftParams,
        i: usize,
        counter: Option<&AtomicUsize>,
    ) -> (Moved, [f32; 3]) {
        // Counted a block at a time: one shared atomic per sample would bounce between cores.
        if let Some(c) = counter
            && i.is_multiple_of(PROGRESS_BLOCK)
        {
            c.fetch_add(PROGRESS_BLOCK.min(cloud.len() - i), Ordering::Relaxed);
        }
        let mut p = cloud.positions[i];
        let kps = self.kps;
        // The kernels are frozen per sample (as eq. 3.6 freezes Φ): re-choosing them every step makes
        // the field discontinuous and the samples oscillate instead of converging.
        let near: Vec<usize> = if self.site_of.is_empty() {
            self.centre_tree.nearest_k(&p, kps)
        } else {
            let s = self.site_of[i] as usize;
            self.site_near[s * kps..(s + 1) * kps].iter().filter(|&&j| j != u32::MAX).map(|&j| j as usize).collect()
        };
        let nearest = near[0];
        // The sample's own kernel, or (kernels thinned) the nearest one standing for it.
        let h = if self.sites.len() == cloud.len() { self.kernels[i].h } else { self.kernels[nearest].h };
        // The support at the sample's own position: eq. 3.7's adaptive step would carry even an
        // unsupported outlier onto the surface in one step, so support is judged before moving.
        let mut support = None;
        let colour_at = |p: &Point3| -> [f32; 3] {
            let Some(colors) = &cloud.colors else { return [0.0; 3] };
            let (mut sum, mut den) = ([0.0; 3], 0.0);
            for &j in &near {
                let phi = self.phi(cloud, j, p);
                for c in 0..3 {
                    sum[c] += phi * colors[self.sites[j]][c] as Real;
                }
                den += phi;
            }
            if den < 1e-300 { colors[i].map(|v| v as f32) } else { sum.map(|s| (s / den) as f32) }
        };
        let done = |p: Point3, it: usize, support: Real| {
            let m = Moved { p, iterations: it as u32, nearest: nearest as u32, support };
            (m, colour_at(&p))
        };
        for it in 0..params.max_iterations {
            let mut m = Vector3::zeros();
            let mut den = 0.0;
            let mut pdf = 0.0;
            for &j in &near {
                let k = &self.kernels[j];
                let y = p - k.centre;
                let phi = self.phi(cloud, j, &p);
                m += k.normal * (phi * y.dot(&k.normal));
                den += phi;
                pdf += phi * k.density;
            }
            let s0 = *support.get_or_insert(pdf);
            if den < 1e-300 {
                return done(p, it, s0);
            }
            let step = m / den;
            p -= step;
            if step.norm() < 1e-4 * h {
                return done(p, it + 1, s0);
            }
        }
        done(p, params.max_iterations, support.unwrap_or(0.0))
    }
}

/// The maxima the samples reached: samples that converged within a radius of each other reached the
/// same one. Per cluster, the mean of its samples' positions, their count, the kernel nearest its
/// first sample and its colour sum; per input sample, its cluster.
struct Clusters {
    positions: Vec<Point3>,
    count: Vec<u32>,
    near: Vec<u32>,
    colour_sums: Vec<[f32; 3]>,
    /// Per input sample, its cluster ([`Clusters::NONE`] for strays).
    cluster_of: Vec<u32>,
}

impl Clusters {
    const NONE: u32 = u32::MAX;

    /// Union–find over radius queries among the samples not `stray`, so a cluster never splits at an
    /// arbitrary cell border.
    fn of(moved: Vec<Moved>, colours: Vec<[f32; 3]>, stray: &[bool], radius: Real) -> Clusters {
        let members: Vec<usize> = (0..moved.len()).filter(|&i| !stray[i]).collect();
        let finals: Vec<Point3> = members.iter().map(|&i| moved[i].p).collect();
        let mut sets = rig::union_find::UnionFind::new(finals.len());
        // Each pair once (j > i), in one flat list: most samples end alone. A grid of cells twice the
        // radius finds them in the 8 cells about each sample, built on all cores (a k-d tree over 2.8 M
        // samples is built on one).
        let pairs = match CellGrid::new(&finals, 2.0 * radius) {
            Some(grid) => grid.pairs_within(radius),
            None => {
                let final_tree = PointTree::new(&finals);
                finals
                    .par_iter()
                    .enumerate()
                    .flat_map_iter(|(i, p)| {
                        final_tree
                            .within(p, radius)
                            .into_iter()
                            .filter(move |&j| j > i)
                            .map(move |j| (i as u32, j as u32))
                    })
                    .collect()
            }
        };
        for &(i, j) in &pairs {
            sets.union(i as usize, j as usize);
        }
        drop(pairs);
        drop(finals);
        let coloured = !colours.is_empty();
        let mut index = vec![Self::NONE; members.len()];
        let mut c = Clusters {
            positions: Vec::new(),
            count: Vec::new(),
            near: Vec::new(),
            colour_sums: Vec::new(),
            cluster_of: vec![Self::NONE; moved.len()],
        };
        for (m, &i) in members.iter().enumerate() {
            let r = sets.find(m);
            if index[r] == Self::NONE {
                index[r] = c.positions.len() as u32;
                c.positions.push(Point3::origin());
                c.count.push(0);
                c.near.push(moved[i].nearest);
                if coloured {
                    c.colour_sums.push([0.0; 3]);
                }
            }
            let k = index[r] as usize;
            c.positions[k] += moved[i].p.coords;
            c.count[k] += 1;
            if let Some(colour) = colours.get(i) {
                for (sum, v) in c.colour_sums[k].iter_mut().zip(colour) {
                    *sum += v;
                }
            }
            c.cluster_of[i] = k as u32;
        }
        // The clustering's working arrays go before the representatives' tree is built.
        drop((index, sets, members, moved, colours));
        for (p, &n) in c.positions.iter_mut().zip(&c.count) {
            *p = Point3::from(p.coords / n as Real);
        }
        c
    }

    /// The fused cloud: the representatives `keep` keeps, each with the normal of the kernel
    /// nearest it (turned to the input's side where the input had normals) and its mean colour.
    fn representatives(&self, cloud: &PointCloud, keep: &[bool], kernels: &[Kernel], sites: &[usize]) -> PointCloud {
        let kept_count = keep.iter().filter(|&&k| k).count();
        let mut out = PointCloud {
            positions: Vec::with_capacity(kept_count),
            normals: Some(Vec::with_capacity(kept_count)),
            colors: cloud.colors.as_ref().map(|_| Vec::with_capacity(kept_count)),
            ..Default::default()
        };
        for r in (0..self.positions.len()).filter(|&r| keep[r]) {
            if let Some(colors) = out.colors.as_mut() {
                let n = self.count[r] as f32;
                colors.push(self.colour_sums[r].map(|s| (s / n).round().clamp(0.0, 255.0) as u8));
            }
            let near = self.near[r] as usize;
            let mut n = kernels[near].normal;
            if let Some(input) = &cloud.normals
                && n.dot(&input[sites[near]]) < 0.0
            {
                n = -n;
            }
            out.positions.push(self.positions[r]);
            out.normals.as_mut().unwrap().push(n);
        }
        out
    }
}
