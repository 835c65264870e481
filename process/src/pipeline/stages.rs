//! The stages as functions: plain data in, a new value and a report out, or a typed error. `scanrig
//! process` and every single-stage subcommand (`denoise`, `register`, `fuse`, `reconstruct`,
//! `remesh`) call these same functions with the same parameter types, whose `Default`s are the one
//! source of defaults — so a stage run alone and the same stage inside `process` write identical
//! files for identical inputs.

use crate::denoise::{DenoiseError, DenoiseParams, DenoiseReport};
use crate::fuse::mean_shift::{MeanShiftParams, MeanShiftReport};
use crate::kd_tree::PointTree;
use crate::merge::views::{ViewData, ViewGrid, turntable_pose};
use crate::merge::{CropParams, place_sparse, place_view};
use crate::reconstruct::adfft::{AdFftParams, AdFftReport, reconstruct_adfft};
pub use crate::reconstruct::base::{Base, BaseReport};
use crate::reconstruct::global_fft::{FftParams, FftReport, ReconstructError, reconstruct_fft_in};
pub use crate::reconstruct::trim::TrimReport;
use crate::register::icp::IcpError;
use crate::register::lasers::{LaserAlignParams, LasersReport};
use crate::register::multiview::MultiViewReport;
use crate::register::register_scan::{Refused, RegisterParams, Tolerance, ViewPose, register_grids};
use crate::remesh::{RemeshError, RemeshParams, RemeshReport};
use crate::triangulate::grid_normals::estimate_normals;
use rig::math::{Isometry3, Point3, Real, Vector3};
use rig::{PointCloud, PolyMesh, RangeGrid, TriMesh, TurntableAxis};
use serde::{Deserialize, Serialize};

