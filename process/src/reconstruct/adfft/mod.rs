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

mod leaf;
mod octree;
mod params;
mod slabs;
mod sweep;

pub use leaf::{LeafGrid, LeafSolver, LeafTask, SolvedLeaf};
pub use octree::{BYTES_PER_TRIANGLE, CoarseChi, MIN_SAMPLES_PER_CELL, TRIANGLES_PER_AREA_CELL, supported_depth};
pub use params::{AdFftParams, AdFftReport};
pub use slabs::{SlabJob, slab_part, sweep_slab};

use self::leaf::{Samples, solve_leaf};
use self::octree::{Plan, plan};
use self::slabs::slab_layers;
use self::sweep::{ActiveLeaf, extract};
use crate::reconstruct::global_fft::ReconstructError;
use crate::reconstruct::marching_cubes::{GridFrame, join_slabs};
use crate::reconstruct::{fit, prune, self_intersect};
use rayon::prelude::*;
use rig::TriMesh;
use rig::math::Real;
use std::sync::atomic::AtomicUsize;
use std::time::Instant;

/// Reconstructs a watertight mesh by AdFFT.
pub fn reconstruct_adfft<'a>(
    cloud: impl Into<rig::CloudRef<'a>>,
    params: &AdFftParams,
) -> Result<(TriMesh, AdFftReport), ReconstructError> {
    reconstruct_adfft_counting(cloud, params, &AtomicUsize::new(0))
}

/// [`reconstruct_adfft`], counting in `planes` the sweep's planes done (up to 2^depth), for a
/// progress display ([`crate::pipeline::watch`]): at depth 10 the sweep runs for minutes.
pub fn reconstruct_adfft_counting<'a>(
    cloud: impl Into<rig::CloudRef<'a>>,
    params: &AdFftParams,
    planes: &AtomicUsize,
) -> Result<(TriMesh, AdFftReport), ReconstructError> {
    adfft_of(cloud.into(), params, planes)
}

/// [`reconstruct_adfft_counting`]'s body, compiled once here: generic over the caller's cloud type,
/// the whole reconstruction was compiled again into every crate that called it.
fn adfft_of(
    cloud: rig::CloudRef<'_>,
    params: &AdFftParams,
    planes: &AtomicUsize,
) -> Result<(TriMesh, AdFftReport), ReconstructError> {
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
) -> Result<(TriMesh, AdFftReport), ReconstructError> {
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
        prune::prune_small_or_away(&mut mesh, params.min_component, &samples.tree, 4.0 * report.cell);
    let area: Real = samples.weights.iter().sum();
    let radius = fit::radius(samples.positions.len(), area, report.cell);
    report.fit = fit::fit_to_samples(&mut mesh, samples.positions, samples.normals, radius, 0.5 * report.cell);
    report.self_intersections = self_intersect::repair(&mut mesh, 8);
    report.seconds_extract = t.elapsed().as_secs_f64();
    report.vertices = mesh.vertices.len();
    report.triangles = mesh.faces.len();
    (mesh, report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::topology::topology;
    use std::sync::atomic::Ordering;

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
