//! A whole rig from calibration captures: the board found in every lit frame, then each step the
//! captures allow — camera intrinsics first, then the turntable axis, the laser planes and the
//! projector — merged into a starting rig. What `scanrig calibrate` runs; the binary only parses
//! arguments, shows progress and writes the files.

pub mod captures;
pub mod limits;
pub mod plausible;
pub mod report;
mod steps;

pub use captures::{Orientation, Position, load};
pub use report::{CALIB_REPORT_SCHEMA_VERSION, CalibReport};

use crate::{CalibError, CameraOptions, Gray, LensModel, Placement, find_board};
use report::{BoardFound, BoardReport, NotFound, Skipped};
use rig::math::{Point3, Real};
use rig::{Laser, PinholeCamera, Projector, Rig};
use std::path::PathBuf;
use steps::{Board, Found};

/// A calibration step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// Camera intrinsics and distortion.
    Camera,
    /// The projector's lens and pose.
    Projector,
    /// Laser planes.
    Laser,
    /// The turntable axis.
    Turntable,
}

impl std::fmt::Display for Step {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Step::Camera => "camera",
            Step::Projector => "projector",
            Step::Laser => "laser",
            Step::Turntable => "turntable",
        })
    }
}

/// What to calibrate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// One step (the camera from `base` where it is not this one).
    Only(Step),
    /// Every step the captures allow, the camera first.
    All,
}

/// Why a calibration failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WorkflowError {
    /// Reading a file.
    #[error(transparent)]
    File(#[from] rig::Error),
    /// An image folder without images.
    #[error("{}: no scan.json and no PNG or JPEG images", path.display())]
    NoImages {
        /// The folder or pattern.
        path: PathBuf,
    },
    /// A capture folder without a usable view.
    #[error("{}: the capture folder has no complete view with a lit (white) frame", folder.display())]
    NoLitFrame {
        /// The folder.
        folder: PathBuf,
    },
    /// Images of different sizes.
    #[error(
        "{} is {}x{} but {} is {}x{}: one camera's images must share one size",
        image.display(), size.0, size.1, first.display(), first_size.0, first_size.1
    )]
    SizeMismatch {
        /// The odd image.
        image: PathBuf,
        /// Its size.
        size: (u32, u32),
        /// The image it was compared with.
        first: PathBuf,
        /// That one's size.
        first_size: (u32, u32),
    },
    /// The board was found nowhere.
    #[error(
        "no {cols}x{rows} board found in any of the {images} images ({files}); check --board (inner corners) \
         and --transpose"
    )]
    NoBoard {
        /// Inner corners across.
        cols: usize,
        /// Inner corners down.
        rows: usize,
        /// Images looked at.
        images: usize,
        /// Some of them, named.
        files: String,
    },
    /// A step's estimate failed.
    #[error("{step}: {source} ({files})")]
    Step {
        /// The step.
        step: Step,
        /// Why.
        source: CalibError,
        /// The images it used, named.
        files: String,
    },
    /// A step without the frames it needs.
    #[error("{step}: no {step} frames among the positions where the board was found")]
    NoFrames {
        /// The step.
        step: Step,
    },
    /// Too few turntable views for the axis.
    #[error("turntable: the board was found in {found} view(s) on the turntable; at least 3 are needed ({files})")]
    TooFewTurntableViews {
        /// Views found.
        found: usize,
        /// The images, named.
        files: String,
    },
    /// A board whose pose cannot be solved.
    #[error("{}: no board pose from its corners", image.display())]
    NoBoardPose {
        /// Its lit frame.
        image: PathBuf,
    },
    /// Structured light that does not decode.
    #[error("{}: {source}", image.display())]
    Decode {
        /// The position's lit frame.
        image: PathBuf,
        /// Why.
        source: decode::DecodeError,
    },
    /// A step that needs a calibrated camera without one.
    #[error("{step} calibration needs the camera: give --rig RIG, or calibrate `camera` or `all` first")]
    NeedsCamera {
        /// The step.
        step: Step,
    },
    /// The starting rig's camera does not match the images.
    #[error("the rig's camera is {}x{} but the images are {}x{}", rig.0, rig.1, images.0, images.1)]
    CameraSize {
        /// The rig's camera size.
        rig: (u32, u32),
        /// The images' size.
        images: (u32, u32),
    },
    /// The projector's size is unknown.
    #[error("projector: give its resolution with --projector WIDTHxHEIGHT")]
    ProjectorSize,
    /// An option outside what calibration can use ([`limits`]).
    #[error(transparent)]
    Param(#[from] rig::limits::ParamError),
}

/// The board: inner corners across and down, square size, and its markers if it is a ChArUco board.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoardSpec {
    /// Inner corners across.
    pub cols: usize,
    /// Inner corners down.
    pub rows: usize,
    /// Square size, mm.
    pub square_mm: Real,
    /// A ChArUco board's markers (`crate::charuco`); `None`: a plain chessboard.
    pub markers: Option<crate::charuco::CharucoMarkers>,
}

