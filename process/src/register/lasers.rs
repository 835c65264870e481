//! Registering a laser scan's lasers with each other (the ICP of thesis ch. 2.2, on whole lasers).
//!
//! A rig with two lasers lights every meridian of the object twice, once with each, from views some
//! tens of degrees apart. Each laser's lines, placed by the turntable, form a cloud of the whole object;
//! with calibrated planes the clouds are one surface. A plane that is off — the complaint Horus users
//! file most ("two objects, one inside the other") — displaces every point of that laser along its
//! camera ray; after the turn that is a rotation about the axis, a vertical shift and a radial offset
//! of that laser's whole cloud. One line alone cannot be registered (a curve fixes a pose in only a
//! few directions), but one laser's cloud against another's can: point-to-plane ICP of each laser's
//! cloud onto the reference laser's, held near the identity by the turntable prior, removes the rigid
//! part. What is left (a radial offset no rigid motion undoes) shows as a gap that stays after the
//! alignment; a gap beyond the lines' own noise, before or after, is what [`LaserAlignment::disagrees`]
//! reports.

use crate::register::icp::{IcpError, IcpParams, IcpReport, IcpTarget, PosePrior, icp_near};
use rig::PointCloud;
use rig::math::{Isometry3, Point3, Real, Vector3};
use serde::{Deserialize, Serialize};

/// A gap between two lasers' surfaces beyond this many times the lines' noise is a disagreement:
/// two noisy samples of one surface lie about one noise apart (median of the point-to-plane distance
/// between them, the interpolation across lines adding a little).
pub const DISAGREEMENT_NOISE_FACTOR: Real = 3.0;

/// How one laser was aligned with the reference laser.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct LaserAlignment {
    /// The laser (its index in the rig).
    pub laser: usize,
    /// Its points.
    pub points: usize,
    /// The correction applied to its points (object frame), row-major 4 × 4.
    pub correction: [[Real; 4]; 4],
    /// The correction's rotation (degrees).
    pub rotation_deg: Real,
    /// How far the correction moves the laser's centroid (mm).
    pub shift_mm: Real,
    /// Median distance of its points to the reference laser's surface before the correction (mm), over
    /// the points with a reference point within reach.
    pub gap_before_mm: Real,
    /// The same after the correction (a correction that does not lessen the gap is not applied: then
    /// the correction is the identity and this is `gap_before_mm`).
    pub gap_after_mm: Real,
    /// Share of its points with a reference point within reach (after the correction).
    pub overlap: Real,
    /// The reach (mm): correspondences and the gaps take reference points this near.
    #[serde(default)]
    pub reach_mm: Real,
    /// The registration's last iteration.
    pub icp: IcpReport,
}

impl LaserAlignment {
    /// Whether this laser and the reference disagree by more than `noise_mm` allows, before or after
    /// the correction.
    pub fn disagrees(&self, noise_mm: Real) -> bool {
        let limit = DISAGREEMENT_NOISE_FACTOR * noise_mm;
        !(self.gap_before_mm <= limit && self.gap_after_mm <= limit)
    }
}

/// What aligning the lasers did.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct LasersReport {
    /// The laser the others were aligned with (the first with points).
    pub reference: usize,
    /// The lines' noise (mm): the robust standard deviation of a point about its two neighbours on its
    /// own line ([`line_noise`]).
    pub noise_mm: Real,
    /// Every other laser's alignment.
    pub lasers: Vec<LaserAlignment>,
    /// Lasers that could not be aligned (too little overlap), and why: they keep their placement.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub unaligned: Vec<String>,
}

impl LasersReport {
    /// One warning per laser that could not be aligned, and per laser whose cloud and the reference
    /// laser's lie farther apart than the lines' noise allows: a laser plane in the rig that is off.
    pub fn disagreements(&self) -> Vec<String> {
        let unaligned = self.unaligned.iter().cloned();
        unaligned
            .chain(self.lasers.iter().filter(|a| self.noise_mm > 0.0 && a.disagrees(self.noise_mm)).map(|a| {
                format!(
                    "laser {} and laser {} disagree: their surfaces lie {:.3} mm apart ({:.3} mm after a {:.2}° and \
                     {:.2} mm correction of laser {}) where the lines' noise is {:.3} mm: a laser plane in rig.toml \
                     is off; calibrate the lasers again (`scanrig calibrate laser`)",
                    a.laser,
                    self.reference,
                    a.gap_before_mm,
                    a.gap_after_mm,
                    a.rotation_deg,
                    a.shift_mm,
                    a.laser,
                    self.noise_mm
                )
            }))
            .collect()
    }
}