/// Why a stage could not run on its input.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StageError {
    /// The frames cannot be decoded.
    #[error(transparent)]
    Decode(#[from] decode::structured_light::DecodeError),
    /// A projector map of another size than the rig's camera.
    #[error(
        "the frames are {}×{} pixels but the rig's camera is {}×{}: the rig does not belong to these frames \
         (check width_px and height_px in rig.toml)",
        map.0, map.1, camera.0, camera.1
    )]
    MapSize {
        /// The map's (frames') size.
        map: (usize, usize),
        /// The camera's size.
        camera: (u32, u32),
    },
    /// Fusion needs more points than its neighbourhoods hold.
    #[error(
        "the cloud has {points} points; fusion with {k} neighbours per kernel needs more (lower --k, or check \
         that the scan found the object)"
    )]
    TooFewPoints {
        /// Points in the cloud.
        points: usize,
        /// Neighbours per kernel.
        k: usize,
    },
    /// A point or normal that is not a finite number.
    #[error("point {index} of the cloud is not finite (position or normal NaN or infinite)")]
    NonFinite {
        /// The point.
        index: usize,
    },
    /// Normals of zero length: they face no side.
    #[error(
        "point {index} of the cloud has a zero normal ({count} such points): a normal without a side cannot \
         say where the outside is; drop the cloud's normals (fusion then estimates and orients them) or fix them"
    )]
    ZeroNormal {
        /// The first such point.
        index: usize,
        /// How many.
        count: usize,
    },
    /// The base could not be cut.
    #[error(transparent)]
    Base(#[from] crate::reconstruct::base::BaseError),
    /// The reconstruction found no surface.
    #[error(
        "the reconstruction found no surface in {points} points: the normals may point inward, or the cloud \
         is spread over a far larger box than the object (a stray point far away)"
    )]
    NoSurface {
        /// Points in the cloud.
        points: usize,
    },
    /// A streamline spacing so small the quad mesh could not be built in reasonable time.
    #[error(
        "--spacing {spacing:.3e}: {ratio:.0} times finer than the default for a mesh {diagonal:.4} across; \
         give at least {smallest:.4}"
    )]
    SpacingTooSmall {
        /// The spacing asked for.
        spacing: Real,
        /// The mesh's bounding-box diagonal.
        diagonal: Real,
        /// Default spacing over the asked one.
        ratio: Real,
        /// The smallest spacing accepted.
        smallest: Real,
    },
    /// A parameter outside what the stage can use (`process::limits`).
    #[error(transparent)]
    Param(#[from] rig::limits::ParamError),
    /// Denoising refused the grid.
    #[error(transparent)]
    Denoise(#[from] DenoiseError),
    /// Registration found too few views.
    #[error("registration needs at least two views, found {0}")]
    TooFewViews(usize),
    /// Pairwise registration failed.
    #[error("registration: {0}")]
    Icp(#[from] IcpError),
    /// A result that cannot be right: refused unless forced.
    #[error("{what}; {hint}")]
    Implausible {
        /// What is wrong, with the figures.
        what: String,
        /// What may cause it and what the user can do.
        hint: String,
    },
    /// The cloud cannot be meshed.
    #[error(transparent)]
    Reconstruct(#[from] ReconstructError),
    /// The mesh cannot be remeshed.
    #[error(transparent)]
    Remesh(#[from] RemeshError),
}

/// Decodes one view's structured-light frames into a projector map (see [`decode::decode_view`]).
pub fn decode(
    frames: &[(rig::Pattern, &rig::image::Image8)],
    projector_px: (u32, u32),
    params: &decode::structured_light::DecodeParams,
) -> Result<(crate::ProjectorMap, decode::structured_light::DecodeReport), StageError> {
    Ok(decode::structured_light::decode_view(frames, projector_px.0, projector_px.1, params)?)
}

/// Triangulates a decoded view into a range grid in the camera frame (mm) with grid normals: the
/// general ray–surface form of eq. 2.3 through `triangulator` (built once per rig), then normals
/// from grid neighbours no farther apart than `normal_max_jump_mm`.
pub fn triangulate(
    map: &crate::ProjectorMap,
    triangulator: &crate::triangulate::Triangulator,
    params: &crate::triangulate::TriangulateParams,
    normal_max_jump_mm: Real,
) -> Result<(RangeGrid, super::GridReport), StageError> {
    let camera = triangulator.camera_size();
    if (map.width, map.height) != (camera.0 as usize, camera.1 as usize) {
        return Err(StageError::MapSize { map: (map.width, map.height), camera });
    }
    let mut grid = triangulator.triangulate(map, params);
    let normals = estimate_normals(&mut grid, normal_max_jump_mm);
    let report = super::GridReport { points: grid.valid_count(), normals };
    Ok((grid, report))
}

/// Denoising a range grid: the filter (ch. 4), then grid normals estimated again where the grid had
/// them (the filter moves points, so the old normals no longer fit).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DenoiseStage {
    /// The filter.
    pub filter: DenoiseParams,
    /// Grid neighbours farther apart than this (the grid's units) are not used for its normals.
    pub normal_max_jump: Real,
}

impl Default for DenoiseStage {
    fn default() -> Self {
        DenoiseStage { filter: DenoiseParams::default(), normal_max_jump: 2.0 }
    }
}

/// Denoises frame `current` of `frames` using the frames within `temporal` of it (eq. 4.6; 0 filters
/// the frame alone, eq. 4.3), and estimates its normals again where it had them.
pub fn denoise(
    frames: &[RangeGrid],
    current: usize,
    temporal: usize,
    params: &DenoiseStage,
) -> Result<(RangeGrid, DenoiseReport), StageError> {
    params.validate()?;
    let (mut clean, report) = crate::denoise::denoise_sequence(frames, current, temporal, &params.filter)?;
    if clean.normals.is_some() {
        estimate_normals(&mut clean, params.normal_max_jump);
    }
    Ok((clean, report))
}

/// What merging did.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct MergeReport {
    /// Points in the merged cloud.
    pub points: usize,
    /// Points each view kept inside the object cylinder, in view order.
    pub placed_points: Vec<usize>,
    /// Points that had no normal (laser lines; grid cells whose neighbours jump) and got a PCA normal
    /// over their neighbours, turned toward their camera.
    pub sensor_normals: usize,
    /// The working volume applied and the points each view had outside it ([`super::volume`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub volume: Option<super::volume::VolumeReport>,
}

/// Neighbours for the PCA normals of clouds without normals. 48, because laser samples are dense
/// along each line and sparse across lines (a 2° step puts lines 1.7 mm apart at 50 mm from the axis,
/// rows 0.3 mm apart): a dozen neighbours lie on one line, and their "plane" turns freely about it.
pub const SENSOR_NORMAL_NEIGHBOURS: usize = 48;

/// At most this many of a PCA normal's neighbours come from one view (one laser line): the rest
/// from the lines beside it (see [`crate::normals::pca_normal_across_views`]).
pub const SENSOR_NORMAL_PER_VIEW: usize = 16;

/// Gives every point of a merged cloud without a normal (zero, or no normals at all) the PCA normal
/// of its [`SENSOR_NORMAL_NEIGHBOURS`] neighbours, turned toward the camera of its view (`centres`:
/// each view's camera centre in the object frame, by view id). Returns how many it filled.
pub fn fill_normals(cloud: &mut PointCloud, centres: &std::collections::HashMap<u32, Point3>) -> usize {
    use rayon::prelude::*;
    let normals = cloud.normals.get_or_insert_with(|| vec![Vector3::zeros(); cloud.positions.len()]);
    // Zero, NaN or infinite: no usable normal.
    let unusable = |n: &Vector3| !n.norm_squared().is_finite() || n.norm_squared() <= 0.5;
    let missing: Vec<usize> = (0..normals.len()).filter(|&i| unusable(&normals[i])).collect();
    if missing.is_empty() {
        return 0;
    }
    let tree = crate::kd_tree::PointTree::new(&cloud.positions);
    let filled: Vec<Vector3> = missing
        .par_iter()
        .map(|&i| {
            let p = &cloud.positions[i];
            let v = cloud.view_id.as_ref().map_or(0, |v| v[i]);
            let toward = centres.get(&v).map_or(Vector3::z(), |c| c - p);
            match &cloud.view_id {
                Some(ids) => crate::normals::pca_normal_across_views(
                    &cloud.positions,
                    &tree,
                    SENSOR_NORMAL_NEIGHBOURS,
                    SENSOR_NORMAL_PER_VIEW,
                    |j| ids[j],
                    p,
                    toward,
                ),
                None => crate::normals::pca_normal(&cloud.positions, &tree, SENSOR_NORMAL_NEIGHBOURS, p, toward),
            }
        })
        .collect();
    let normals = cloud.normals.as_mut().expect("set above");
    for (&i, n) in missing.iter().zip(filled) {
        normals[i] = n;
    }
    missing.len()
}

/// Places each view in the object frame by its turntable pose, crops it to the object cylinder and
/// merges them into one cloud with view ids and confidences; points without a normal get one
/// ([`fill_normals`]), so every merged cloud is oriented.
pub fn merge(views: &[ViewGrid], turntable: Option<&TurntableAxis>, crop: &CropParams) -> (PointCloud, MergeReport) {
    let poses: Vec<Isometry3> = views.iter().map(|v| turntable_pose(turntable, v.angle_deg)).collect();
    merge_at(views, &poses, crop)
}

/// [`merge`] with each view at its own camera → object pose.
fn merge_at(views: &[ViewGrid], poses: &[Isometry3], crop: &CropParams) -> (PointCloud, MergeReport) {
    use rayon::prelude::*;
    let placed: Vec<PointCloud> = views
        .par_iter()
        .zip(poses)
        .map(|(v, pose)| match v.data {
            ViewData::Grid(g) => place_view(g, pose, crop, v.view as u32),
            ViewData::Sparse(s) => place_sparse(s, pose, crop, v.view as u32),
        })
        .collect();
    let mut report = MergeReport { placed_points: placed.iter().map(|c| c.len()).collect(), ..Default::default() };
    let mut cloud = crate::merge::merge(placed);
    let centres = views.iter().zip(poses).map(|(v, pose)| (v.view as u32, pose * Point3::origin())).collect();
    report.sensor_normals = fill_normals(&mut cloud, &centres);
    report.points = cloud.len();
    (cloud, report)
}

/// What registration did.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct RegisterReport {
    /// Views registered.
    pub views: usize,
    /// The largest rotation of a view away from its turntable pose (degrees).
    pub max_rotation_change_deg: Real,
    /// The largest movement of a view's centroid away from its turntable pose (mm).
    pub max_shift_mm: Real,
    /// Points in the registered cloud.
    pub points: usize,
    /// Points given a PCA normal ([`fill_normals`]).
    pub sensor_normals: usize,
    /// Corrections beyond the tolerance, not applied (those views keep their turntable poses).
    #[serde(default)]
    pub refused: Vec<Refused>,
    /// The multi-view refinement's rounds.
    pub refinement: MultiViewReport,
    /// A laser scan's: how its lasers were aligned with each other (its views are lines, not refined
    /// one by one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lasers: Option<LasersReport>,
}

impl RegisterReport {
    /// The plausibility check: with refused corrections, an error unless `force`, else one warning
    /// per refused view.
    /// A laser scan's lasers that disagree by more than the lines' noise are warnings too.
    pub fn check(&self, tolerance: &Tolerance, force: bool) -> Result<Vec<String>, StageError> {
        let disagreements = self.lasers.iter().flat_map(LasersReport::disagreements);
        let Some(first) = self.refused.first() else { return Ok(disagreements.collect()) };
        let limit = format!(
            "beyond the {}° and {} mm a turntable can be off (--max-correction-deg, --max-correction-mm)",
            tolerance.rotation_deg, tolerance.shift_mm
        );
        if !force {
            let others = match self.refused.len() {
                1 => String::new(),
                n => format!(" (and {} more views)", n - 1),
            };
            return Err(StageError::Implausible {
                what: format!("{first}{others}, {limit}"),
                hint: "the views may overlap too little (take more views), or the object look the same turned; \
                       --force goes on with such views at their turntable poses"
                    .into(),
            });
        }
        let kept = self.refused.iter().map(|r| format!("{r}, {limit}: kept at its turntable pose (--force)"));
        Ok(kept.chain(disagreements).collect())
    }
}

/// Refines the views' poses from the turntable's by multi-view ICP (ch. 2.2) and merges them again,
/// cropped like [`merge`]. Returns the registered cloud and every view's pose; corrections beyond the
/// tolerance are not applied but listed in the report ([`RegisterReport::check`] decides on them).
/// A laser scan's views (lines) are registered laser against laser instead ([`register_lasers`]).
pub fn register(
    views: &[ViewGrid],
    axis: &TurntableAxis,
    crop: &CropParams,
    params: &RegisterParams,
) -> Result<(PointCloud, Vec<ViewPose>, RegisterReport), StageError> {
    params.validate()?;
    crop.validate()?;
    if views.iter().any(|v| matches!(v.data, ViewData::Sparse(_))) {
        return register_lasers(views, axis, crop, params);
    }
    let refs: Vec<(usize, Real, &RangeGrid)> = views
        .iter()
        .filter_map(|v| match v.data {
            ViewData::Grid(g) => Some((v.view, v.angle_deg, g)),
            ViewData::Sparse(_) => None,
        })
        .collect();
    if refs.len() < 2 {
        return Err(StageError::TooFewViews(refs.len()));
    }
    let (mut cloud, poses, refinement) = register_grids(&refs, axis, crop, params)?;
    // The refined poses place the cameras too: the normals a point lacks turn toward its own.
    let centres = poses.iter().map(|p| (p.view as u32, Point3::from(p.translation_mm()))).collect();
    let sensor_normals = fill_normals(&mut cloud, &centres);
    let applied = || poses.iter().filter(|p| !p.refused);
    let report = RegisterReport {
        sensor_normals,
        views: views.len(),
        max_rotation_change_deg: applied().map(|p| p.rotation_change_deg).fold(0.0, Real::max),
        max_shift_mm: applied().map(|p| p.shift_mm).fold(0.0, Real::max),
        refused: poses
            .iter()
            .filter(|p| p.refused)
            .map(|p| Refused { view: p.view, laser: None, rotation_deg: p.rotation_change_deg, shift_mm: p.shift_mm })
            .collect(),
        points: cloud.len(),
        refinement,
        lasers: None,
    };
    Ok((cloud, poses, report))
}

/// Registers a laser scan: each laser's lines, placed by the turntable, form one cloud, and every
/// laser's cloud is aligned with the reference laser's ([`crate::register::lasers`]); the lines are then merged
/// again at their corrected placements, cropped like [`merge`]. A correction beyond the tolerance is
/// not applied but listed as refused. With lines of fewer than two lasers (a laser whose frames gave
/// nothing) there is nothing to align: the lines are merged as the turntable placed them.
pub fn register_lasers(
    views: &[ViewGrid],
    axis: &TurntableAxis,
    crop: &CropParams,
    params: &RegisterParams,
) -> Result<(PointCloud, Vec<ViewPose>, RegisterReport), StageError> {
    let lasers = views.iter().map(|v| v.laser.unwrap_or(0) + 1).max().unwrap_or(0);
    let turntable: Vec<Isometry3> = views.iter().map(|v| axis.object_from_camera(v.angle_deg)).collect();
    let clouds: Vec<PointCloud> = (0..lasers)
        .map(|k| {
            let mine: Vec<usize> = (0..views.len()).filter(|&i| views[i].laser.unwrap_or(0) == k).collect();
            let lines: Vec<ViewGrid> = mine.iter().map(|&i| views[i]).collect();
            let poses: Vec<Isometry3> = mine.iter().map(|&i| turntable[i]).collect();
            merge_at(&lines, &poses, crop).0
        })
        .collect();
    let noise = crate::register::lasers::line_noise(views.iter().filter_map(|v| match v.data {
        ViewData::Sparse(s) => Some((&s.points[..], &s.pixels[..])),
        ViewData::Grid(_) => None,
    }))
    .unwrap_or(0.0);
    let align = LaserAlignParams {
        icp: params.refine.icp,
        prior: params.refine.prior,
        reach_mm: LASER_GAP_REACH * params.refine.icp.min_distance,
    };
    let (mut corrections, mut lr) = crate::register::lasers::align_lasers(&clouds, noise, &align)?;
    let mut refused = Vec::new();
    for a in &lr.lasers {
        if !params.tolerance.allows(a.rotation_deg, a.shift_mm) {
            corrections[a.laser] = Isometry3::identity();
            let first = views.iter().find(|v| v.laser.unwrap_or(0) == a.laser).map_or(0, |v| v.view);
            refused.push(Refused {
                view: first,
                laser: Some(a.laser),
                rotation_deg: a.rotation_deg,
                shift_mm: a.shift_mm,
            });
        }
    }
    lr.lasers
        .iter_mut()
        .filter(|a| refused.iter().any(|r| r.laser == Some(a.laser)))
        .for_each(|a| a.gap_after_mm = a.gap_before_mm);
    let poses: Vec<Isometry3> =
        views.iter().zip(&turntable).map(|(v, t)| corrections[v.laser.unwrap_or(0)] * t).collect();
    let (cloud, mr) = merge_at(views, &poses, crop);
    let view_poses = views
        .iter()
        .zip(&poses)
        .map(|(v, pose)| {
            let a = lr.lasers.iter().find(|a| Some(a.laser) == v.laser);
            let m = pose.to_homogeneous();
            ViewPose {
                view: v.view,
                laser: v.laser,
                angle_deg: v.angle_deg,
                object_from_camera: std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)])),
                rotation_change_deg: a.map_or(0.0, |a| a.rotation_deg),
                shift_mm: a.map_or(0.0, |a| a.shift_mm),
                refused: refused.iter().any(|r| r.laser.is_some() && r.laser == v.laser),
            }
        })
        .collect();
    let applied = || lr.lasers.iter().filter(|a| !refused.iter().any(|r| r.laser == Some(a.laser)));
    let report = RegisterReport {
        views: views.len(),
        max_rotation_change_deg: applied().map(|a| a.rotation_deg).fold(0.0, Real::max),
        max_shift_mm: applied().map(|a| a.shift_mm).fold(0.0, Real::max),
        points: cloud.len(),
        sensor_normals: mr.sensor_normals,
        refused,
        refinement: MultiViewReport::default(),
        lasers: Some(lr),
    };
    Ok((cloud, view_poses, report))
}

