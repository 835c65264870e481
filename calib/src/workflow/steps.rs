//! The calibration steps, each from the board positions whose corners were found: camera
//! intrinsics, the turntable axis, laser planes and the projector.

use super::captures::{Orientation, Position};
use super::report::CoverageReport;
use super::report::{BoardPose, BoardView, CameraReport, LaserReport, LensReport, ProjectorReport, TurntableReport};
use super::{Step, WorkflowError as E};
use crate::laser_plane::on_even_print;
use crate::lens_model::{Coverage, LensModel, choose};
use crate::turntable_axis::{board_pose, fit_axis_seen};
use crate::{
    BoardRegion, CameraOptions, LaserView, Placement, StereoView, SweepView, View, calibrate_camera,
    calibrate_projector, fit_laser_plane, fit_sweep, projector_corners,
};
use decode::laser_line::{LaserParams, detect_line_within};
use decode::structured_light::{DecodeParams, decode_view};
use rig::math::{Isometry3, Point2, Point3, Real};
use rig::{LaserPlane, PinholeCamera, TurntableAxis};
use std::path::PathBuf;

/// A position whose board was found, whole or in part: its corners' numbers on the board and
/// their pixels.
pub struct Found<'a> {
    pub position: &'a Position,
    pub ids: Vec<usize>,
    pub corners: Vec<Point2>,
    pub placement: Placement,
}

impl Found<'_> {
    /// The found corners in the board frame.
    fn object(&self, board: &Board) -> Vec<Point3> {
        self.ids.iter().map(|&i| board.object[i]).collect()
    }

    /// The board's square in pixels: the median distance between corners next to each other in a row.
    fn square_px(&self, cols: usize) -> Real {
        crate::charuco::square_px(&self.ids, &self.corners, cols)
    }
}

/// The board: its corners in its own frame and its corner grid.
pub struct Board {
    pub cols: usize,
    pub rows: usize,
    pub object: Vec<Point3>,
}

/// Names a few files for an error message.
pub fn some_files<'a>(files: impl Iterator<Item = &'a PathBuf>) -> String {
    let all: Vec<String> = files.map(|f| f.display().to_string()).collect();
    match all.len() {
        0 => "none".into(),
        n if n <= 4 => all.join(", "),
        n => format!("{}, … ({n} in all)", all[..3].join(", ")),
    }
}

/// The camera's lens from every board found, whole or in part, with the distortion terms the views
/// support (`lens_model`) unless `model` is `Full`.
pub fn camera(
    found: &[Found],
    board: &Board,
    size: (u32, u32),
    user: CameraOptions,
    model: LensModel,
) -> Result<(PinholeCamera, CameraReport), E> {
    let views: Vec<View> = found.iter().map(|f| View { object: f.object(board), image: f.corners.clone() }).collect();
    let cov = Coverage::of(found.iter().map(|f| f.corners.as_slice()), size.0, size.1);
    let (opts, model) = choose(model, user, &cov);
    let c = calibrate_camera(&views, size.0, size.1, opts).map_err(|source| E::Step {
        step: Step::Camera,
        source,
        files: format!("images with the board: {}", some_files(found.iter().map(|f| &f.position.lit))),
    })?;
    let views = found.iter().zip(&c.view_rms).zip(&c.poses);
    let report = CameraReport {
        lens: LensReport::of(&c.camera),
        rms_px: c.rms,
        views: views.map(|((f, r), pose)| board_view(f, *r, pose, board, &c.camera)).collect(),
        outlier_views: c.outlier_views.iter().map(|&v| found[v].position.lit.clone()).collect(),
        iterations: c.iterations,
        model,
        coverage: coverage_report(&cov, &c.poses),
    };
    Ok((c.camera, report))
}

/// The smallest tilt (degrees) that counts as a board turned about an image axis.
const TILT_DEG: Real = 15.0;