/// Settings: the ICP and the prior on how far a laser's cloud may be off (the turntable prior of
/// registration), and how far a point may lie from the other laser's surface to count in a gap.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaserAlignParams {
    /// The registration.
    pub icp: IcpParams,
    /// Held around the turntable placement (the identity correction).
    pub prior: Option<PosePrior>,
    /// Points farther than this from the other surface (mm) are not overlap and not in the gap; it
    /// grows to twice the median distance from a laser's points to the reference's nearest.
    pub reach_mm: Real,
}

/// The noise of laser lines (mm): over every run of three consecutive rows on one line, the distance
/// of the middle point from the midpoint of the other two, turned into a standard deviation — for
/// noise σ along each point's ray that distance is 1.22 σ, its median 0.826 σ. Lines are smooth over
/// three rows, so what remains is the line-centre noise as it shows in space. `lines`: each line's
/// points with their image rows, in row order. `None` with no such run.
pub fn line_noise<'a>(lines: impl IntoIterator<Item = (&'a [Point3], &'a [[f32; 2]])>) -> Option<Real> {
    let mut d: Vec<Real> = Vec::new();
    for (points, pixels) in lines {
        for i in 1..points.len().saturating_sub(1) {
            let rows = [pixels[i - 1][1], pixels[i][1], pixels[i + 1][1]];
            if rows[1] - rows[0] == 1.0 && rows[2] - rows[1] == 1.0 {
                d.push((points[i] - Point3::from((points[i - 1].coords + points[i + 1].coords) / 2.0)).norm());
            }
        }
    }
    if d.is_empty() {
        return None;
    }
    let mid = d.len() / 2;
    Some(*d.select_nth_unstable_by(mid, Real::total_cmp).1 / 0.826)
}

/// The median distance from `points` (moved by `pose`) to the plane of their nearest `target` point
/// within `reach`, and the share that had one.
fn gap(points: &[Point3], pose: &Isometry3, target: &IcpTarget, reach: Real) -> (Real, Real) {
    use rayon::prelude::*;
    let mut d: Vec<Real> = points
        .par_iter()
        .filter_map(|p| {
            let q = pose * p;
            let (j, d2) = target.nearest(&q);
            (d2 <= reach * reach).then(|| (q - target.point(j)).dot(&target.normal(j)).abs())
        })
        .collect();
    let overlap = d.len() as Real / points.len().max(1) as Real;
    if d.is_empty() {
        return (Real::INFINITY, 0.0);
    }
    let mid = d.len() / 2;
    (*d.select_nth_unstable_by(mid, Real::total_cmp).1, overlap)
}

/// The median distance from (at most 5,000 evenly strided of) `points` to their nearest `target` point.
fn median_nearest(points: &[Point3], target: &IcpTarget) -> Real {
    let stride = points.len().div_ceil(5000).max(1);
    let mut d: Vec<Real> = points.iter().step_by(stride).map(|p| target.nearest(p).1.sqrt()).collect();
    if d.is_empty() {
        return 0.0;
    }
    let mid = d.len() / 2;
    *d.select_nth_unstable_by(mid, Real::total_cmp).1
}