/// A laser's point counts in the gap between two lasers' surfaces within this many ICP distance
/// floors (`min_distance`) of the other surface.
const LASER_GAP_REACH: Real = 2.0;

/// Fusion: mean shift (ch. 3), then — for inputs without normals, whose kernel normals have no side —
/// a consistent orientation over a spanning tree of `orient_k` neighbours, the top facing up.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FuseParams {
    /// Mean shift.
    pub mean_shift: MeanShiftParams,
    /// Neighbours per point in the orientation graph.
    pub orient_k: usize,
}

impl Default for FuseParams {
    fn default() -> Self {
        // The pipeline's clouds are many overlapping views: one kernel per cell of 0.7 of a kernel's
        // reach stands for the samples the views share (a third of the time on the demo, and closer to
        // the truth: p95 0.0071 → 0.0056 % of the diagonal); clouds of laser lines are left whole.
        FuseParams { mean_shift: MeanShiftParams { kernel_spacing: 0.7, ..MeanShiftParams::default() }, orient_k: 12 }
    }
}

/// What fusion did: mean shift's report, and how the normals were oriented.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct FuseReport {
    /// Mean shift.
    #[serde(flatten)]
    pub mean_shift: MeanShiftReport,
    /// Points removed in all (strays and isolated representatives).
    pub points_removed: usize,
    /// Where the input had no normals: the connected parts the spanning-tree orientation seeded.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub oriented_parts: Option<usize>,
}

