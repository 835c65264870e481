//! The calibrations as `scanrig calibrate` runs them (`calib::calibrate_rig`): `calibrate_camera`
//! (Zhang's method on chessboard views) and `calibrate_rig` (camera, projector by its Gray codes,
//! laser planes, turntable axis — whatever the captures hold). A result the plausibility checks
//! refuse raises `StageError` unless `force`, as the command line fails.

use crate::errors;
use crate::run::interruptible;
use crate::stages::report;
use calib::workflow::{Orientation, Step, Target};
use calib::{BoardSpec, CameraOptions, RigCalibParams};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rig::Rig;
use std::path::PathBuf;

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(calibrate_camera, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate_rig, m)?)?;
    Ok(())
}

/// A board as Python gives it: a chessboard's inner corners `(columns, rows)`, or a ChArUco board's
/// description `"charuco:11x9:square=10:marker=7:dict=4x4_50"` (as the command line's `--board`).
#[derive(FromPyObject)]
enum Board {
    Corners((u32, u32)),
    Described(String),
}

/// The options every calibration shares, as the command line's flags.
struct Options {
    board: Board,
    square: f64,
    rig: Option<PathBuf>,
    out: Option<PathBuf>,
    projector: Option<(u32, u32)>,
    lens: CameraOptions,
    lens_model: String,
    corner_height: Option<f64>,
    force: bool,
}

fn run<'py>(py: Python<'py>, captures: PathBuf, target: Target, o: Options) -> PyResult<(String, Bound<'py, PyAny>)> {
    let (cols, rows, charuco) = match &o.board {
        Board::Corners((c, r)) if *c < 2 || *r < 2 => {
            return Err(PyValueError::new_err(format!(
                "board: inner corners (columns, rows), at least 2×2, got {c}×{r}"
            )));
        }
        Board::Corners((c, r)) => (*c, *r, None),
        Board::Described(text) => {
            let (c, r, square, markers) =
                calib::charuco::parse(text).map_err(|e| PyValueError::new_err(format!("board: {e}")))?;
            (c, r, Some((square, markers)))
        }
    };
    let lens_model = match o.lens_model.as_str() {
        "auto" => calib::LensModel::Auto,
        "full" => calib::LensModel::Full,
        other => {
            return Err(PyValueError::new_err(format!(
                "lens_model must be \"auto\" (the terms the views support) or \"full\", got {other:?}"
            )));
        }
    };
    if !(o.square > 0.0 && o.square.is_finite()) {
        return Err(PyValueError::new_err(format!("square must be a positive length in mm, got {}", o.square)));
    }
    // The base rig: the one given, else the output being updated, else the captures' own (as the
    // command line looks for it).
    let base_path =
        [o.rig.clone(), o.out.clone(), Some(captures.join("rig.toml"))].into_iter().flatten().find(|p| p.is_file());
    let base = base_path.as_deref().map(Rig::read).transpose().map_err(errors::file)?;
    let orientation = Orientation(base.as_ref().map(|r| r.image).unwrap_or_default());
    let projector_size = o.projector.or_else(|| {
        // Pose folders of Gray codes say their projector's size by their image count.
        let inferred = calib::workflow::captures::pose_layout_projector(&captures);
        inferred.filter(|_| base.as_ref().is_none_or(|r| r.projector.is_none()))
    });
    let params = RigCalibParams {
        target,
        board: BoardSpec {
            cols: cols as usize,
            rows: rows as usize,
            square_mm: charuco.map_or(o.square, |c| c.0),
            markers: charuco.map(|c| c.1),
        },
        orientation,
        lens: o.lens,
        lens_model,
        corner_height_mm: o.corner_height,
        projector_size,
    };
    let (rig, mut r) = interruptible(py, move || {
        let positions = calib::workflow::load(&captures, params.orientation, params.projector_size, |_, _| {})?;
        calib::calibrate_rig(&positions, base.as_ref(), &params, |_, _, _| {})
    })?
    .map_err(errors::stage)?;
    let warnings = &r.warnings;
    if !warnings.is_empty() && !o.force {
        return Err(errors::StageError::new_err(format!(
            "the calibration cannot be right: {}; fix the captures or the options, or give force=True to take it anyway",
            warnings.join("; ")
        )));
    }
    if let Some(out) = &o.out {
        rig.write(out).map_err(errors::file)?;
        r.rig = Some(out.clone());
    }
    Ok((rig.to_toml_string(), report(py, &r)?))
}

