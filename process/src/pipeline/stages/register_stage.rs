//! Registration: the views' poses refined from the turntable's (ch. 2.2), or a laser scan's lasers
//! aligned with each other.

use super::StageError;
use super::merge_stage::{fill_normals, merge_at};
use crate::merge::CropParams;
use crate::merge::views::{ViewData, ViewGrid};
use crate::pipeline::records::{Fingerprint, StageCode, rig_part};
use crate::register::lasers::{LaserAlignParams, LasersReport};
use crate::register::multiview::{Misfit, MultiViewReport};
use crate::register::register_scan::{Refused, RegisterParams, Tolerance, ViewPose, register_grids};
use rig::math::{Isometry3, Point3, Real};
use rig::{PointCloud, RangeGrid, TurntableAxis};
use serde::{Deserialize, Serialize};
use serde_json::json;

/// What registration returns: the cloud, every view's pose and the report.
pub type Registered = (PointCloud, Vec<ViewPose>, RegisterReport);

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
    /// Views that fit the others far worse than they fit each other after registration (a turntable
    /// step that slipped or did not happen, an object that moved), by view number.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub misfits: Vec<Misfit>,
    /// A laser scan's: how its lasers were aligned with each other (its views are lines, not refined
    /// one by one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lasers: Option<LasersReport>,
    /// A scan of several passes: how each pass was placed in the first's frame
    /// ([`super::register_passes`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub passes: Option<Vec<PassAlignment>>,
}

/// How a pass was placed in the first pass's object frame.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct PassAlignment {
    /// The pass (from 1).
    pub pass: u32,
    /// Its views.
    pub views: usize,
    /// Its points, registered within the pass.
    pub points: usize,
    /// The motion from this pass's turntable frame into the first pass's, row-major 4 × 4.
    pub first_from_pass: [[Real; 4]; 4],
    /// Whether the alignment is trusted (see `why` otherwise).
    pub aligned: bool,
    /// Why not, in words (empty when aligned).
    pub why: String,
    /// Share of the pass's thinned cloud that lands on the passes placed before it.
    pub overlap: Real,
    /// RMS distance of those points (mm).
    pub rms_mm: Real,
    /// Descriptor matches and those agreeing with the motion.
    pub matches: usize,
    /// Matches agreeing with the motion.
    pub inliers: usize,
    /// The best other motion's overlap as a share of this one's (near 1: ambiguous).
    pub rival_share: Real,
    /// A laser scan's pass after the first: how its lasers were aligned with each other (the first
    /// pass's is the register report's own `lasers`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lasers: Option<crate::register::lasers::LasersReport>,
    /// How far the fine ICP moved the search's result (degrees, mm at the pass's centroid).
    pub refine_deg: Real,
    /// The same, in mm.
    pub refine_mm: Real,
}

impl RegisterReport {
    /// The plausibility check: with refused corrections, an error unless `force`, else one warning
    /// per refused view.
    /// A laser scan's lasers that disagree by more than the lines' noise are warnings too.
    pub fn check(&self, tolerance: &Tolerance, force: bool) -> Result<Vec<String>, StageError> {
        // A pass placed by a match that is not trusted: the merged object would be two objects.
        let mut unaligned = Vec::new();
        for a in self.passes.iter().flatten().filter(|a| !a.aligned) {
            let what = format!("pass {} could not be aligned with pass 1 by its shape: {}", a.pass, a.why);
            if !force {
                return Err(StageError::Implausible {
                    what,
                    hint: "the passes may overlap too little (let each pass show much of what the first saw), or the \
                           object look the same turned (a sphere, a cylinder); --force merges this best guess anyway"
                        .into(),
                });
            }
            unaligned.push(format!("{what}: merged at the best guess (--force)"));
        }
        // Every pass's lasers: a plane that is off shows in each pass a laser scan has.
        let lasers = self.lasers.iter().chain(self.passes.iter().flatten().filter_map(|a| a.lasers.as_ref()));
        let disagreements = unaligned.into_iter().chain(lasers.flat_map(LasersReport::disagreements));
        let mut misfits = Vec::new();
        for m in &self.misfits {
            let what = format!(
                "view {} fits the other views far worse than they fit each other after registration: {:.0} % of its \
                 points lie on them (the others' median {:.0} %), at an RMS of {:.3} mm (theirs {:.3} mm)",
                m.view,
                100.0 * m.fitness,
                100.0 * m.median_fitness,
                m.rms,
                m.median_rms
            );
            if !force {
                return Err(StageError::Implausible {
                    what,
                    hint: "the turntable may not have turned (or turned too far) for that view, or the object moved \
                           on the platter: check that the platter turns freely and the object stands fixed, and scan \
                           again; --force keeps the view"
                        .into(),
                });
            }
            misfits.push(format!("{what}: kept (--force)"));
        }
        let disagreements = misfits.into_iter().chain(disagreements);
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
/// cropped like [`super::merge`]. Returns the registered cloud and every view's pose; corrections beyond the
/// tolerance are not applied but listed in the report ([`RegisterReport::check`] decides on them).
/// A laser scan's views (lines) are registered laser against laser instead ([`register_lasers`]).
pub fn register(
    views: &[ViewGrid],
    axis: &TurntableAxis,
    crop: &CropParams,
    params: &RegisterParams,
) -> Result<Registered, StageError> {
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
        misfits: refinement.misfits().into_iter().map(|m| Misfit { view: refs[m.view].0, ..m }).collect(),
        refinement,
        lasers: None,
        passes: None,
    };
    Ok((cloud, poses, report))
}

/// Registers a laser scan: each laser's lines, placed by the turntable, form one cloud, and every
/// laser's cloud is aligned with the reference laser's ([`crate::register::lasers`]); the lines are then merged
/// again at their corrected placements, cropped like [`super::merge`]. A correction beyond the tolerance is
/// not applied but listed as refused. With lines of fewer than two lasers (a laser whose frames gave
/// nothing) there is nothing to align: the lines are merged as the turntable placed them.
pub fn register_lasers(
    views: &[ViewGrid],
    axis: &TurntableAxis,
    crop: &CropParams,
    params: &RegisterParams,
) -> Result<Registered, StageError> {
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
            ViewPose {
                view: v.view,
                laser: v.laser,
                angle_deg: v.angle_deg,
                object_from_camera: rig::math::rows_of(pose),
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
        misfits: Vec::new(),
        lasers: Some(lr),
        passes: None,
    };
    Ok((cloud, view_poses, report))
}

/// A laser's point counts in the gap between two lasers' surfaces within this many ICP distance
/// floors (`min_distance`) of the other surface.
const LASER_GAP_REACH: Real = 2.0;

/// The registered poses as `registered.poses.json` holds them.
pub fn poses_json(poses: &[ViewPose]) -> Vec<u8> {
    serde_json::to_vec_pretty(poses).expect("poses serialise")
}

/// The register stage's code version (the registered cloud and its poses).
pub const REGISTER: StageCode = StageCode { stage: "register", version: 2 };

/// What registration is made from besides the views' measurements: the crop (the working volume's),
/// the registration parameters and the turntable exactly as the rig describes it.
pub fn register_fingerprint(
    crop: &CropParams,
    params: &RegisterParams,
    turntable: Option<&TurntableAxis>,
) -> Fingerprint {
    Fingerprint::new(REGISTER, json!({"crop": crop, "register": params, "rig.turntable": rig_part(&turntable)}))
}