/// Fusion's result: the fused cloud with normals, and which input points survived.
#[derive(Debug, Clone)]
pub struct Fused {
    /// The fused cloud.
    pub cloud: PointCloud,
    /// Per input point: kept (true) or removed as an outlier.
    pub kept: Vec<bool>,
}

impl Fused {
    /// The input points removed as outliers (positions only).
    pub fn outliers(&self, input: &PointCloud) -> PointCloud {
        PointCloud::from_positions((0..input.len()).filter(|&i| !self.kept[i]).map(|i| input.positions[i]).collect())
    }
}

/// Fuses a cloud (see [`FuseParams`]).
pub fn fuse(cloud: PointCloud, params: &FuseParams) -> Result<(Fused, FuseReport), StageError> {
    fuse_counting(cloud, params, &std::sync::atomic::AtomicUsize::new(0))
}

/// [`fuse`], counting in `moved` the samples whose shift has begun (up to the cloud's size),
/// for a progress display ([`super::watch`]).
pub fn fuse_counting(
    cloud: PointCloud,
    params: &FuseParams,
    moved: &std::sync::atomic::AtomicUsize,
) -> Result<(Fused, FuseReport), StageError> {
    check_fusable(cloud.borrowed(), params)?;
    let had_normals = cloud.normals.is_some();
    // Owned: fusion's Morton-ordered copy replaces the input instead of sitting beside it.
    fused(crate::fuse::mean_shift::mean_shift_owned_counting(cloud, &params.mean_shift, moved), had_normals, params)
}

