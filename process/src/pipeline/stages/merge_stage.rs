//! Merging: every view placed by its turntable pose, cropped to the object, one oriented cloud.

use crate::merge::views::{ViewData, ViewGrid, turntable_pose};
use crate::merge::{CropParams, place_sparse, place_view};
use crate::pipeline::records::{Fingerprint, StageCode, rig_part};
use rig::math::{Isometry3, Point3, Vector3};
use rig::{PointCloud, TurntableAxis};
use serde::{Deserialize, Serialize};
use serde_json::json;

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
    /// The working volume applied and the points each view had outside it ([`crate::pipeline::volume`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub volume: Option<crate::pipeline::volume::VolumeReport>,
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
pub(super) fn merge_at(views: &[ViewGrid], poses: &[Isometry3], crop: &CropParams) -> (PointCloud, MergeReport) {
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

/// The merge stage's code version.
pub const MERGE: StageCode = StageCode { stage: "merge", version: 1 };

/// What the merged cloud is made from besides the views' measurements: the crop, the object-top
/// search (a laser scan's) and the turntable exactly as the rig describes it.
pub fn merge_fingerprint(
    crop: &CropParams,
    top: Option<&crate::merge::object_top::TopParams>,
    turntable: Option<&TurntableAxis>,
) -> Fingerprint {
    Fingerprint::new(MERGE, json!({"crop": crop, "object_top": top, "rig.turntable": rig_part(&turntable)}))
}
