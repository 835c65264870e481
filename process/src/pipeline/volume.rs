//! The working volume a scan's merged points must lie in: the platter's cylinder (the rig's radius,
//! or `--crop-radius`) up to the object's top as the laser lines show it
//! ([`crate::merge::object_top`]). Every point outside is counted per view and why, reported in the
//! merge's report (`merge.volume` in report.json) and named in a warning: points are never dropped
//! in silence, and a ring of stray light over the object cannot reach the mesh as a lid.

use crate::merge::CropParams;
use crate::merge::object_top::{ObjectTop, TopParams, object_top};
use crate::merge::views::{ViewData, ViewGrid, turntable_pose};
use rig::TurntableAxis;
use rig::math::{Point3, Real};
use serde::{Deserialize, Serialize};

/// One view's (one laser line's) points outside the volume.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ViewVolume {
    /// The view.
    pub view: usize,
    /// The laser, for a laser scan.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub laser: Option<usize>,
    /// Its points before the crop.
    pub points: usize,
    /// Below the crop's minimum height: the platter itself (expected, not warned of).
    pub below_platter: usize,
    /// Farther from the axis than the platter radius.
    pub outside_radius: usize,
    /// Above the object's top (or `--crop-max-height`).
    pub above_top: usize,
}

/// The volume applied and what it removed.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct VolumeReport {
    /// The radius kept (mm); `None`: no radius known, nothing cropped by it.
    pub radius_mm: Option<Real>,
    /// The height cap applied (mm above the platter): the object's top plus
    /// [`TopParams::margin_mm`], or `--crop-max-height` if lower; `None`: none.
    pub max_height_mm: Option<Real>,
    /// The object's top as the lines show it (laser scans with a turntable).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub top: Option<ObjectTop>,
    /// Points removed beyond the radius, all views.
    pub outside_radius: usize,
    /// Points removed above the cap, all views.
    pub above_top: usize,
    /// Per view (and laser), in view order.
    pub views: Vec<ViewVolume>,
    /// How far apart a laser scan's lines lie around the axis (laser scans with a turntable).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spacing: Option<LineSpacing>,
}

/// How far apart a laser scan's lines lie around the turntable axis. Each line is one meridian of the
/// object; between neighbouring lines the surface is not measured but made up by the reconstruction,
/// which at a fine depth follows each line and sags between them: ribs. The largest gap, as an arc at
/// the object's median radius, held against the mesh's cell, says when that happens.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LineSpacing {
    /// Lines with points in the volume.
    pub lines: usize,
    /// The largest angle between neighbouring lines around the axis (degrees).
    pub largest_gap_deg: Real,
    /// The median distance of the lines' points from the axis (mm).
    pub radius_mm: Real,
    /// That gap as an arc at that radius (mm).
    pub largest_gap_mm: Real,
}

/// A mesh cell this many times smaller than the widest gap between lines resolves ribs along them.
pub const MAX_GAP_CELLS: Real = 4.0;

impl LineSpacing {
    /// The lines of `placed` (each a line's points in the object frame, inside the volume): each at
    /// the mean direction of its points about the axis. `None` for fewer than two lines.
    pub fn of(placed: &[Vec<Point3>]) -> Option<LineSpacing> {
        let median = |mut v: Vec<Real>| -> Option<Real> {
            if v.is_empty() {
                return None;
            }
            let mid = v.len() / 2;
            Some(*v.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1)
        };
        // A line's azimuth: its points' directions averaged as unit vectors (a line on the −x side
        // straddles ±180°, where a median of angles would fail).
        let mut azimuths: Vec<Real> = placed
            .iter()
            .filter_map(|pts| {
                let (sx, sy) = pts.iter().fold((0.0, 0.0), |(sx, sy), p| {
                    let r = p.x.hypot(p.y);
                    if r > 0.0 { (sx + p.x / r, sy + p.y / r) } else { (sx, sy) }
                });
                (sx.hypot(sy) > 0.0).then(|| sy.atan2(sx).to_degrees())
            })
            .collect();
        if azimuths.len() < 2 {
            return None;
        }
        azimuths.sort_by(|a, b| a.total_cmp(b));
        let wrap = 360.0 - (azimuths[azimuths.len() - 1] - azimuths[0]);
        let largest = azimuths.windows(2).map(|w| w[1] - w[0]).fold(wrap, Real::max);
        let radius = median(placed.iter().flatten().map(|p| p.x.hypot(p.y)).collect())?;
        Some(LineSpacing {
            lines: azimuths.len(),
            largest_gap_deg: largest,
            radius_mm: radius,
            largest_gap_mm: radius * largest.to_radians(),
        })
    }

