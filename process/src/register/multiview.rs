//! Multi-view registration in two stages. First, views are placed one at a time, outward from a fixed
//! anchor, each against the union of the views already placed — so no view is ever pulled toward others
//! that are still at their rough starting poses (a group of such views can agree with each other and lock
//! into a wrong pose together). Then every view is refined in turn against the union of the others near
//! it, for a few rounds (fewer once a round moves nothing) — closing the 360° loop so that error does not accumulate along a chain.

use crate::register::icp::{IcpError, IcpParams, IcpReport, IcpTarget, PosePrior, icp_near};
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
    /// Only views whose starting orientation is within this many degrees of a view's make its target
    /// (180: every view). A turntable view overlaps its neighbours, not the far side, and a target of
    /// every other view makes the work grow with the square of the views; views from anywhere (the
    /// Stanford bunny's tops and chin) need them all.
    pub neighbour_deg: Real,
    /// Most points in one target union (the per-view share shrinks when more views are near).
    pub max_target_points: usize,
    /// Rounds stop once a round moves no view by more than this rotation (degrees) and this
    /// fraction of ICP's `min_distance`: the poses already agree.
    pub settled_deg: Real,
    /// See `settled_deg`.
    pub settled_shift: Real,
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
            neighbour_deg: 180.0,
            max_target_points: 60_000,
            settled_deg: 0.01,
            settled_shift: 0.01,
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

/// A view whose fit after registration is far from the others': under [`MISFIT_SHARE`] of their
/// median share of points on the rest, and over [`MISFIT_RMS`] times their median RMS.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
pub struct Misfit {
    /// The view (an index into [`MultiViewReport::views`]; the scan's view number in a register
    /// report).
    pub view: usize,
    /// Its share of points with a correspondence on the other views.
    pub fitness: Real,
    /// Their RMS point-to-plane distance.
    pub rms: Real,
    /// The other views' median share.
    pub median_fitness: Real,
    /// Their median RMS.
    pub median_rms: Real,
}

/// A misfit's share of points on the others is under this share of their median: a view that turned
/// with the rest lands nearly as much of itself on them as they do (0.89–0.94 on a simulated
/// 12-view scan), and one captured where the turntable did not turn lands about half (0.51).
pub const MISFIT_SHARE: Real = 0.7;

/// … and its RMS over this many times their median (the same scan: 0.02–0.07 mm, the stalled view
/// 0.25 mm): both, so a view that sees a thin side (fewer points on the others) or a rough part
/// (a higher RMS) is not one.
pub const MISFIT_RMS: Real = 3.0;

impl MultiViewReport {
    /// The views that fit the others far worse than they fit each other (see [`Misfit`]): the
    /// turntable slipped or stalled for them, or the object moved. Needs four views registered.
    pub fn misfits(&self) -> Vec<Misfit> {
        // The anchor's report is empty: it was not registered.
        let registered: Vec<(usize, &IcpReport)> =
            self.views.iter().enumerate().filter(|(_, r)| r.iterations > 0).collect();
        if registered.len() < 4 {
            return Vec::new();
        }
        // Four or more registered: three or more others, never empty.
        let median = |mut v: Vec<Real>| crate::median::median(&mut v).unwrap_or(0.0);
        registered
            .iter()
            .filter_map(|&(view, r)| {
                let others = || registered.iter().filter(|(v, _)| *v != view).map(|(_, o)| *o);
                let median_fitness = median(others().map(|o| o.fitness).collect());
                let median_rms = median(others().map(|o| o.inlier_rmse).collect());
                (r.fitness < MISFIT_SHARE * median_fitness && r.inlier_rmse > MISFIT_RMS * median_rms)
                    .then_some(Misfit { view, fitness: r.fitness, rms: r.inlier_rmse, median_fitness, median_rms })
            })
            .collect()
    }
}

/// The union of the views `include` says yes to, at their poses: `per_view` points each, fewer when
/// that would exceed `max_points` in all.
fn union_target(
    views: &[View],
    poses: &[Isometry3],
    include: impl Fn(usize) -> bool,
    per_view: usize,
    max_points: usize,
) -> IcpTarget {
    let (mut pts, mut nrm, mut bnd) = (Vec::new(), Vec::new(), Vec::new());
    let included = (0..views.len()).filter(|&v| include(v)).count().max(1);
    let per_view = per_view.min(max_points / included).max(1);
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
    // Views that overlap: starting orientations within `neighbour_deg` of each other.
    // A view with none near (two views half a turn apart) takes every other as before.
    let near = |u: usize, v: usize| {
        let close = |w: usize| (initial[w].rotation.inverse() * initial[v].rotation).angle().to_degrees();
        close(u) <= params.neighbour_deg || (0..views.len()).all(|w| w == v || close(w) > params.neighbour_deg)
    };
    let (per_view, max_points) = (params.target_points_per_view, params.max_target_points);
    for &v in order.unwrap_or(&default_order) {
        let target = union_target(views, &poses, |u| placed[u] && near(u, v), per_view, max_points);
        let prior = params.prior.map(|p| (&initial[v], p));
        let icp = adapted(&params.icp, &views[v], &target, &poses[v]);
        poses[v] = icp_near(&views[v].points, &views[v].normals, &target, &poses[v], prior, &icp)?.0;
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
            let target = union_target(views, &poses, |u| u != v && near(u, v), per_view, max_points);
            let prior = params.prior.map(|p| (&initial[v], p));
            let icp = adapted(&params.icp, &views[v], &target, &poses[v]);
            let (pose, r) = icp_near(&views[v].points, &views[v].normals, &target, &poses[v], prior, &icp)?;
            max_rot = max_rot.max((pose.rotation.inverse() * poses[v].rotation).angle().to_degrees());
            max_shift = max_shift.max((pose * centroids[v] - poses[v] * centroids[v]).norm());
            poses[v] = pose;
            report.views[v] = r;
        }
        report.rounds += 1;
        report.max_rotation_change_deg.push(max_rot);
        report.max_shift.push(max_shift);
        if max_rot < params.settled_deg && max_shift < params.settled_shift * params.icp.min_distance {
            break;
        }
    }
    Ok((poses, report))
}

/// ICP's settings for one view against a target: the first correspondence distance fitted to how far
/// the view lies from the target now (four times the median distance of a sample of its points to
/// their nearest target points, within ICP's own bounds). Views that already agree start at the
/// floor and converge in a few iterations instead of shrinking down from the largest distance.
fn adapted(icp: &IcpParams, view: &View, target: &IcpTarget, pose: &Isometry3) -> IcpParams {
    if target.is_empty() || view.points.is_empty() {
        return *icp;
    }
    let stride = view.points.len().div_ceil(400).max(1);
    let mut d: Vec<Real> = view.points.iter().step_by(stride).map(|p| target.nearest(&(pose * p)).1.sqrt()).collect();
    d.sort_by(Real::total_cmp);
    let start = (4.0 * d[d.len() / 2]).clamp(icp.min_distance, icp.start_distance.max(icp.min_distance));
    IcpParams { start_distance: start, ..*icp }
}

#[cfg(test)]
mod tests {
    #[test]
    fn turntable_order_walks_outward_from_the_anchor() {
        assert_eq!(super::turntable_order(6, 0), vec![1, 5, 2, 4, 3]);
        assert_eq!(super::turntable_order(5, 2), vec![3, 1, 4, 0]);
    }
}