/// [`fuse`] of a borrowed cloud (a caller's arrays): its Morton-ordered working copy is the only one.
pub fn fuse_borrowed(cloud: rig::CloudRef<'_>, params: &FuseParams) -> Result<(Fused, FuseReport), StageError> {
    check_fusable(cloud, params)?;
    fused(crate::fuse::mean_shift::mean_shift(cloud, &params.mean_shift), cloud.normals.is_some(), params)
}

fn check_fusable(cloud: rig::CloudRef<'_>, params: &FuseParams) -> Result<(), StageError> {
    params.validate_for(cloud.len())?;
    check_finite(cloud)?;
    let k = params.mean_shift.k;
    if cloud.len() <= k.max(params.mean_shift.density_k) {
        return Err(StageError::TooFewPoints { points: cloud.len(), k });
    }
    Ok(())
}

/// Fusion's result oriented where the input had no normals, and its report.
fn fused(
    mut result: crate::fuse::mean_shift::MeanShiftResult,
    had_normals: bool,
    params: &FuseParams,
) -> Result<(Fused, FuseReport), StageError> {
    let mut oriented_parts = None;
    if !had_normals && let Some(normals) = result.cloud.normals.as_mut() {
        oriented_parts =
            Some(crate::fuse::orient::orient_by_spanning_tree(&result.cloud.positions, normals, params.orient_k));
    }
    let r = result.report;
    let report = FuseReport { points_removed: r.strays + r.outliers_removed, mean_shift: r, oriented_parts };
    Ok((Fused { cloud: result.cloud, kept: result.kept }, report))
}

/// The reconstruction method and its parameters (ch. 5).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "method")]
pub enum ReconstructParams {
    /// The global FFT method (Kazhdan 2005): one N³ grid.
    Fft(FftParams),
    /// AdFFT: local FFT solutions over an octree, blended by a partition of unity (thesis 5.3).
    Adfft(AdFftParams),
}

impl ReconstructParams {
    /// The octree depth (the global grid's, 2^depth a side).
    pub fn depth(&self) -> u32 {
        match self {
            ReconstructParams::Fft(p) => p.depth,
            ReconstructParams::Adfft(p) => p.depth,
        }
    }
}

impl Default for ReconstructParams {
    fn default() -> Self {
        ReconstructParams::Fft(FftParams::default())
    }
}