fn lens(fix_aspect_ratio: bool, fix_principal_point: bool, zero_tangential: bool, fix_k3: bool) -> CameraOptions {
    CameraOptions { fix_aspect_ratio, fix_principal_point, zero_tangential, fix_k3 }
}

/// Calibrates the camera from chessboard captures (a scan-style capture folder, pose folders, or a
/// folder of images): corners, Zhang's closed form, then Levenberg–Marquardt on the reprojection
/// error with distortion [k1, k2, p1, p2, k3]. `board` counts inner corners. Returns (rig TOML text,
/// report dict as `NAME.report.json`); with `out`, the rig file is written (merged into it).
/// `lens_model`: "auto" estimates the distortion terms the views support (the report's
/// `camera.model` says which and why), "full" every term not fixed.
#[pyfunction]
#[pyo3(signature = (captures, *, board=Board::Corners((9, 6)), square=15.0, out=None, rig=None, fix_aspect_ratio=false, fix_principal_point=false, zero_tangential=false, fix_k3=false, lens_model="auto".to_string(), force=false))]
#[allow(clippy::too_many_arguments)]
fn calibrate_camera<'py>(
    py: Python<'py>,
    captures: PathBuf,
    board: Board,
    square: f64,
    out: Option<PathBuf>,
    rig: Option<PathBuf>,
    fix_aspect_ratio: bool,
    fix_principal_point: bool,
    zero_tangential: bool,
    fix_k3: bool,
    lens_model: String,
    force: bool,
) -> PyResult<(String, Bound<'py, PyAny>)> {
    let o = Options {
        board,
        square,
        rig,
        out,
        projector: None,
        lens: lens(fix_aspect_ratio, fix_principal_point, zero_tangential, fix_k3),
        lens_model,
        corner_height: None,
        force,
    };
    run(py, captures, Target::Only(Step::Camera), o)
}

/// Calibrates the whole rig the captures hold: the camera, then the projector from its Gray codes
/// on the board (a second camera, stereo), the laser planes from the lines on the board, and the
/// turntable axis from the board turned on the platter. Returns (rig TOML text, report dict); with
/// `out`, the rig file is written.
#[pyfunction]
#[pyo3(signature = (captures, *, board=Board::Corners((9, 6)), square=15.0, out=None, rig=None, projector=None, corner_height=None, fix_aspect_ratio=false, fix_principal_point=false, zero_tangential=false, fix_k3=false, lens_model="auto".to_string(), force=false))]
#[allow(clippy::too_many_arguments)]
fn calibrate_rig<'py>(
    py: Python<'py>,
    captures: PathBuf,
    board: Board,
    square: f64,
    out: Option<PathBuf>,
    rig: Option<PathBuf>,
    projector: Option<(u32, u32)>,
    corner_height: Option<f64>,
    fix_aspect_ratio: bool,
    fix_principal_point: bool,
    zero_tangential: bool,
    fix_k3: bool,
    lens_model: String,
    force: bool,
) -> PyResult<(String, Bound<'py, PyAny>)> {
    let o = Options {
        board,
        square,
        rig,
        out,
        projector,
        lens: lens(fix_aspect_ratio, fix_principal_point, zero_tangential, fix_k3),
        lens_model,
        corner_height,
        force,
    };
    run(py, captures, Target::All, o)
}
