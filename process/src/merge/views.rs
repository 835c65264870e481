//! The views a scan's merge and registration take: each view's index, turntable angle, laser and
//! what it measured, and the pose that places it in the object frame.

use rig::math::{Isometry3, Real};
use rig::{RangeGrid, SparseView, TurntableAxis};

/// What a view measured: a range grid (structured light: a point per pixel) or a sparse view (a
/// laser line: a point per row).
#[derive(Debug, Clone, Copy)]
pub enum ViewData<'a> {
    /// A dense range grid.
    Grid(&'a RangeGrid),
    /// Points with their pixels.
    Sparse(&'a SparseView),
}

/// One view to merge or register: its index, turntable angle (degrees) and what it measured (camera
/// frame, mm).
#[derive(Debug, Clone, Copy)]
pub struct ViewGrid<'a> {
    /// View index (kept as the points' `view_id`).
    pub view: usize,
    /// Turntable angle, degrees, counter-clockwise seen from above.
    pub angle_deg: Real,
    /// The laser whose line this is (a laser scan has one per view and laser).
    pub laser: Option<usize>,
    /// The measurements.
    pub data: ViewData<'a>,
}

impl<'a> ViewGrid<'a> {
    /// A view of a range grid.
    pub fn grid(view: usize, angle_deg: Real, grid: &'a RangeGrid) -> Self {
        ViewGrid { view, angle_deg, laser: None, data: ViewData::Grid(grid) }
    }
}

/// The camera → object pose of a view at `angle_deg` (the identity without a turntable).
pub fn turntable_pose(turntable: Option<&TurntableAxis>, angle_deg: Real) -> Isometry3 {
    turntable.map(|t| t.object_from_camera(angle_deg)).unwrap_or_else(Isometry3::identity)
}
