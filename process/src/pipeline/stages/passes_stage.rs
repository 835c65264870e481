//! Several passes of one object (issue 40): the object scanned, turned over by hand (on its side,
//! upside down) and scanned again. Within a pass the turntable places the views and registration
//! refines them ([`super::register`]); between passes nothing is known — the operator put the object
//! down anew — so each further pass is aligned by its shape to the passes placed before it
//! ([`crate::register::global`]: local descriptors, a robust search, then ICP), refined by ICP on the
//! full clouds, and merged into the first pass's object frame. A pass whose alignment is not trusted
//! (ambiguous, too little overlap) is a result that cannot be right: [`RegisterReport::check`]
//! refuses it unless forced.

use super::StageError;
use super::merge_stage::merge;
use super::register_stage::{PassAlignment, RegisterReport, Registered, register};
use crate::merge::CropParams;
use crate::merge::views::{ViewGrid, turntable_pose};
use crate::register::global::{GlobalAlignment, GlobalParams, align_global};
use crate::register::icp::{IcpParams, IcpTarget, icp};
use crate::register::register_scan::{RegisterParams, ViewPose};
use rig::math::{Isometry3, rows_of};
use rig::{PointCloud, TurntableAxis};

/// One pass on its own: registered from its turntable poses where it can be (two views, or two
/// lasers' lines), else merged as the turntable placed it.
fn one_pass(
    views: &[ViewGrid],
    axis: &TurntableAxis,
    crop: &CropParams,
    params: &RegisterParams,
) -> Result<(PointCloud, Vec<ViewPose>, Option<RegisterReport>), StageError> {
    let registrable = match views.iter().filter_map(|v| v.laser).max() {
        Some(k) => k >= 1,
        None => views.len() >= 2,
    };
    if registrable {
        let (cloud, poses, report) = register(views, axis, crop, params)?;
        return Ok((cloud, poses, Some(report)));
    }
    let (cloud, _) = merge(views, Some(axis), crop);
    let poses = views
        .iter()
        .map(|v| ViewPose {
            view: v.view,
            laser: v.laser,
            angle_deg: v.angle_deg,
            object_from_camera: rows_of(&turntable_pose(Some(axis), v.angle_deg)),
            rotation_change_deg: 0.0,
            shift_mm: 0.0,
            refused: false,
        })
        .collect();
    Ok((cloud, poses, None))
}