    /// The warning for a mesh of `cell` (mm) made from these lines at `--depth depth`, when the widest
    /// gap spans more than [`MAX_GAP_CELLS`] cells.
    pub fn warning(&self, cell: Real, depth: u32) -> Option<String> {
        let cells = self.largest_gap_mm / cell;
        (cells > MAX_GAP_CELLS).then(|| {
            format!(
                "mesh.ply: the laser lines lie up to {:.1}° apart around the axis ({:.1} mm at the object's median \
                 radius {:.0} mm), {cells:.0} times the mesh's {cell:.2} mm cell (--depth {depth}): between the lines \
                 the surface is not measured, and the mesh shows ribs along them; take more views (`scan --views`, \
                 `sim --views`) or reconstruct at a lower --depth",
                self.largest_gap_deg, self.largest_gap_mm, self.radius_mm
            )
        })
    }
}

impl VolumeReport {
    /// `base` with the height cap this volume applies.
    pub fn crop(&self, base: &CropParams) -> CropParams {
        CropParams { max_height_mm: self.max_height_mm, ..*base }
    }

    /// One warning naming what was removed and why, with the views that lost most; none when nothing
    /// outside the volume was removed.
    pub fn warnings(&self) -> Vec<String> {
        let removed = self.outside_radius + self.above_top;
        if removed == 0 {
            return Vec::new();
        }
        let total: usize = self.views.iter().map(|v| v.points).sum();
        let mut why = Vec::new();
        if self.above_top > 0 {
            let cap = self.max_height_mm.unwrap_or(Real::INFINITY);
            why.push(match self.top {
                Some(t) => format!(
                    "{} above the object's top ({:.1} mm: the highest point of a line running unbroken from the platter, \
                     view {}{}; kept up to {cap:.1} mm)",
                    self.above_top,
                    t.top_mm,
                    t.view,
                    t.laser.map_or(String::new(), |l| format!(" laser {l}"))
                ),
                None => format!("{} above --crop-max-height {cap:.1} mm", self.above_top),
            });
        }
        if self.outside_radius > 0 {
            why.push(format!(
                "{} beyond the platter radius {:.1} mm",
                self.outside_radius,
                self.radius_mm.unwrap_or(Real::INFINITY)
            ));
        }
        let mut worst: Vec<&ViewVolume> = self.views.iter().filter(|v| v.outside_radius + v.above_top > 0).collect();
        worst.sort_by_key(|v| std::cmp::Reverse(v.outside_radius + v.above_top));
        let named: Vec<String> = worst
            .iter()
            .take(4)
            .map(|v| {
                let laser = v.laser.map_or(String::new(), |l| format!(" laser {l}"));
                format!("view {}{laser}: {} of {}", v.view, v.outside_radius + v.above_top, v.points)
            })
            .collect();
        vec![format!(
            "merge: {removed} of {total} points lie outside the working volume and were removed: {}; stray light \
             (a second line, a reflection) or a rig whose platter or laser planes are off; most in {}{} (every view in \
             report.json, merge.volume)",
            why.join(", "),
            named.join(", "),
            if worst.len() > 4 { ", …" } else { "" }
        )]
    }
}