/// What reconstruction did, by method.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "method")]
pub enum ReconstructReport {
    /// The global method's report.
    Fft(FftReport),
    /// AdFFT's report.
    Adfft(AdFftReport),
}

impl ReconstructReport {
    /// Grid points per axis (AdFFT: of the equivalent global grid).
    pub fn n(&self) -> usize {
        match self {
            ReconstructReport::Fft(r) => r.n,
            ReconstructReport::Adfft(r) => r.n,
        }
    }
    /// Grid spacing, in the cloud's units.
    pub fn cell(&self) -> Real {
        match self {
            ReconstructReport::Fft(r) => r.cell,
            ReconstructReport::Adfft(r) => r.cell,
        }
    }
    /// Triangles written.
    pub fn triangles(&self) -> usize {
        match self {
            ReconstructReport::Fft(r) => r.triangles,
            ReconstructReport::Adfft(r) => r.triangles,
        }
    }
    /// Seconds spent.
    pub fn seconds(&self) -> Real {
        match self {
            ReconstructReport::Fft(r) => r.seconds_splat + r.seconds_fft + r.seconds_extract,
            ReconstructReport::Adfft(r) => r.seconds_octree + r.seconds_extract,
        }
    }
}

/// A watertight mesh of an oriented cloud.
pub fn reconstruct<'a>(
    cloud: impl Into<rig::CloudRef<'a>>,
    params: &ReconstructParams,
) -> Result<(TriMesh, ReconstructReport), StageError> {
    reconstruct_in(cloud, params, None)
}

/// [`reconstruct`] with a k-d tree over the cloud's positions the caller already has (`None`: built
/// where needed): the pipeline builds one and asks it for the area weights, the mesh's support
/// ([`check_support`]) and its colours ([`mesh_colours`]).
pub fn reconstruct_in<'a>(
    cloud: impl Into<rig::CloudRef<'a>>,
    params: &ReconstructParams,
    tree: Option<&PointTree>,
) -> Result<(TriMesh, ReconstructReport), StageError> {
    let cloud = cloud.into();
    check_finite(cloud)?;
    params.validate_for(rig::Aabb::of(cloud.positions).map_or(0.0, |b| b.diagonal()))?;
    let (mesh, report) = match params {
        ReconstructParams::Fft(p) => {
            let (m, r) = reconstruct_fft_in(cloud, p, tree)?;
            (m, ReconstructReport::Fft(r))
        }
        ReconstructParams::Adfft(p) => {
            let (m, r) = reconstruct_adfft(cloud, p)?;
            (m, ReconstructReport::Adfft(r))
        }
    };
    if mesh.faces.is_empty() {
        return Err(StageError::NoSurface { points: cloud.len() });
    }
    Ok((mesh, report))
}

/// What becomes of the reconstructed surface before it is written: its never-seen base, and surface
/// far from the data.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FinishParams {
    /// The base of an object on the platter (only where the platter plane is known: a turntable scan).
    pub base: Base,
    /// Remove surface farther than this from every sample (the cloud's units); `None` keeps it all.
    pub trim: Option<Real>,
    /// Close the holes trimming leaves, each by a fan from its centre.
    pub trim_fill: bool,
}

impl Default for FinishParams {
    fn default() -> Self {
        FinishParams { base: Base::Flat, trim: None, trim_fill: false }
    }
}

/// What finishing did.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct FinishReport {
    /// The base cut, where one was made.
    #[serde(default)]
    pub base: Option<BaseReport>,
    /// The trim, where asked.
    #[serde(default)]
    pub trim: Option<TrimReport>,
    /// The cut at the working volume's top, where the mesh rose above it
    /// ([`crate::reconstruct::top_cut`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub top: Option<BaseReport>,
    /// What was not done and why.
    #[serde(default)]
    pub skipped: Vec<String>,
}

/// A reconstruction's record: the method's report, and what finishing did.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MeshReport {
    /// The reconstruction.
    #[serde(flatten)]
    pub reconstruct: ReconstructReport,
    /// Base and trim.
    #[serde(default)]
    pub finish: FinishReport,
}

/// How far above the platter the base is cut, in reconstruction cells: above the low-pass's rounding
/// of the bottom edge (a cell or two), so the skirt below it is the object's wall.
pub const SKIRT_CELLS: Real = 2.0;

