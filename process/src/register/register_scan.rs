//! Registering a processed scan: every view's range grid (denoised where available) refined from its
//! turntable pose by multi-view ICP ([`crate::register::multiview`]), then placed, cropped and merged again. What
//! `scanrig register` runs on the output of `scanrig process`.

use crate::merge::{CropParams, merge, place_view};
use crate::register::icp::IcpError;
use crate::register::multiview::{MultiViewParams, MultiViewReport, View, refine_views};
use crate::triangulate::grid_normals;
use rayon::prelude::*;
use rig::math::{Isometry3, Real};
use rig::{PointCloud, RangeGrid, TurntableAxis};
use serde::Serialize;

/// The most a registration may move a view from its turntable pose. A turntable that steps and a
/// calibrated axis are off by a degree or two and a few millimetres; a correction far beyond that is
/// not a better pose but a registration gone wrong (a symmetric object slid round, two views that
/// barely overlap), and is refused: the view keeps its turntable pose.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Tolerance {
    /// Largest rotation (degrees).
    pub rotation_deg: Real,
    /// Largest movement of the view's centroid (mm).
    pub shift_mm: Real,
}

impl Tolerance {
    /// Whether a correction of `rotation_deg` and `shift_mm` is within the tolerance (NaN is not: a pose
    /// that is not a number is no correction).
    pub fn allows(&self, rotation_deg: Real, shift_mm: Real) -> bool {
        rotation_deg <= self.rotation_deg && shift_mm <= self.shift_mm
    }
}

impl Default for Tolerance {
    fn default() -> Self {
        Tolerance { rotation_deg: 5.0, shift_mm: 10.0 }
    }
}

/// Registration's settings: the multi-view refinement and the tolerance on its corrections.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RegisterParams {
    /// The refinement.
    pub refine: MultiViewParams,
    /// The corrections accepted.
    pub tolerance: Tolerance,
}

impl Default for RegisterParams {
    fn default() -> Self {
        // Turntable views overlap the views within about a quarter turn of them, not the far side:
        // each registers against those, so the work grows with the views, not their square.
        let refine = MultiViewParams { neighbour_deg: 100.0, ..MultiViewParams::default() };
        RegisterParams { refine, tolerance: Tolerance::default() }
    }
}

/// A correction beyond the [`Tolerance`], not applied.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
pub struct Refused {
    /// The view (for a laser's correction, its first view).
    pub view: usize,
    /// A laser whose whole cloud the correction moved (a laser scan's registration), not one view.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub laser: Option<usize>,
    /// The rotation registration found (degrees).
    pub rotation_deg: Real,
    /// The centroid's movement it found (mm).
    pub shift_mm: Real,
}

impl std::fmt::Display for Refused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let what = match self.laser {
            Some(k) => format!("laser {k}'s lines"),
            None => format!("view {}", self.view),
        };
        write!(
            f,
            "registration would turn {what} by {:.1}° and move {} {:.1} mm from {} turntable pose",
            self.rotation_deg,
            if self.laser.is_some() { "them" } else { "it" },
            self.shift_mm,
            if self.laser.is_some() { "their" } else { "its" }
        )
    }
}

/// One view's refined pose and how far it moved from the turntable's.
#[derive(Debug, Clone, Serialize)]
pub struct ViewPose {
    /// View index.
    pub view: usize,
    /// The laser whose line this is (a laser scan: one pose per view and laser).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub laser: Option<usize>,
    /// Turntable angle (degrees).
    pub angle_deg: Real,
    /// The refined camera → object transform, row-major 4 × 4.
    pub object_from_camera: [[Real; 4]; 4],
    /// Rotation between the turntable pose and the refined one (degrees).
    pub rotation_change_deg: Real,
    /// Movement of the view's centroid between the two poses (mm).
    pub shift_mm: Real,
    /// The correction registration found was beyond the tolerance: the view keeps its turntable
    /// pose, and the two figures above are the refused correction's.
    pub refused: bool,
}

/// A grid's valid cells as a view: points, unit normals (grid normals, estimated if absent) and the
/// cells on the grid's boundary.
fn view_of(mut grid: RangeGrid) -> View {
    if grid.normals.is_none() {
        grid_normals::estimate_normals(&mut grid, 2.0);
    }
    let (w, h) = (grid.width, grid.height);
    let normals = grid.normals.as_ref().expect("estimated above");
    let cells: Vec<usize> = (0..w * h).filter(|&i| grid.valid[i] && normals[i].norm_squared() > 0.0).collect();
    View {
        points: cells.iter().map(|&i| grid.points[i]).collect(),
        normals: cells.iter().map(|&i| normals[i]).collect(),
        boundary: cells
            .iter()
            .map(|&i| {
                let (c, r) = (i % w, i / w);
                c == 0
                    || r == 0
                    || c + 1 == w
                    || r + 1 == h
                    || [i - 1, i + 1, i - w, i + w].iter().any(|&j| !grid.valid[j])
            })
            .collect(),
    }
}

impl ViewPose {
    /// The pose's translation: where the view's camera centre lies in the object frame (mm).
    pub fn translation_mm(&self) -> rig::Vector3 {
        let m = &self.object_from_camera;
        rig::Vector3::new(m[0][3], m[1][3], m[2][3])
    }
}

/// Refines the poses of views from their turntable poses by multi-view ICP and merges them again,
/// cropped like the pipeline's merge; a view whose correction is beyond the tolerance keeps its
/// turntable pose (marked `refused`). `grids` are (view index, turntable angle, range grid); at least
/// two (see [`crate::pipeline::stages::register`]). Returns the registered cloud, every view's pose
/// and the registration's report.
pub fn register_grids(
    grids: &[(usize, Real, &RangeGrid)],
    axis: &TurntableAxis,
    crop: &CropParams,
    params: &RegisterParams,
) -> Result<(PointCloud, Vec<ViewPose>, MultiViewReport), IcpError> {
    let views: Vec<View> = grids.par_iter().map(|(_, _, g)| view_of((*g).clone())).collect();
    let initial: Vec<Isometry3> = grids.iter().map(|&(_, a, _)| axis.object_from_camera(a)).collect();
    let (poses, report) = refine_views(&views, &initial, None, &params.refine)?;
    // Views placed side by side (each is independent of the others), merged in view order.
    let placed: Vec<(PointCloud, ViewPose)> = grids
        .par_iter()
        .enumerate()
        .map(|(k, &(v, angle, grid))| {
            let n = views[k].points.len().max(1) as Real;
            let c = rig::Point3::from(views[k].points.iter().fold(rig::Vector3::zeros(), |a, p| a + p.coords) / n);
            let rotation_change_deg = (poses[k].rotation.inverse() * initial[k].rotation).angle().to_degrees();
            let shift_mm = (poses[k] * c - initial[k] * c).norm();
            let refused = !params.tolerance.allows(rotation_change_deg, shift_mm);
            let pose = if refused { initial[k] } else { poses[k] };
            let view_pose = ViewPose {
                view: v,
                laser: None,
                angle_deg: angle,
                object_from_camera: rig::math::rows_of(&pose),
                rotation_change_deg,
                shift_mm,
                refused,
            };
            (place_view(grid, &pose, crop, v as u32), view_pose)
        })
        .collect();
    let (clouds, view_poses): (Vec<PointCloud>, Vec<ViewPose>) = placed.into_iter().unzip();
    Ok((merge(clouds), view_poses, report))
}