/// Aligns every laser's cloud (object frame, unit normals, as the turntable placed it) with the
/// first laser with points; `noise_mm` is the lines' noise ([`line_noise`]).
/// Returns each laser's correction (the identity for the reference) and the report. A laser with
/// no points keeps the identity and is not reported; one ICP cannot align keeps it and is listed in
/// [`LasersReport::unaligned`].
pub fn align_lasers(
    clouds: &[PointCloud],
    noise_mm: Real,
    params: &LaserAlignParams,
) -> Result<(Vec<Isometry3>, LasersReport), IcpError> {
    let reference = (0..clouds.len()).find(|&k| !clouds[k].is_empty()).unwrap_or(0);
    let mut corrections = vec![Isometry3::identity(); clouds.len()];
    let mut report = LasersReport { reference, noise_mm, lasers: Vec::new(), unaligned: Vec::new() };
    let normals_of = |c: &PointCloud| c.normals.clone().unwrap_or_else(|| vec![Vector3::zeros(); c.len()]);
    let Some(r) = clouds.get(reference).filter(|c| !c.is_empty()) else { return Ok((corrections, report)) };
    let target = IcpTarget::new(r.positions.clone(), normals_of(r), None);
    for (k, cloud) in clouds.iter().enumerate() {
        if k == reference || cloud.is_empty() {
            continue;
        }
        let identity = Isometry3::identity();
        // Lines of two lasers need not fall on the same meridians: a point's nearest point on the
        // other laser's surface may lie half a line spacing away, its plane still the right one. The
        // correspondences reach at least twice the typical such distance.
        // At most the largest misalignment the ICP starts from: lasers that do not overlap at all
        // must not stretch the reach until they seem to.
        let reach = params.reach_mm.max(2.0 * median_nearest(&cloud.positions, &target)).min(params.icp.start_distance);
        let icp_params = IcpParams {
            min_distance: params.icp.min_distance.max(reach),
            start_distance: params.icp.start_distance.max(2.0 * reach),
            ..params.icp
        };
        let prior = params.prior.map(|p| (&identity, p));
        // Lasers that barely overlap (a laser whose frames mostly failed, an object one laser hardly
        // reaches) give ICP too little to hold on to: that laser stays where the turntable put it,
        // and the report says so rather than failing the scan.
        let (pose, icp) = match icp_near(&cloud.positions, &normals_of(cloud), &target, &identity, prior, &icp_params) {
            Ok(aligned) => aligned,
            Err(e) => {
                report.unaligned.push(format!(
                    "laser {k} could not be aligned with laser {reference} ({e}): its lines keep their turntable \
                     placement"
                ));
                continue;
            }
        };
        let centroid =
            Point3::from(cloud.positions.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / cloud.len() as Real);
        let (gap_before_mm, overlap_before) = gap(&cloud.positions, &identity, &target, reach);
        let (gap_after, overlap_after) = gap(&cloud.positions, &pose, &target, reach);
        // A correction that does not bring the surfaces closer (a radial offset, which no rigid
        // motion undoes) is not applied.
        let (pose, gap_after_mm, overlap) = if gap_after < gap_before_mm {
            (pose, gap_after, overlap_after)
        } else {
            (identity, gap_before_mm, overlap_before)
        };
        report.lasers.push(LaserAlignment {
            laser: k,
            points: cloud.len(),
            correction: rig::math::rows_of(&pose),
            rotation_deg: pose.rotation.angle().to_degrees(),
            shift_mm: (pose * centroid - centroid).norm(),
            gap_before_mm,
            gap_after_mm,
            overlap,
            reach_mm: reach,
            icp,
        });
        corrections[k] = pose;
    }
    Ok((corrections, report))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::math::{Translation3, UnitQuaternion};
    use std::f64::consts::TAU;

    /// A fluted, waisted column r(φ, z) = 30 + 3 cos 5φ + 4 sin(z / 10), 60 mm tall, sampled as a
    /// laser samples it: `count` meridians starting at `phase` (radians), 300 rows each; radius grown
    /// by `grow` (a plane off).
    fn lines(count: usize, phase: Real, grow: Real) -> PointCloud {
        let mut cloud = PointCloud { normals: Some(Vec::new()), ..Default::default() };
        for l in 0..count {
            let a = phase + TAU * l as Real / count as Real;
            for k in 0..300 {
                let z = 5.0 + 0.2 * k as Real;
                let r = 30.0 + 3.0 * (5.0 * a).cos() + 4.0 * (z / 10.0).sin() + grow;
                let (r_a, r_z) = (-15.0 * (5.0 * a).sin(), 0.4 * (z / 10.0).cos());
                // The normal: ∂S/∂a × ∂S/∂z, outward.
                let s_a = Vector3::new(r_a * a.cos() - r * a.sin(), r_a * a.sin() + r * a.cos(), 0.0);
                let s_z = Vector3::new(r_z * a.cos(), r_z * a.sin(), 1.0);
                cloud.positions.push(Point3::new(r * a.cos(), r * a.sin(), z));
                cloud.normals.as_mut().unwrap().push(s_a.cross(&s_z).normalize());
            }
        }
        cloud
    }

    fn params() -> LaserAlignParams {
        LaserAlignParams {
            icp: IcpParams { min_distance: 0.5, ..Default::default() },
            prior: Some(PosePrior { rotation_deg: 2.0, shift: 5.0 }),
            reach_mm: 2.0,
        }
    }

    #[test]
    fn a_laser_turned_and_lifted_is_brought_back_onto_the_other() {
        let reference = lines(72, 0.0, 0.0);
        let off = Isometry3::from_parts(
            Translation3::new(0.0, 0.0, 0.6),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 1.0f64.to_radians()),
        );
        let mut moved = lines(36, 0.05, 0.0);
        moved.positions.iter_mut().for_each(|p| *p = off * *p);
        moved.normals.as_mut().unwrap().iter_mut().for_each(|n| *n = off.rotation * *n);
        let (c, report) = align_lasers(&[reference, moved], 0.01, &params()).unwrap();
        assert_eq!(report.reference, 0, "the first laser is the reference");
        let a = report.lasers[0];
        let residual = c[1] * off;
        assert!(residual.rotation.angle().to_degrees() < 0.05, "{:.3}°", residual.rotation.angle().to_degrees());
        assert!(residual.translation.vector.norm() < 0.05, "{:?}", residual.translation.vector);
        assert!((a.rotation_deg - 1.0).abs() < 0.05, "{a:?}");
        assert!(a.gap_before_mm > 0.1 && a.gap_after_mm < 0.05, "{a:?}");
        assert!(a.disagrees(0.01), "a laser 0.6 mm off disagrees with a 0.01 mm noise");
        assert!(a.overlap > 0.9, "{a:?}");
    }

    #[test]
    fn agreeing_lasers_get_no_correction_and_a_radial_offset_stays_and_is_said() {
        // The lines fall between the reference's (5° apart): interpolating across them adds about
        // 0.03 mm to the gap, so these noiseless lines are judged with a noise of 0.02 mm.
        let (reference, other) = (lines(72, 0.0, 0.0), lines(36, 0.05, 0.0));
        let (c, report) = align_lasers(&[reference.clone(), other], 0.02, &params()).unwrap();
        assert!(c[1].rotation.angle().to_degrees() < 0.05 && c[1].translation.vector.norm() < 0.02, "{:?}", c[1]);
        assert!(!report.lasers[0].disagrees(0.02), "{:?}", report.lasers[0]);
        // A plane 0.5 mm off moves that laser's points outward all round: no rigid motion undoes it,
        // and a correction that does not help is not applied.
        let (c, report) = align_lasers(&[reference, lines(36, 0.05, 0.5)], 0.02, &params()).unwrap();
        let a = report.lasers[0];
        assert!(a.gap_after_mm > 0.3 && a.gap_after_mm <= a.gap_before_mm, "{a:?}");
        assert!(a.disagrees(0.02));
        assert!(c[1].rotation.angle() < 0.01 || a.gap_after_mm < a.gap_before_mm, "{:?}", c[1]);
    }

    #[test]
    fn a_laser_that_overlaps_nothing_keeps_its_placement_and_is_said() {
        let mut far = lines(36, 0.05, 0.0);
        far.positions.iter_mut().for_each(|p| p.z += 500.0);
        let (c, report) = align_lasers(&[lines(72, 0.0, 0.0), far], 0.02, &params()).unwrap();
        assert_eq!(c[1], Isometry3::identity());
        assert!(report.lasers.is_empty() && report.unaligned.len() == 1, "{report:?}");
        assert!(report.disagreements()[0].contains("laser 1 could not be aligned"), "{:?}", report.disagreements());
    }

    #[test]
    fn line_noise_is_the_standard_deviation_of_points_about_their_line() {
        let mut rng = fixtures::Rng::new(7);
        let (points, pixels): (Vec<Point3>, Vec<[f32; 2]>) =
            (0..20_000).map(|k| (Point3::new(0.3 * k as Real, 0.0, 0.1 * rng.gaussian()), [0.0, k as f32])).unzip();
        let noise = line_noise([(&points[..], &pixels[..])]).unwrap();
        assert!((noise - 0.1).abs() < 0.01, "{noise}");
        // A gap in the rows breaks the run: rows 0, 2, 4 give nothing.
        let sparse: Vec<[f32; 2]> = (0..3).map(|k| [0.0, 2.0 * k as f32]).collect();
        assert_eq!(line_noise([(&points[..3], &sparse[..])]), None);
    }
}