/// Finishes a reconstructed mesh: cuts its base at the platter plane `platter_z` (when known) as
/// `params.base` says — at [`SKIRT_CELLS`] of `cell` above it, carried straight down —, then trims
/// surface farther than `params.trim` from `samples` (never the flat base, which no sample need cover).
pub fn finish(
    mesh: TriMesh,
    samples: &PointCloud,
    params: &FinishParams,
    platter_z: Option<Real>,
    cell: Real,
) -> Result<(TriMesh, FinishReport), StageError> {
    params.validate()?;
    let mut report = FinishReport::default();
    let mut mesh = mesh;
    match (params.base, platter_z) {
        (Base::Closed, _) => {}
        (_, None) => report
            .skipped
            .push("base: the platter plane is not known (no turntable), so the base is kept as reconstructed".into()),
        (base, Some(z)) => {
            let (cut, r) = crate::reconstruct::base::cut_base(&mesh, base, z, SKIRT_CELLS * cell)?;
            mesh = cut;
            report.base = Some(r);
        }
    }
    if let Some(t) = params.trim {
        // The base (cap and skirt) is where the object stood: kept by definition, not by samples.
        let base = report.base.filter(|r| r.outline_edges > 0).map(|r| r.z + r.skirt);
        let faces_before = mesh.faces.len();
        let (trimmed, r) = crate::reconstruct::trim::trim(&mesh, &samples.positions, t, params.trim_fill, base);
        // A trim that takes (nearly) the whole surface is a distance below the data's spacing, not a
        // result.
        if trimmed.faces.len() * 10 < faces_before {
            return Err(StageError::Implausible {
                what: format!(
                    "--trim {t} removed {} of the mesh's {faces_before} faces",
                    faces_before - trimmed.faces.len()
                ),
                hint: format!(
                    "the distance is below the samples' spacing; give a larger --trim (the grid cell is {cell:.4})"
                ),
            });
        }
        mesh = trimmed;
        report.trim = Some(r);
    }
    Ok((mesh, report))
}

/// The largest median distance from a mesh's vertices to its cloud, as a fraction of the cloud's
/// bounding-box diagonal, that a reconstruction of the cloud can have. A mesh the data supports lies
/// on its points (median 0.1–0.2 % of the diagonal on the simulated scans, where closing the holes a
/// scan leaves puts a tenth or more of the vertices far from any point); a median of several per cent
/// means most of the surface is made up — inconsistent normals (a laser scan's, 6.9 %) or a stray
/// cluster.
pub const MAX_MEDIAN_GAP: Real = 0.02;

/// The plausibility check of a reconstruction: the median distance from the mesh's vertices
/// (sampled, up to 20,000) to the nearest point of `cloud`. Beyond [`MAX_MEDIAN_GAP`] of the
/// diagonal: an error unless `force`, else the warning to give.
pub fn check_support(
    mesh: &TriMesh,
    cloud: &PointCloud,
    tree: &PointTree,
    force: bool,
) -> Result<Option<String>, StageError> {
    let Some(bounds) = cloud.bounding_box() else { return Ok(None) };
    let diagonal = (bounds.max - bounds.min).norm();
    let step = mesh.vertices.len().div_ceil(20_000).max(1);
    let mut gaps: Vec<Real> = mesh.vertices.iter().step_by(step).map(|v| tree.nearest(v).1.sqrt()).collect();
    if gaps.is_empty() {
        return Ok(None);
    }
    let mid = gaps.len() / 2;
    let median = *gaps.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
    if median <= MAX_MEDIAN_GAP * diagonal {
        return Ok(None);
    }
    let what = format!(
        "the mesh lies far from its cloud: half its vertices are more than {median:.2} mm from any point ({:.1} % of \
         the cloud's {diagonal:.0} mm diagonal, over {} %)",
        100.0 * median / diagonal,
        100.0 * MAX_MEDIAN_GAP
    );
    if force {
        return Ok(Some(format!("{what} (--force)")));
    }
    Err(StageError::Implausible {
        what,
        hint: "most of the surface is not in the data — normals that disagree, or a cluster of stray points; \
               --force keeps it"
            .into(),
    })
}

/// Refuses a cloud with a NaN or infinite position or normal (every later distance would be NaN) or
/// a zero normal.
fn check_finite(cloud: rig::CloudRef<'_>) -> Result<(), StageError> {
    let bad_point = cloud.positions.iter().position(|p| !p.coords.iter().all(|x| x.is_finite()));
    let bad_normal = cloud.normals.and_then(|n| n.iter().position(|v| !v.iter().all(|x| x.is_finite())));
    if let Some(index) = bad_point.into_iter().chain(bad_normal).min() {
        return Err(StageError::NonFinite { index });
    }
    if let Some(n) = cloud.normals {
        let zero: Vec<usize> = (0..n.len()).filter(|&i| n[i].norm_squared() <= 1e-24).collect();
        if let Some(&index) = zero.first() {
            return Err(StageError::ZeroNormal { index, count: zero.len() });
        }
    }
    Ok(())
}

/// A quad mesh of a triangle mesh (ch. 6).
pub fn remesh(mesh: &TriMesh, params: &RemeshParams) -> Result<(PolyMesh, RemeshReport), StageError> {
    remesh_counting(mesh, params, &std::sync::atomic::AtomicUsize::new(0))
}

