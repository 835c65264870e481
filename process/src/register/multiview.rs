//! Multi-view registration in two stages. First, views are placed one at a time, outward from a fixed
//! anchor, each against the union of the views already placed — so no view is ever pulled toward others
//! that are still at their rough starting poses (a group of such views can agree with each other and lock
//! into a wrong pose together). Then every view is refined in turn against the union of all the others,
//! for a few rounds — closing the 360° loop so that error does not accumulate along a chain.

use crate::icp::{IcpError, IcpParams, IcpReport, IcpTarget, PosePrior, icp_near};
use rig::math::{Isometry3, Point3, Real, Vector3};
use serde::Serialize;

/// One view: points in its own frame, unit normals, and scan-boundary flags.
#[derive(Debug, Clone, PartialEq)]
pub struct View {
    /// Points (view frame).
    pub points: Vec<Point3>,
    /// Unit normals (view frame).
    pub normals: Vec<Vector3>,
    /// Whether each point lies on the scan's boundary.
    pub boundary: Vec<bool>,
}

/// Settings of the refinement.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MultiViewParams {
    /// The pairwise registration used for each view.
    pub icp: IcpParams,
    /// Rounds over all views.
    pub rounds: usize,
    /// The view that stays where it is (its pose fixes the frame).
    pub anchor: usize,
    /// Points taken from each other view into a target union (evenly strided), keeping the k-d tree small.
    pub target_points_per_view: usize,
    /// How far a view's true pose may lie from its starting (turntable) pose, held as a prior on
    /// every registration of the view (`None`: none, the starting poses are only starts).
    pub prior: Option<PosePrior>,
}

impl Default for MultiViewParams {
    fn default() -> Self {
        MultiViewParams {
            icp: IcpParams::default(),
            rounds: 3,
            anchor: 0,
            target_points_per_view: 8000,
            // A turntable's step error and a calibrated axis are good to about a degree and a few mm.
            prior: Some(PosePrior { rotation_deg: 2.0, shift: 5.0 }),
        }
    }
}

/// What the refinement did.
#[derive(Debug, Clone, Default, Serialize, serde::Deserialize)]
pub struct MultiViewReport {
    /// Rounds run.
    pub rounds: usize,
    /// The last round's registration of each view (the anchor's is empty).
    pub views: Vec<IcpReport>,
    /// Per round, the largest change of any view's pose: rotation (degrees).
    pub max_rotation_change_deg: Vec<Real>,
    /// Per round, the largest change of any view's centroid (data units).
    pub max_shift: Vec<Real>,
}

/// The union of the views `include` says yes to, `per_view` points each, at their poses.
fn union_target(views: &[View], poses: &[Isometry3], include: impl Fn(usize) -> bool, per_view: usize) -> IcpTarget {
    let (mut pts, mut nrm, mut bnd) = (Vec::new(), Vec::new(), Vec::new());
    for (v, (view, pose)) in views.iter().zip(poses).enumerate() {
        if !include(v) {
            continue;
        }
        let stride = view.points.len().div_ceil(per_view.max(1)).max(1);
        for k in (0..view.points.len()).step_by(stride) {
            pts.push(pose * view.points[k]);
            nrm.push(pose.rotation * view.normals[k]);
            bnd.push(view.boundary[k]);
        }
    }
    IcpTarget::new(pts, nrm, Some(bnd))
}

/// The default placement order for a turntable sequence: outward from the anchor, alternating sides
/// (a, a+1, a−1, a+2, …, cyclically).
pub fn turntable_order(views: usize, anchor: usize) -> Vec<usize> {
    let mut order = Vec::with_capacity(views);
    for step in 1..views {
        let k = step.div_ceil(2);
        let v = if step % 2 == 1 { (anchor + k) % views } else { (anchor + views - k) % views };
        if !order.contains(&v) && v != anchor {
            order.push(v);
        }
    }
    order
}

/// Registers all views (poses: view frame → common frame) from `initial`, placing them in `order`
/// (every view but the anchor, each exactly once; `None` takes [`turntable_order`]).
pub fn refine_views(
    views: &[View],
    initial: &[Isometry3],
    order: Option<&[usize]>,
    params: &MultiViewParams,
) -> Result<(Vec<Isometry3>, MultiViewReport), IcpError> {
    let mut poses = initial.to_vec();
    let default_order = turntable_order(views.len(), params.anchor);
    let mut placed = vec![false; views.len()];
    placed[params.anchor] = true;
    for &v in order.unwrap_or(&default_order) {
        let target = union_target(views, &poses, |u| placed[u], params.target_points_per_view);
        let prior = params.prior.map(|p| (&initial[v], p));
        poses[v] = icp_near(&views[v].points, &views[v].normals, &target, &poses[v], prior, &params.icp)?.0;
        placed[v] = true;
    }
    let mut report = MultiViewReport { views: vec![IcpReport::default(); views.len()], ..Default::default() };
    let centroids: Vec<Point3> = views
        .iter()
        .map(|v| {
            Point3::from(v.points.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / v.points.len().max(1) as Real)
        })
        .collect();
    for _ in 0..params.rounds {
        let (mut max_rot, mut max_shift) = (0.0f64, 0.0f64);
        for v in 0..views.len() {
            if v == params.anchor {
                continue;
            }
            let target = union_target(views, &poses, |u| u != v, params.target_points_per_view);
            let prior = params.prior.map(|p| (&initial[v], p));
            let (pose, r) = icp_near(&views[v].points, &views[v].normals, &target, &poses[v], prior, &params.icp)?;
            max_rot = max_rot.max((pose.rotation.inverse() * poses[v].rotation).angle().to_degrees());
            max_shift = max_shift.max((pose * centroids[v] - poses[v] * centroids[v]).norm());
            poses[v] = pose;
            report.views[v] = r;
        }
        report.rounds += 1;
        report.max_rotation_change_deg.push(max_rot);
        report.max_shift.push(max_shift);
    }
    Ok((poses, report))
}

#[cfg(test)]
mod tests {
    #[test]
    fn turntable_order_walks_outward_from_the_anchor() {
        assert_eq!(super::turntable_order(6, 0), vec![1, 5, 2, 4, 3]);
        assert_eq!(super::turntable_order(5, 2), vec![3, 1, 4, 0]);
    }
}