/// Everything [`calibrate_rig`] can be told.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigCalibParams {
    /// What to calibrate.
    pub target: Target,
    /// The board.
    pub board: BoardSpec,
    /// How images are turned before use.
    pub orientation: Orientation,
    /// Which lens terms the camera and projector fits may move.
    pub lens: CameraOptions,
    /// Whether the camera's distortion terms follow from the views (`lens_model`'s rule) or are all
    /// estimated that `lens` does not fix.
    pub lens_model: LensModel,
    /// How high the board's lowest inner corners stand above the platter (mm); `None`: two squares.
    pub corner_height_mm: Option<Real>,
    /// The projector's resolution; `None`: the base rig's projector.
    pub projector_size: Option<(u32, u32)>,
}

/// A rig of just a camera, for a rig file that does not exist yet.
pub fn camera_only(name: &str, camera: PinholeCamera) -> Rig {
    Rig {
        name: name.into(),
        camera,
        projector: None,
        lasers: Vec::new(),
        turntable: None,
        platter_radius_mm: None,
        working_height_mm: None,
        image: Default::default(),
        platform_rotation: None,
    }
}

/// Calibrates from `positions` (see [`load`]), starting from `base` (kept where not calibrated; its
/// camera serves the other steps when the camera is not calibrated too). `progress(what, done,
/// total)` as images are searched and decoded.
pub fn calibrate_rig(
    positions: &[Position],
    base: Option<&Rig>,
    params: &RigCalibParams,
    mut progress: impl FnMut(&str, usize, usize),
) -> Result<(Rig, CalibReport), WorkflowError> {
    calibrate_rig_dyn(positions, base, params, &mut progress)
}

