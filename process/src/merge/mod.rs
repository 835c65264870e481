//! Placing views by their turntable pose: camera-frame range grids and sparse views into the object frame, the turntable
//! and background cropped away, and the views merged into one cloud that remembers where each point
//! came from.

pub mod object_top;
/// The views merged and registered, and the pose that places each.
pub mod views;

use rig::math::{Isometry3, Real, Vector3};
use rig::{PointCloud, RangeGrid, SparseView};
use serde::Serialize;

/// The cylinder of the object frame that holds the object: above the platter, within its radius.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CropParams {
    /// Keep points within this distance of the turntable axis (mm); `None` keeps all.
    pub radius_mm: Option<Real>,
    /// Keep points at least this high above the platter (mm): the platter itself is cut away.
    pub min_height_mm: Real,
    /// Keep points at most this high above the platter (mm), if set.
    pub max_height_mm: Option<Real>,
}

impl Default for CropParams {
    fn default() -> Self {
        CropParams { radius_mm: None, min_height_mm: 1.0, max_height_mm: None }
    }
}

impl CropParams {
    fn keeps(&self, x: Real, y: Real, z: Real) -> bool {
        z >= self.min_height_mm
            && self.max_height_mm.is_none_or(|m| z <= m)
            && self.radius_mm.is_none_or(|r| x * x + y * y <= r * r)
    }
}

/// A view's valid cells in the object frame (`object_from_camera` maps camera points there), cropped,
/// with normals (zero where the grid had none), confidence and the view id.
pub fn place_view(grid: &RangeGrid, object_from_camera: &Isometry3, crop: &CropParams, view_id: u32) -> PointCloud {
    let mut out = PointCloud {
        normals: grid.normals.as_ref().map(|_| Vec::new()),
        colors: grid.colors.as_ref().map(|_| Vec::new()),
        confidence: Some(Vec::new()),
        view_id: Some(Vec::new()),
        ..Default::default()
    };
    for i in (0..grid.points.len()).filter(|&i| grid.valid[i]) {
        let p = object_from_camera * grid.points[i];
        if !crop.keeps(p.x, p.y, p.z) {
            continue;
        }
        out.positions.push(p);
        if let (Some(dst), Some(src)) = (out.colors.as_mut(), grid.colors.as_ref()) {
            dst.push(src[i]);
        }
        if let (Some(dst), Some(src)) = (out.normals.as_mut(), grid.normals.as_ref()) {
            dst.push(object_from_camera.rotation * src[i]);
        }
        out.confidence.as_mut().unwrap().push(grid.confidence.as_ref().map_or(1.0, |c| c[i]));
        out.view_id.as_mut().unwrap().push(view_id);
    }
    out
}

/// A sparse view's points in the object frame, cropped, with confidence and the view id (no normals:
/// a line has none of its own; merging gives them).
pub fn place_sparse(view: &SparseView, object_from_camera: &Isometry3, crop: &CropParams, view_id: u32) -> PointCloud {
    let mut out = PointCloud {
        confidence: Some(Vec::new()),
        view_id: Some(Vec::new()),
        colors: view.colors.as_ref().map(|_| Vec::new()),
        ..Default::default()
    };
    for (i, (p, &c)) in view.points.iter().zip(&view.confidence).enumerate() {
        let p = object_from_camera * p;
        if crop.keeps(p.x, p.y, p.z) {
            out.positions.push(p);
            if let (Some(dst), Some(src)) = (out.colors.as_mut(), view.colors.as_ref()) {
                dst.push(src[i]);
            }
            out.confidence.as_mut().unwrap().push(c);
            out.view_id.as_mut().unwrap().push(view_id);
        }
    }
    out
}

/// All views in one cloud (normals only if every view has them).
pub fn merge(views: Vec<PointCloud>) -> PointCloud {
    let all_normals = views.iter().all(|v| v.normals.is_some());
    // Colour only if every view has it: a cloud half coloured would read as black elsewhere.
    let all_colours = !views.is_empty() && views.iter().all(|v| v.colors.is_some());
    let mut out = PointCloud {
        normals: all_normals.then(Vec::new),
        colors: all_colours.then(Vec::new),
        confidence: Some(Vec::new()),
        view_id: Some(Vec::new()),
        ..Default::default()
    };
    for v in views {
        let n = v.len();
        out.positions.extend(v.positions);
        if let (Some(dst), Some(src)) = (out.colors.as_mut(), v.colors) {
            dst.extend(src);
        }
        if let Some(dst) = out.normals.as_mut() {
            dst.extend(v.normals.unwrap_or_else(|| vec![Vector3::zeros(); n]));
        }
        out.confidence.as_mut().unwrap().extend(v.confidence.unwrap_or_else(|| vec![1.0; n]));
        out.view_id.as_mut().unwrap().extend(v.view_id.unwrap_or_else(|| vec![0; n]));
    }
    out
}