/// The coverage and tilts of the camera step's views, and what a next capture should add.
fn coverage_report(cov: &Coverage, poses: &[Isometry3]) -> CoverageReport {
    // The board's normal towards the camera: its z axis (out of the printed face), camera frame.
    let tilts: Vec<[Real; 2]> = poses
        .iter()
        .map(|p| {
            let n = p.rotation * rig::math::Vector3::z();
            // Positive: the board's top (−y) farther away; its right side (+x) farther away.
            [(-n.y).atan2(-n.z).to_degrees(), (-n.x).atan2(-n.z).to_degrees()]
        })
        .collect();
    let seen = |axis: usize, sign: Real| tilts.iter().any(|t| sign * t[axis] >= TILT_DEG);
    let mut missing_tilts = Vec::new();
    for (axis, sign, what) in [
        (0, 1.0, "top leaning away"),
        (0, -1.0, "top leaning towards the camera"),
        (1, 1.0, "right side turned away"),
        (1, -1.0, "left side turned away"),
    ] {
        if !seen(axis, sign) {
            missing_tilts.push(format!("{what} by {TILT_DEG:.0}° or more"));
        }
    }
    let missing_regions = cov.missing();
    let mut advice = Vec::new();
    if !missing_regions.is_empty() {
        advice.push(format!("hold the board so its corners reach the {} of the image", missing_regions.join(", ")));
    }
    if !missing_tilts.is_empty() {
        advice.push(format!("add views with the board's {}", missing_tilts.join("; ")));
    }
    CoverageReport {
        covered: cov.covered(),
        reach: cov.reach,
        missing_regions,
        tilts_deg: tilts.iter().map(|t| t.map(|v| (v * 10.0).round() / 10.0)).collect(),
        missing_tilts,
        advice: advice.join("; "),
    }
}

/// One board view of the camera step: its image, RMS, the corners found, each corner's
/// reprojection residual (reprojected − found, px) and the board's pose (camera from board), for the
/// calibration report to draw.
fn board_view(f: &Found, rms: Real, pose: &Isometry3, board: &Board, camera: &PinholeCamera) -> BoardView {
    let round = |v: Real| (v * 1e4).round() / 1e4;
    let residuals: Vec<[Real; 2]> = f
        .object(board)
        .iter()
        .zip(&f.corners)
        .map(|(o, c)| match camera.project(&(pose * o)) {
            Some(p) => [round(p.x - c.x), round(p.y - c.y)],
            None => [Real::NAN, Real::NAN],
        })
        .collect();
    BoardView {
        image: f.position.lit.clone(),
        rms_px: rms,
        corners: f.corners.iter().map(|c| [round(c.x), round(c.y)]).collect(),
        corner_ids: f.ids.clone(),
        placement: f.placement,
        residuals_px: residuals,
        pose: BoardPose {
            rotation_vector: pose.rotation.scaled_axis().into(),
            translation_mm: pose.translation.vector.into(),
        },
    }
}

/// The turntable axis: from the views with recorded angles adjusted as one sweep, or without angles
/// (an image folder) from the corners' circles. Also returns the sweep's board poses by position
/// (for the laser step). Whole boards and parts placed on the board are used; a part whose place is
/// unknown is not: the axis relates views to one another, which a shifted numbering would turn.
pub fn turntable(
    found: &[Found],
    board: &Board,
    camera: &PinholeCamera,
    corner_height_mm: Real,
) -> Result<(TurntableAxis, Vec<Option<Isometry3>>, TurntableReport), E> {
    let placed: Vec<usize> = (0..found.len()).filter(|&k| found[k].placement != Placement::Unplaced).collect();
    let swept: Vec<usize> = placed.iter().copied().filter(|&k| found[k].position.angle_deg.is_some()).collect();
    let names = || some_files(found.iter().map(|f| &f.position.lit));
    if swept.len() >= 3 {
        let views: Vec<SweepView> = swept
            .iter()
            .map(|&k| SweepView {
                angle_deg: found[k].position.angle_deg.unwrap(),
                corners: found[k].corners.clone(),
                ids: found[k].ids.clone(),
            })
            .collect();
        let fit = fit_sweep(camera, &board.object, &views, corner_height_mm).map_err(|source| E::Step {
            step: Step::Turntable,
            source,
            files: names(),
        })?;
        let mut poses = vec![None; found.len()];
        for (&k, p) in swept.iter().zip(&fit.poses) {
            poses[k] = Some(*p);
        }
        let report = TurntableReport {
            method: "sweep adjusted as one turn about one axis".into(),
            point_mm: fit.axis.point.coords.into(),
            direction: (*fit.axis.direction).into(),
            rms_px: Some(fit.rms_px),
            circle_rms_mm: None,
            views: swept.len(),
            corner_height_mm,
        };
        return Ok((fit.axis, poses, report));
    }
    if found.iter().any(|f| f.position.angle_deg.is_some()) || placed.len() < 3 {
        return Err(E::TooFewTurntableViews { found: swept.len(), files: names() });
    }
    // An image folder: every view is taken to be on the turntable, angles unknown.
    let views: Vec<(&[usize], &[Point2])> =
        placed.iter().map(|&k| (found[k].ids.as_slice(), found[k].corners.as_slice())).collect();
    let fit = fit_axis_seen(camera, &board.object, &views, corner_height_mm).map_err(|source| E::Step {
        step: Step::Turntable,
        source,
        files: names(),
    })?;
    let report = TurntableReport {
        method: "corner circles (no recorded angles)".into(),
        point_mm: fit.axis.point.coords.into(),
        direction: (*fit.axis.direction).into(),
        rms_px: None,
        circle_rms_mm: Some(fit.circle_rms_mm),
        views: fit.views,
        corner_height_mm,
    };
    Ok((fit.axis, vec![None; found.len()], report))
}