/// [`calibrate_rig`]'s body, compiled once here rather than into every caller's crate.
fn calibrate_rig_dyn(
    positions: &[Position],
    base: Option<&Rig>,
    params: &RigCalibParams,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<(Rig, CalibReport), WorkflowError> {
    params.validate()?;
    let BoardSpec { cols, rows, square_mm, .. } = params.board;
    let board = Board {
        cols,
        rows,
        object: (0..rows)
            .flat_map(|j| (0..cols).map(move |i| Point3::new(i as Real * square_mm, j as Real * square_mm, 0.0)))
            .collect(),
    };
    let turn = params.orientation;
    // The board in every lit frame; all frames of one camera share a size.
    let mut size: Option<(u32, u32, PathBuf)> = None;
    let (mut found, mut missed) = (Vec::new(), Vec::new());
    for (k, p) in positions.iter().enumerate() {
        progress("looking for the board", k + 1, positions.len());
        let img = turn.read(&p.lit)?;
        match &size {
            None => size = Some((img.width, img.height, p.lit.clone())),
            Some((w, h, first)) if (*w, *h) != (img.width, img.height) => {
                return Err(WorkflowError::SizeMismatch {
                    image: p.lit.clone(),
                    size: (img.width, img.height),
                    first: first.clone(),
                    first_size: (*w, *h),
                });
            }
            _ => {}
        }
        let corners = match &params.board.markers {
            Some(m) => crate::charuco::find_charuco(&img, board.cols, board.rows, square_mm, m),
            None => find_board(&Gray::from_image(&img), board.cols, board.rows),
        };
        match corners {
            Ok(b) => found.push(Found { position: p, ids: b.ids, corners: b.pixels, placement: b.placement }),
            Err(e) => missed.push((p.lit.clone(), e.to_string())),
        }
    }
    let Some((width, height, _)) = size else {
        return Err(WorkflowError::NoBoard { cols, rows, images: 0, files: "none".into() });
    };
    if found.is_empty() {
        return Err(WorkflowError::NoBoard {
            cols,
            rows,
            images: positions.len(),
            files: steps::some_files(missed.iter().map(|m| &m.0)),
        });
    }

    let wants = |s: Step| params.target == Target::All || params.target == Target::Only(s);
    let mut report = CalibReport { schema_version: CALIB_REPORT_SCHEMA_VERSION, ..Default::default() };
    let camera = if wants(Step::Camera) {
        let (camera, r) = steps::camera(&found, &board, (width, height), params.lens, params.lens_model)
            .map_err(|e| with_missed(e, &missed))?;
        report.camera = Some(r);
        camera
    } else {
        let step = match params.target {
            Target::Only(s) => s,
            Target::All => Step::Camera,
        };
        let rig = base.ok_or(WorkflowError::NeedsCamera { step })?;
        if (rig.camera.width, rig.camera.height) != (width, height) {
            return Err(WorkflowError::CameraSize {
                rig: (rig.camera.width, rig.camera.height),
                images: (width, height),
            });
        }
        rig.camera
    };
    let mut rig = base.cloned().unwrap_or_else(|| camera_only("calibrated rig", camera));
    rig.camera = camera;
    // The camera was calibrated on the turned frames: processing must turn them the same way.
    rig.image = params.orientation.0;

    // The axis relates views to one another: boards whose corners are known by their numbers.
    let placed = found.iter().filter(|f| f.placement != Placement::Unplaced).count();
    let on_turntable =
        found.iter().filter(|f| f.placement != Placement::Unplaced && f.position.angle_deg.is_some()).count();
    let captured_on_turntable = positions.iter().filter(|p| p.angle_deg.is_some()).count();
    let mut skipped = Vec::new();
    if params.target == Target::All && on_turntable < 3 && captured_on_turntable > 0 {
        // Turntable captures were taken, so the axis was wanted: say why there is none.
        skipped.push(Skipped {
            step: "turntable".into(),
            why: format!(
                "the board was found and placed in {on_turntable} of the {captured_on_turntable} turntable views; the axis needs 3"
            ),
        });
    }
    let mut sweep_poses = vec![None; found.len()];
    if params.target == Target::Only(Step::Turntable) || (params.target == Target::All && on_turntable >= 3) {
        let height = params.corner_height_mm.unwrap_or(2.0 * square_mm);
        let (axis, poses, r) = steps::turntable(&found, &board, &camera, height)?;
        rig.set_turntable(axis);
        sweep_poses = poses;
        report.turntable = Some(r);
    } else if params.target == Target::All
        && captured_on_turntable == 0
        && placed >= 3
        && base.is_some_and(|r| r.turntable.is_some())
    {
        // A turntable scanner's image folder (FabScanPi's sweep): no angles were recorded, but the
        // board turned with the platter. `calibrate turntable` fits the axis to its corners' circles;
        // `all` must not keep the base rig's axis in silence. Hand-held views fit no circles: then the
        // axis is kept, and the report says why.
        let height = params.corner_height_mm.unwrap_or(2.0 * square_mm);
        let fit = steps::turntable(&found, &board, &camera, height);
        let spread = fit.as_ref().ok().and_then(|f| f.2.circle_rms_mm);
        match fit {
            Ok((axis, poses, r)) if spread.is_some_and(|s| s <= plausible::MAX_SPREAD_MM) => {
                rig.set_turntable(axis);
                sweep_poses = poses;
                report.turntable = Some(r);
            }
            other => skipped.push(Skipped {
                step: "turntable".into(),
                why: format!(
                    "the captures record no turntable angles and the board's corners fit no turn about one axis \
                     ({}): the axis was kept from the base rig",
                    match other {
                        Err(e) => e.to_string(),
                        Ok(_) => format!("{:.2} mm RMS off circles", spread.unwrap_or(f64::NAN)),
                    }
                ),
            }),
        }
    }
    let has_lasers = found.iter().any(|f| !f.position.lasers.is_empty());
    if params.target == Target::Only(Step::Laser) || (params.target == Target::All && has_lasers) {
        let (planes, r) = steps::lasers(&found, &board, &camera, &sweep_poses, turn)?;
        for (i, plane) in planes.into_iter().enumerate() {
            match rig.lasers.get_mut(i) {
                Some(l) => l.plane = plane,
                None => rig.lasers.push(Laser { name: format!("laser {i}"), plane, colour: Default::default() }),
            }
        }
        report.lasers = Some(r);
    }
    let has_structured = found.iter().any(|f| !f.position.structured.is_empty());
    if params.target == Target::Only(Step::Projector) || (params.target == Target::All && has_structured) {
        let size = params
            .projector_size
            .or_else(|| base.and_then(|r| r.projector.as_ref()).map(|p| (p.lens.width, p.lens.height)))
            .ok_or(WorkflowError::ProjectorSize)?;
        let (lens, from_camera, r) =
            steps::projector(&found, &board, &camera, size, turn, (params.lens, params.lens_model), |d, t| {
                progress("decoding structured light", d, t)
            })?;
        let gamma = rig.projector.as_ref().map_or(1.0, |p| p.gamma);
        rig.projector = Some(Projector { lens, from_camera, gamma });
        report.projector = Some(r);
    }
    report.not_found = missed.iter().map(|(f, why)| NotFound { image: f.clone(), why: why.clone() }).collect();
    let partial = found.iter().filter(|f| f.placement != Placement::Whole).count();
    report.board_found = BoardFound { found: found.len(), of: positions.len(), partial };
    report.board = BoardReport {
        cols,
        rows,
        square_mm,
        charuco: params.board.markers.map(|m| format!("markers {} mm, dictionary {}", m.marker_mm, m.dictionary)),
    };
    report.skipped = skipped;
    report.warnings = plausible::findings(&rig, &report);
    Ok((rig, report))
}

/// A camera step's failure, with the images where the board was not found named: the usual cause.
fn with_missed(e: WorkflowError, missed: &[(PathBuf, String)]) -> WorkflowError {
    match e {
        WorkflowError::Step { step, source, files } if !missed.is_empty() => {
            let names: Vec<String> = missed.iter().take(5).map(|(f, why)| format!("{}: {why}", f.display())).collect();
            WorkflowError::Step {
                step,
                source,
                files: format!("{files}; the board was not found in {} image(s): {}", missed.len(), names.join("; ")),
            }
        }
        e => e,
    }
}
