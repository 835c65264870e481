//! `NAME.report.json`, what `calibrate` did, field by field: a section per step that ran, the images
//! without the board, the steps skipped and the warnings. The report page
//! (`web::calib_report`) and the plausibility findings read these fields, never string keys.
//!
//! A figure that was not a number (NaN) is written as JSON `null` and read back as NaN.

use rig::math::Real;
use serde::{Deserialize, Deserializer, Serialize};
use std::path::PathBuf;

/// The layout version of the calibration report; raised when a field changes meaning or goes.
pub const CALIB_REPORT_SCHEMA_VERSION: u32 = 1;

/// A figure that may have been NaN when written (JSON `null`).
fn figure<'de, D: Deserializer<'de>>(d: D) -> Result<Real, D::Error> {
    Ok(Option::<Real>::deserialize(d)?.unwrap_or(Real::NAN))
}

/// A figure that is there or not; there, it may have been NaN when written (JSON `null`).
fn some_figure<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Real>, D::Error> {
    figure(d).map(Some)
}

/// Pairs of figures, either of which may have been NaN (JSON `null`).
fn figure_pairs<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<[Real; 2]>, D::Error> {
    let pairs = Vec::<[Option<Real>; 2]>::deserialize(d)?;
    Ok(pairs.into_iter().map(|p| p.map(|x| x.unwrap_or(Real::NAN))).collect())
}

/// What `calibrate` did.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CalibReport {
    /// [`CALIB_REPORT_SCHEMA_VERSION`] of the scanrig that wrote it (0: before reports had one).
    #[serde(default)]
    pub schema_version: u32,
    /// The camera's intrinsics, where that step ran.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<CameraReport>,
    /// The turntable axis, where that step ran.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub turntable: Option<TurntableReport>,
    /// Each laser's plane, where that step ran.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lasers: Option<Vec<LaserReport>>,
    /// The projector and its pose, where that step ran.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub projector: Option<ProjectorReport>,
    /// Images in which the board was not found, and why.
    #[serde(default)]
    pub not_found: Vec<NotFound>,
    /// In how many images the board was found.
    #[serde(default)]
    pub board_found: BoardFound,
    /// The board looked for.
    #[serde(default)]
    pub board: BoardReport,
    /// Steps the captures were taken for but could not serve, and why.
    #[serde(default)]
    pub skipped: Vec<Skipped>,
    /// Figures no working rig gives (`plausible::findings`): the rig is not written unless forced.
    #[serde(default)]
    pub warnings: Vec<String>,
    /// The rig file written (absent when it was not: an implausible calibration, unforced).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rig: Option<PathBuf>,
}

/// The camera step: intrinsics and how well they reproject the board.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CameraReport {
    /// The lens.
    #[serde(flatten)]
    pub lens: LensReport,
    /// RMS reprojection error over every corner (px).
    #[serde(deserialize_with = "figure")]
    pub rms_px: Real,
    /// Each board view.
    #[serde(default)]
    pub views: Vec<BoardView>,
    /// Images whose RMS is far above the others' (three times the median and over 0.5 px).
    #[serde(default)]
    pub outlier_views: Vec<PathBuf>,
    /// Levenberg–Marquardt iterations.
    #[serde(default)]
    pub iterations: usize,
    /// The lens terms estimated and those held at zero, with why (`crate::lens_model`'s rule).
    #[serde(default)]
    pub model: crate::lens_model::ModelChoice,
    /// Where the views' corners fell, and what they leave uncovered.
    #[serde(default)]
    pub coverage: CoverageReport,
}

/// Where the board's corners fell over the camera step's views: what another capture should add.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CoverageReport {
    /// Share of the image's cells (`lens_model::CELLS_X` × `CELLS_Y`) holding a corner.
    #[serde(deserialize_with = "figure")]
    pub covered: Real,
    /// The farthest corner from the image centre, as a share of the centre-to-corner distance.
    #[serde(deserialize_with = "figure")]
    pub reach: Real,
    /// Regions of the image no corner fell in ("top left" …).
    #[serde(default)]
    pub missing_regions: Vec<String>,
    /// The board's tilts towards the camera (degrees about the image's x and y axes), each view.
    #[serde(default)]
    pub tilts_deg: Vec<[Real; 2]>,
    /// Tilts no view had ("tilted left by 20° or more" …): Zhang's method needs the board turned
    /// both ways about both axes for a well-conditioned focal length.
    #[serde(default)]
    pub missing_tilts: Vec<String>,
    /// What to capture next, in a sentence; empty when nothing is missing.
    #[serde(default)]
    pub advice: String,
}