/// Every laser's plane from the positions with laser frames; `poses` are sweep poses where known.
pub fn lasers(
    found: &[Found],
    board: &Board,
    camera: &PinholeCamera,
    poses: &[Option<Isometry3>],
    turn: Orientation,
) -> Result<(Vec<LaserPlane>, Vec<LaserReport>), E> {
    let count = found.iter().flat_map(|f| f.position.lasers.iter().map(|l| l.0 + 1)).max().unwrap_or(0);
    if count == 0 {
        return Err(E::NoFrames { step: Step::Laser });
    }
    let mut views: Vec<Vec<LaserView>> = vec![Vec::new(); count];
    let mut frames: Vec<Vec<PathBuf>> = vec![Vec::new(); count];
    for (k, f) in found.iter().enumerate() {
        if f.position.lasers.is_empty() {
            continue;
        }
        // A part of the board with no place on it gives the board's plane but not where its edges
        // are, which bounds the search for the line.
        if f.placement == Placement::Unplaced {
            continue;
        }
        let pose = match poses.get(k).copied().flatten() {
            Some(p) => p,
            None => board_pose(camera, &f.object(board), &f.corners)
                .ok_or_else(|| E::NoBoardPose { image: f.position.lit.clone() })?,
        };
        let lit = turn.read(&f.position.lit)?;
        let same_size = |img: rig::image::Image8, path: &PathBuf| -> Result<rig::image::Image8, E> {
            if (img.width, img.height) != (lit.width, lit.height) {
                return Err(E::SizeMismatch {
                    image: path.clone(),
                    size: (img.width, img.height),
                    first: f.position.lit.clone(),
                    first_size: (lit.width, lit.height),
                });
            }
            Ok(img)
        };
        let images: Vec<(usize, rig::image::Image8)> =
            f.position.lasers.iter().map(|(i, p)| Ok((*i, same_size(turn.read(p)?, p)?))).collect::<Result<_, E>>()?;
        // The background: the laser-off frame, or else the darker of the laser frames at each pixel.
        let off = match &f.position.laser_off {
            Some(p) => same_size(turn.read(p)?, p)?,
            None => {
                let mut off = images[0].1.clone();
                for (_, img) in &images[1..] {
                    off.data.iter_mut().zip(&img.data).for_each(|(o, &v)| *o = (*o).min(v));
                }
                if images.len() == 1 {
                    off.data.fill(0);
                }
                off
            }
        };
        // The board's whole grid: as found, or where the pose puts the corners not seen.
        let grid: Option<Vec<Point2>> = match f.placement {
            Placement::Whole => Some(f.corners.clone()),
            _ => board.object.iter().map(|o| camera.project(&(pose * o))).collect(),
        };
        let Some(region) = grid.and_then(|g| BoardRegion::new(&g, board.cols, board.rows)) else {
            return Err(E::NoBoardPose { image: f.position.lit.clone() });
        };
        for ((i, on), (_, path)) in images.iter().zip(&f.position.lasers) {
            let (peaks, _) = detect_line_within(on, &off, &LaserParams::default(), |x, y| {
                region.contains(Point2::new(x as Real, y as Real))
            });
            let pixels: Vec<Point2> = peaks
                .iter()
                .map(|p| Point2::new(p.col, p.row as Real))
                .filter(|&p| on_even_print(&lit, p, 6))
                .collect();
            views[*i].push(LaserView { pose, pixels });
            frames[*i].push(path.clone());
        }
    }
    let mut planes = Vec::new();
    let mut report = Vec::new();
    for (i, v) in views.iter().enumerate() {
        let fit = fit_laser_plane(camera, v, 0.5).map_err(|source| E::Step {
            step: Step::Laser,
            source,
            files: format!("laser {i}'s frames: {}", some_files(frames[i].iter())),
        })?;
        report.push(LaserReport {
            laser: i,
            normal: (*fit.plane.normal).into(),
            distance_mm: fit.plane.distance,
            spread_rms_mm: fit.rms_mm,
            spread_max_mm: fit.max_mm,
            points: fit.points,
            inliers: fit.inliers,
            views: fit.views,
        });
        planes.push(fit.plane);
    }
    Ok((planes, report))
}