/// [`remesh`], counting its phases in `phases` (up to
/// [`REMESH_PHASES`](crate::remesh::quad_remesh::REMESH_PHASES)) for a progress display ([`super::watch`]).
pub fn remesh_counting(
    mesh: &TriMesh,
    params: &RemeshParams,
    phases: &std::sync::atomic::AtomicUsize,
) -> Result<(PolyMesh, RemeshReport), StageError> {
    params.validate()?;
    if let (Some(spacing), Some(b)) = (params.spacing, mesh.bounding_box()) {
        let diagonal = b.diagonal();
        let default = crate::remesh::quad_remesh::DEFAULT_SPACING * diagonal;
        // Quads grow with (default / spacing)²: 50× finer is 2,500× the faces of the default remesh.
        if spacing < default / crate::remesh::quad_remesh::MAX_SPACING_RATIO {
            let smallest = default / crate::remesh::quad_remesh::MAX_SPACING_RATIO;
            return Err(StageError::SpacingTooSmall { spacing, diagonal, ratio: default / spacing, smallest });
        }
        // Streamlines farther apart than half the mesh's size cross it once or never: no quads.
        if spacing > diagonal / 2.0 {
            return Err(StageError::Implausible {
                what: format!("--spacing {spacing:.4e} is more than half the mesh's size ({diagonal:.4} across)"),
                hint: format!("no quads fit; give a spacing below {:.4} (the default is {default:.4})", diagonal / 2.0),
            });
        }
    }
    let (mut quads, mut report) = crate::remesh::quad_remesh::remesh_counting(mesh, params, phases)?;
    if quads.face_count() == 0 {
        return Err(StageError::Implausible {
            what: format!("the remesh of {} triangles has no faces", mesh.faces.len()),
            hint: "the mesh may be degenerate (no area) or the --spacing too coarse for it".into(),
        });
    }
    // What the splitter leaves of n-gons, and quads that fold, are cut into triangles: readers
    // (Open3D) refuse non-convex polygons, and a fan folds them. Kept only when asked for.
    if params.split_polygons {
        let (readable, cut) = quads.with_readable_faces();
        quads = readable;
        let sizes = quads.face_sizes();
        let q = &mut report.quality;
        (q.faces, q.quads, q.triangles, q.polygons) = (quads.face_count(), sizes.quads, sizes.triangles, sizes.larger);
        q.quad_fraction = sizes.quads as Real / q.faces.max(1) as Real;
        report.split.cut_for_readers = cut;
    }
    // Readers triangulate polygons by fans from the first corner; start each where that adds no
    // non-manifold diagonal.
    quads.rotate_faces_for_fans();
    Ok((quads, report))
}

/// A reconstructed mesh as it is written: with its vertex normals, which viewers shade by, and the
/// colours of `colours` where given.
pub fn mesh_for_output(mesh: &TriMesh, colours: Option<Vec<[u8; 3]>>) -> PolyMesh {
    PolyMesh { normals: Some(mesh.vertex_normals()), colors: colours, ..mesh.to_poly() }
}

/// Each mesh vertex's colour from the cloud it was made from: the inverse-distance mean of its four
/// nearest coloured samples (a vertex lies between samples, and one sample's noise should not be its
/// colour). `None` when the cloud has no colour.
pub fn mesh_colours(mesh: &TriMesh, cloud: &PointCloud, tree: &PointTree) -> Option<Vec<[u8; 3]>> {
    use rayon::prelude::*;
    let colors = cloud.colors.as_ref().filter(|c| !c.is_empty())?;
    Some(
        mesh.vertices
            .par_iter()
            .map(|v| {
                let (mut sum, mut den) = ([0.0; 3], 0.0);
                for j in tree.nearest_k(v, 4) {
                    let w = 1.0 / ((cloud.positions[j] - v).norm() + 1e-6);
                    for c in 0..3 {
                        sum[c] += w * colors[j][c] as Real;
                    }
                    den += w;
                }
                sum.map(|s| (s / den).round().clamp(0.0, 255.0) as u8)
            })
            .collect(),
    )
}

/// The 8-bit colour of a colour (or grey) image at a sub-pixel position, bilinear; edges clamped.
pub fn colour_at(image: &rig::image::Image8, px: [f32; 2]) -> [u8; 3] {
    let (w, h) = (image.width as usize, image.height as usize);
    let x = (px[0] as Real).clamp(0.0, (w - 1) as Real);
    let y = (px[1] as Real).clamp(0.0, (h - 1) as Real);
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = (x - x0 as Real, y - y0 as Real);
    let nc = image.channels as usize;
    let at = |xx: usize, yy: usize, c: usize| image.data[(yy * w + xx) * nc + c.min(nc - 1)] as Real;
    std::array::from_fn(|c| {
        let top = at(x0, y0, c) * (1.0 - fx) + at(x1, y0, c) * fx;
        let bottom = at(x0, y1, c) * (1.0 - fx) + at(x1, y1, c) * fx;
        (top * (1.0 - fy) + bottom * fy).round().clamp(0.0, 255.0) as u8
    })
}

/// A range grid's colours from the view's texture frame (same size as the grid: camera pixels).
pub fn grid_colours(grid: &RangeGrid, texture: &rig::image::Image8) -> Option<Vec<[u8; 3]>> {
    if (texture.width as usize, texture.height as usize) != (grid.width, grid.height) {
        return None;
    }
    let w = grid.width;
    Some(
        (0..grid.points.len())
            .map(|i| if grid.valid[i] { colour_at(texture, [(i % w) as f32, (i / w) as f32]) } else { [0; 3] })
            .collect(),
    )
}

/// The registered poses as `registered.poses.json` holds them.
pub fn poses_json(poses: &[ViewPose]) -> Vec<u8> {
    serde_json::to_vec_pretty(poses).expect("poses serialise")
}