/// A lens (camera or projector): image size, pinhole and distortion.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct LensReport {
    /// Image size (px).
    pub width: u32,
    /// Image size (px).
    pub height: u32,
    /// Focal length (px).
    #[serde(deserialize_with = "figure")]
    pub fx: Real,
    /// Focal length (px).
    #[serde(deserialize_with = "figure")]
    pub fy: Real,
    /// Principal point (px).
    #[serde(deserialize_with = "figure")]
    pub cx: Real,
    /// Principal point (px).
    #[serde(deserialize_with = "figure")]
    pub cy: Real,
    /// Distortion in OpenCV's order: k1, k2, p1, p2, k3.
    pub distortion: [Real; 5],
}

impl LensReport {
    /// The report of `lens`.
    pub fn of(lens: &rig::PinholeCamera) -> LensReport {
        LensReport {
            width: lens.width,
            height: lens.height,
            fx: lens.fx,
            fy: lens.fy,
            cx: lens.cx,
            cy: lens.cy,
            distortion: lens.distortion.to_opencv(),
        }
    }
}

/// One board view of the camera step.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct BoardView {
    /// The image.
    pub image: PathBuf,
    /// Its RMS reprojection error (px).
    #[serde(deserialize_with = "figure")]
    pub rms_px: Real,
    /// The corners found (px), row by row of the board.
    #[serde(default)]
    pub corners: Vec<[Real; 2]>,
    /// Each found corner's number on the board (row-major, as `corners`); all of them for a whole
    /// board.
    #[serde(default)]
    pub corner_ids: Vec<usize>,
    /// Whether the whole board was seen, or a part placed by its margin, or a part whose place on
    /// the board is unknown (used for the lens only).
    #[serde(default)]
    pub placement: crate::Placement,
    /// Each corner's residual, reprojected − found (px; NaN where the corner does not project).
    #[serde(default, deserialize_with = "figure_pairs")]
    pub residuals_px: Vec<[Real; 2]>,
    /// The board's pose (camera from board).
    pub pose: BoardPose,
}

/// A board's pose: a rotation vector (axis × angle, radians) and a translation (mm).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct BoardPose {
    /// Axis times angle (radians).
    pub rotation_vector: [Real; 3],
    /// Translation (mm).
    pub translation_mm: [Real; 3],
}

/// The turntable step: the axis, in the camera frame.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TurntableReport {
    /// How it was found: the sweep adjusted as one turn, or the corners' circles.
    pub method: String,
    /// A point on the axis (mm).
    pub point_mm: [Real; 3],
    /// The axis direction (unit).
    pub direction: [Real; 3],
    /// The sweep's RMS reprojection error (px), where angles were recorded.
    #[serde(default, deserialize_with = "some_figure", skip_serializing_if = "Option::is_none")]
    pub rms_px: Option<Real>,
    /// The corners' RMS distance from their circles (mm), where no angles were recorded.
    #[serde(default, deserialize_with = "some_figure", skip_serializing_if = "Option::is_none")]
    pub circle_rms_mm: Option<Real>,
    /// Views used.
    pub views: usize,
    /// How high the board's lowest inner corners stood above the platter (mm).
    #[serde(deserialize_with = "figure")]
    pub corner_height_mm: Real,
}

/// The laser step: one laser's plane (camera frame) and how well its points fit it.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct LaserReport {
    /// The laser, 0-based.
    pub laser: usize,
    /// The plane's unit normal.
    pub normal: [Real; 3],
    /// Its distance from the camera centre (mm).
    #[serde(deserialize_with = "figure")]
    pub distance_mm: Real,
    /// RMS distance of the inliers from the plane (mm).
    #[serde(deserialize_with = "figure")]
    pub spread_rms_mm: Real,
    /// Largest distance of an inlier from the plane (mm).
    #[serde(deserialize_with = "figure")]
    pub spread_max_mm: Real,
    /// Line points on the board.
    pub points: usize,
    /// Of which fit the plane.
    pub inliers: usize,
    /// Board views with this laser's line.
    pub views: usize,
}