/// The projector from the positions with structured-light frames.
pub fn projector(
    found: &[Found],
    board: &Board,
    camera: &PinholeCamera,
    size: (u32, u32),
    turn: Orientation,
    (user, model): (CameraOptions, LensModel),
    mut progress: impl FnMut(usize, usize),
) -> Result<(PinholeCamera, Isometry3, ProjectorReport), E> {
    let with: Vec<&Found> = found.iter().filter(|f| !f.position.structured.is_empty()).collect();
    if with.is_empty() {
        return Err(E::NoFrames { step: Step::Projector });
    }
    // A window a little under a square wide: the four squares around a corner, no farther.
    let spacing = with[0].square_px(board.cols);
    let half = ((0.4 * spacing) as usize).clamp(4, 40);
    let mut views = Vec::new();
    for (k, f) in with.iter().enumerate() {
        progress(k + 1, with.len());
        let images: Vec<(rig::Pattern, rig::image::Image8)> =
            f.position.structured.iter().map(|(p, path)| Ok((*p, turn.read(path)?))).collect::<Result<_, E>>()?;
        let frames: Vec<(rig::Pattern, &rig::image::Image8)> = images.iter().map(|(p, i)| (*p, i)).collect();
        let names: Vec<String> = f.position.structured.iter().map(|(_, path)| path.display().to_string()).collect();
        let (map, _) = decode_view(&frames, size.0, size.1, &DecodeParams::default())
            .map_err(|source| E::Decode { image: f.position.lit.clone(), source: source.name_frames(&names) })?;
        views.push(StereoView {
            object: f.object(board),
            camera: f.corners.clone(),
            projector: projector_corners(&f.corners, &map, half),
        });
    }
    // The projector's lens terms follow from where the corners fell in its image, as the camera's do.
    let seen: Vec<Vec<Point2>> = views.iter().map(|v| v.projector.iter().flatten().copied().collect()).collect();
    let (opts, model) = choose(model, user, &Coverage::of(seen.iter().map(|v| v.as_slice()), size.0, size.1));
    let p = calibrate_projector(camera, &views, size.0, size.1, opts).map_err(|source| E::Step {
        step: Step::Projector,
        source,
        files: some_files(with.iter().map(|f| &f.position.lit)),
    })?;
    let report = ProjectorReport {
        lens: LensReport::of(&p.lens),
        rotation_vector: p.from_camera.rotation.scaled_axis().into(),
        translation_mm: p.from_camera.translation.vector.into(),
        projector_rms_px: p.projector_rms,
        stereo_rms_px: p.stereo_rms,
        stereo_camera_rms_px: p.stereo_camera_rms,
        stereo_projector_rms_px: p.stereo_projector_rms,
        views: p.views,
        corners_used: p.corners_used,
        corners_skipped: p.corners_skipped,
        window_px: 2 * half + 1,
        model,
    };
    Ok((p.lens, p.from_camera, report))
}