/// The working volume of `views` placed by `turntable` within `crop`: for a laser scan (`top`
/// given) capped at the object's top as its lines show it, and what it removes from each view.
pub fn working_volume(
    views: &[ViewGrid],
    turntable: Option<&TurntableAxis>,
    crop: &CropParams,
    top: Option<&TopParams>,
) -> VolumeReport {
    use rayon::prelude::*;
    let placed: Vec<Vec<Point3>> = views
        .par_iter()
        .map(|v| {
            let pose = turntable_pose(turntable, v.angle_deg);
            match v.data {
                ViewData::Grid(g) => (0..g.points.len()).filter(|&i| g.valid[i]).map(|i| pose * g.points[i]).collect(),
                ViewData::Sparse(s) => {
                    // In image-row order: a line is followed along its rows.
                    let mut order: Vec<usize> = (0..s.points.len()).collect();
                    order.sort_by(|&a, &b| s.pixels[a][1].total_cmp(&s.pixels[b][1]));
                    order.into_iter().map(|i| pose * s.points[i]).collect()
                }
            }
        })
        .collect();
    let radius = crop.radius_mm;
    let within = |p: &Point3| radius.is_none_or(|r| p.x * p.x + p.y * p.y <= r * r);
    // Heights of each line's points inside the radius (the wall or the table are not the object).
    let found = match (top, turntable) {
        (Some(tp), Some(_)) => {
            let heights: Vec<Vec<Real>> =
                placed.iter().map(|pts| pts.iter().filter(|p| within(p)).map(|p| p.z).collect()).collect();
            let lines = views
                .iter()
                .zip(&heights)
                .filter(|(v, _)| matches!(v.data, ViewData::Sparse(_)))
                .map(|(v, h)| (v.view, v.laser, &h[..]));
            object_top(lines, tp).map(|t| (t, t.top_mm + tp.margin_mm))
        }
        _ => None,
    };
    let cap = match (found.map(|f| f.1), crop.max_height_mm) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    };
    let mut report =
        VolumeReport { radius_mm: radius, max_height_mm: cap, top: found.map(|f| f.0), ..Default::default() };
    if top.is_some() && turntable.is_some() {
        let inside = |p: &&Point3| p.z >= crop.min_height_mm && within(p) && cap.is_none_or(|c| p.z <= c);
        let lines: Vec<Vec<Point3>> = views
            .iter()
            .zip(&placed)
            .filter(|(v, _)| matches!(v.data, ViewData::Sparse(_)))
            .map(|(_, pts)| pts.iter().filter(inside).copied().collect())
            .collect();
        report.spacing = LineSpacing::of(&lines);
    }
    for (v, pts) in views.iter().zip(&placed) {
        let mut vv = ViewVolume { view: v.view, laser: v.laser, points: pts.len(), ..Default::default() };
        for p in pts {
            if p.z < crop.min_height_mm {
                vv.below_platter += 1;
            } else if !within(p) {
                vv.outside_radius += 1;
            } else if cap.is_some_and(|c| p.z > c) {
                vv.above_top += 1;
            }
        }
        report.outside_radius += vv.outside_radius;
        report.above_top += vv.above_top;
        report.views.push(vv);
    }
    report
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::math::{UnitVector3, Vector3};
    use rig::{Sensor, SparseView};

    /// A line as a camera on the axis would give it: points (x, 0, z) with z its height, row by row.
    fn line(points: &[(Real, Real)]) -> SparseView {
        SparseView {
            width: 10,
            height: points.len(),
            points: points.iter().map(|&(x, z)| Point3::new(x, 0.0, z)).collect(),
            pixels: (0..points.len()).map(|r| [0.0, r as f32]).collect(),
            confidence: vec![1.0; points.len()],
            colors: None,
            sensor: Sensor::Center(Point3::origin()),
        }
    }

    #[test]
    fn points_above_the_lines_top_and_beyond_the_platter_are_counted_per_view_and_said() {
        let axis = TurntableAxis { point: Point3::origin(), direction: UnitVector3::new_normalize(Vector3::z()) };
        // View 0: stray light at 120–100 mm, then the object from 60 mm down to the platter.
        let mut first: Vec<(Real, Real)> = (0..40).map(|k| (50.0, 120.0 - 0.5 * k as Real)).collect();
        first.extend((0..=120).map(|k| (20.0, 60.0 - 0.5 * k as Real)));
        // View 1: the object, and two points beyond the 70 mm platter.
        let mut second: Vec<(Real, Real)> = (0..=110).map(|k| (25.0, 55.0 - 0.5 * k as Real)).collect();
        second.extend([(90.0, 30.0), (95.0, 31.0)]);
        let (a, b) = (line(&first), line(&second));
        let views = [
            ViewGrid { view: 0, angle_deg: 0.0, laser: Some(0), data: ViewData::Sparse(&a) },
            ViewGrid { view: 1, angle_deg: 0.0, laser: Some(0), data: ViewData::Sparse(&b) },
        ];
        let crop = CropParams { radius_mm: Some(70.0), ..Default::default() };
        let r = working_volume(&views, Some(&axis), &crop, Some(&TopParams::default()));
        let top = r.top.unwrap();
        assert_eq!((top.top_mm, top.view, top.grounded_lines), (60.0, 0, 2));
        assert_eq!(r.max_height_mm, Some(61.0));
        assert_eq!((r.views[0].above_top, r.views[0].outside_radius), (40, 0));
        assert_eq!((r.views[1].above_top, r.views[1].outside_radius), (0, 2));
        assert_eq!(r.crop(&crop).max_height_mm, Some(61.0));
        let w = r.warnings();
        assert!(w[0].contains("42 of 274 points") && w[0].contains("40 above the object's top (60.0 mm"), "{w:?}");
        assert!(w[0].contains("2 beyond the platter radius 70.0 mm") && w[0].contains("view 0 laser 0: 40"), "{w:?}");
        // Without lines (structured light) only the radius and the user's cap apply.
        let r = working_volume(&views, Some(&axis), &crop, None);
        assert!(r.top.is_none() && r.max_height_mm.is_none() && r.above_top == 0 && r.outside_radius == 2);
        assert!(r.spacing.is_none());
    }

    #[test]
    fn the_widest_gap_between_lines_is_measured_at_the_median_radius_and_said_against_the_cell() {
        // Lines at 0°, 10°, …, 350° except 180° (missing) on a 30 mm cylinder; one wraps through ±180°.
        let line_at = |deg: Real| -> Vec<Point3> {
            let a = deg.to_radians();
            (0..20).map(|k| Point3::new(30.0 * a.cos(), 30.0 * a.sin(), k as Real)).collect()
        };
        let lines: Vec<Vec<Point3>> = (0..36).filter(|&k| k != 18).map(|k| line_at(10.0 * k as Real)).collect();
        let s = LineSpacing::of(&lines).unwrap();
        assert_eq!(s.lines, 35);
        assert!((s.largest_gap_deg - 20.0).abs() < 1e-9 && (s.radius_mm - 30.0).abs() < 1e-9, "{s:?}");
        assert!((s.largest_gap_mm - 30.0 * 20f64.to_radians()).abs() < 1e-9);
        // 10.5 mm against a 0.5 mm cell: 21 cells, said naming the depth and the views; a 3 mm cell is fine.
        let w = s.warning(0.5, 8).unwrap();
        assert!(w.contains("20.0° apart") && w.contains("--depth 8") && w.contains("--views"), "{w}");
        assert!(!w.contains("  "), "one sentence, single-spaced: {w}");
        assert!(s.warning(3.0, 8).is_none());
        // One line: no spacing; a full set 1° apart at 30 mm: 0.52 mm, under four 0.2 mm cells.
        assert!(LineSpacing::of(&lines[..1]).is_none());
        let dense: Vec<Vec<Point3>> = (0..360).map(|k| line_at(k as Real - 180.0)).collect();
        assert!(LineSpacing::of(&dense).unwrap().warning(0.2, 9).is_none());
    }
}
