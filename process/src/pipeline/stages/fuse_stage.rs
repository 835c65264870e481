//! Fusion: mean shift (ch. 3) and, for clouds without normals, their orientation.

use super::StageError;
use super::mesh_stage::check_cloud;
use crate::fuse::mean_shift::{MeanShiftParams, MeanShiftReport};
use crate::pipeline::records::{Fingerprint, StageCode};
pub use crate::reconstruct::base::{Base, BaseReport};
pub use crate::reconstruct::trim::TrimReport;
use rig::PointCloud;
use serde::{Deserialize, Serialize};
use serde_json::json;

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
/// for a progress display ([`crate::pipeline::watch`]).
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
    check_cloud(cloud)?;
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

/// The fuse stage's code version.
pub const FUSE: StageCode = StageCode { stage: "fuse", version: 1 };

/// What the fused cloud is made from besides its input cloud: fusion's parameters.
pub fn fuse_fingerprint(params: &FuseParams) -> Fingerprint {
    Fingerprint::new(FUSE, json!({ "fuse": params }))
}