/// Registers a scan of several passes: each pass within itself, then every further pass aligned by
/// its shape to the trusted passes placed before it and refined by ICP, all in the first pass's
/// object frame. `pass_of(view)`
/// gives a view's pass (from 1). Returns the cloud, every view's pose (in that frame) and the report,
/// whose `passes` says how each pass was placed.
pub fn register_passes(
    views: &[ViewGrid],
    pass_of: &dyn Fn(usize) -> u32,
    axis: &TurntableAxis,
    crop: &CropParams,
    params: &RegisterParams,
) -> Result<Registered, StageError> {
    // Each pass's registration checks the parameters too; a scan refused is refused before any pass.
    params.validate()?;
    crop.validate()?;
    let mut passes: Vec<u32> = views.iter().map(|v| pass_of(v.view)).collect();
    passes.sort_unstable();
    passes.dedup();
    let mut report = RegisterReport::default();
    let mut alignments = Vec::new();
    let mut all = PointCloud::default();
    let mut all_poses = Vec::new();
    // The passes placed so far and trusted (what the next pass is searched against), with their
    // ICP target: a pass that overlaps only the second still finds its place.
    let mut placed: Option<(Vec<rig::math::Point3>, Vec<rig::math::Vector3>, IcpTarget)> = None;
    for &p in &passes {
        let mine: Vec<ViewGrid> = views.iter().filter(|v| pass_of(v.view) == p).copied().collect();
        let (mut cloud, mut poses, r) = one_pass(&mine, axis, crop, params)?;
        let reference_pass = placed.is_none();
        let mut pass_lasers = None;
        if let Some(r) = r {
            report.max_rotation_change_deg = report.max_rotation_change_deg.max(r.max_rotation_change_deg);
            report.max_shift_mm = report.max_shift_mm.max(r.max_shift_mm);
            report.sensor_normals += r.sensor_normals;
            report.refused.extend(r.refused);
            report.misfits.extend(r.misfits);
            if reference_pass {
                report.refinement = r.refinement;
                report.lasers = r.lasers;
            } else {
                pass_lasers = r.lasers;
            }
        }
        // Views, not lines: a laser scan has one entry per view and laser.
        let mut numbers: Vec<usize> = mine.iter().map(|v| v.view).collect();
        numbers.dedup();
        let mut a = PassAlignment {
            pass: p,
            views: numbers.len(),
            points: cloud.len(),
            lasers: pass_lasers,
            ..Default::default()
        };
        let motion = match &placed {
            None => {
                a.aligned = true;
                a.overlap = 1.0;
                Isometry3::identity()
            }
            Some((reference, _, target)) => {
                let seed = GlobalParams::default().seed;
                let search = GlobalParams::for_clouds(&cloud.positions, reference, None, seed)?;
                let g = align_global(&cloud.positions, reference, &search)?;
                let fine = refine(&cloud, target, &g);
                let centre =
                    rig::Aabb::of(&cloud.positions).map_or(rig::Point3::origin(), |b| nalgebra::center(&b.min, &b.max));
                a.refine_deg = (g.pose.rotation.inverse() * fine.rotation).angle().to_degrees();
                a.refine_mm = (fine * centre - g.pose * centre).norm();
                let GlobalAlignment { aligned, why, matches, inliers, overlap, rms, rival_share, .. } = g;
                (a.aligned, a.why, a.matches, a.inliers, a.overlap, a.rms_mm, a.rival_share) =
                    (aligned, why, matches, inliers, overlap, rms, rival_share);
                fine
            }
        };
        a.first_from_pass = rows_of(&motion);
        alignments.push(a);
        for q in &mut cloud.positions {
            *q = motion * *q;
        }
        for n in cloud.normals.iter_mut().flatten() {
            *n = motion.rotation * *n;
        }
        for pose in &mut poses {
            // A pose this stage wrote from an isometry a moment ago: always one.
            let placed = rig::math::isometry_of(&pose.object_from_camera).unwrap_or_else(Isometry3::identity);
            pose.object_from_camera = rows_of(&(motion * placed));
        }
        all_poses.extend(poses);
        // A trusted pass joins the reference (an untrusted one, merged only because forced, must not
        // mislead the next search). Without normals there is no point-to-plane target: the search's
        // motion then stands alone.
        if alignments.last().is_some_and(|a: &PassAlignment| a.aligned) {
            let (mut points, mut normals) = placed.take().map(|(p, n, _)| (p, n)).unwrap_or_default();
            points.extend_from_slice(&cloud.positions);
            match &cloud.normals {
                Some(n) if normals.len() + n.len() == points.len() => normals.extend_from_slice(n),
                _ => normals.clear(),
            }
            let target = match normals.len() == points.len() {
                true => IcpTarget::new(points.clone(), normals.clone(), None),
                false => IcpTarget::new(Vec::new(), Vec::new(), None),
            };
            placed = Some((points, normals, target));
        }
        append(&mut all, cloud);
    }
    report.views = views.len();
    report.points = all.len();
    report.passes = Some(alignments);
    Ok((all, all_poses, report))
}

/// The search's motion refined by point-to-plane ICP on the full clouds (the search matched them
/// thinned): from within a few spacings down to the scan's own noise. The search's motion where
/// ICP cannot run (no normals).
fn refine(cloud: &PointCloud, target: &IcpTarget, g: &GlobalAlignment) -> Isometry3 {
    let Some(normals) = cloud.normals.as_ref().filter(|_| g.aligned && !target.is_empty()) else { return g.pose };
    let params = IcpParams { start_distance: 5.0, min_distance: 0.5, ..IcpParams::default() };
    icp(&cloud.positions, normals, target, &g.pose, &params).map_or(g.pose, |r| r.0)
}

/// `b` appended to `a`, keeping an attribute only where both have it.
fn append(a: &mut PointCloud, b: PointCloud) {
    let first = a.positions.is_empty();
    fn join<T>(x: &mut Option<Vec<T>>, y: Option<Vec<T>>, first: bool) {
        match (x.as_mut(), y) {
            (Some(x), Some(y)) => x.extend(y),
            (None, Some(y)) if first => *x = Some(y),
            _ => *x = None,
        }
    }
    a.positions.extend(b.positions);
    join(&mut a.normals, b.normals, first);
    join(&mut a.colors, b.colors, first);
    join(&mut a.confidence, b.confidence, first);
    join(&mut a.view_id, b.view_id, first);
}