/// The projector step: its lens, its pose and the stereo fit.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ProjectorReport {
    /// The lens (the projector's image size).
    #[serde(flatten)]
    pub lens: LensReport,
    /// Projector from camera: rotation vector (radians).
    pub rotation_vector: [Real; 3],
    /// Projector from camera: translation (mm).
    pub translation_mm: [Real; 3],
    /// The projector's own reprojection error (px).
    #[serde(deserialize_with = "figure")]
    pub projector_rms_px: Real,
    /// The stereo adjustment's RMS over camera and projector (px).
    #[serde(deserialize_with = "figure")]
    pub stereo_rms_px: Real,
    /// Its camera part (px).
    #[serde(deserialize_with = "figure")]
    pub stereo_camera_rms_px: Real,
    /// Its projector part (px).
    #[serde(deserialize_with = "figure")]
    pub stereo_projector_rms_px: Real,
    /// Board views with structured light.
    pub views: usize,
    /// Corners whose projector position was decoded.
    pub corners_used: usize,
    /// Corners skipped (too few decoded pixels around them).
    pub corners_skipped: usize,
    /// The window around a corner its projector position is fitted in (px).
    pub window_px: usize,
    /// The projector's lens terms estimated and held, with why (`crate::lens_model`'s rule on the
    /// corners' spread in the projector's image).
    #[serde(default)]
    pub model: crate::lens_model::ModelChoice,
}

/// An image without the board.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct NotFound {
    /// The image.
    pub image: PathBuf,
    /// Why the board was not found in it.
    pub why: String,
}

/// In how many images the board was found.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct BoardFound {
    /// Images with the board.
    pub found: usize,
    /// Images looked at.
    pub of: usize,
    /// Of those with the board, how many showed only part of it (placed on the board by its margin
    /// or not: each view's `placement`).
    #[serde(default)]
    pub partial: usize,
}

/// The board: inner corners and square size.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct BoardReport {
    /// Inner corners along a row.
    pub cols: usize,
    /// Inner corners along a column.
    pub rows: usize,
    /// Square size (mm).
    #[serde(deserialize_with = "figure")]
    pub square_mm: Real,
    /// A ChArUco board's markers, in words; absent for a plain chessboard.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub charuco: Option<String>,
}

/// A step the captures were taken for but could not serve.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Skipped {
    /// The step (`turntable`, …).
    pub step: String,
    /// Why.
    pub why: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_report_reads_back_as_written_and_a_nan_figure_stays_nan() {
        let mut r = CalibReport {
            schema_version: CALIB_REPORT_SCHEMA_VERSION,
            camera: Some(CameraReport {
                lens: LensReport { width: 640, height: 480, fx: 500.0, ..Default::default() },
                rms_px: 0.12,
                ..Default::default()
            }),
            turntable: Some(TurntableReport { rms_px: None, circle_rms_mm: Some(Real::NAN), ..Default::default() }),
            ..Default::default()
        };
        r.warnings.push("a warning".into());
        let json = serde_json::to_string(&r).unwrap();
        assert!(!json.contains("\"lasers\"") && !json.contains("\"projector\"") && !json.contains("\"rms_px\":null"));
        let back: CalibReport = serde_json::from_str(&json).unwrap();
        assert_eq!(back.camera, r.camera);
        assert!(back.turntable.unwrap().circle_rms_mm.unwrap().is_nan());
        // A camera figure that was NaN is written as null and read as NaN.
        let nan = CalibReport { camera: Some(CameraReport { rms_px: Real::NAN, ..Default::default() }), ..r };
        let back: CalibReport = serde_json::from_str(&serde_json::to_string(&nan).unwrap()).unwrap();
        assert!(back.camera.unwrap().rms_px.is_nan());
    }
}
