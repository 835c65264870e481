//! From frames to a range grid, and frames from the simulator: `simulate_view` (a view's frames in
//! memory, with the truth), `simulate_scan` (a scan folder, as `scanrig sim`), `decode` (Gray code
//! and phase shift into a projector map, as `scanrig decode`) and `triangulate` (a map into a range
//! grid through the rig, eq. 2.3) and `laser_line` (a laser frame into its line's points, as
//! `scanrig process` makes a laser view).

use crate::errors;
use crate::grids::grid_out;
use crate::run::interruptible;
use crate::stages::report;
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray3, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use rig::image::Image8;
use rig::{Method, Pattern};
use std::path::{Path, PathBuf};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(simulate_view, m)?)?;
    m.add_function(wrap_pyfunction!(simulate_scan, m)?)?;
    m.add_function(wrap_pyfunction!(decode, m)?)?;
    m.add_function(wrap_pyfunction!(triangulate, m)?)?;
    m.add_function(wrap_pyfunction!(laser_line, m)?)?;
    Ok(())
}

/// The simulator's world as `scanrig sim` builds it from its options: the named built-in config (or a
/// TOML file), its resolution and view count, and the object on its platter.
struct World {
    cfg: sim::SimConfig,
    object: rig::TriMesh,
    albedo: sim::Albedo,
}

#[allow(clippy::too_many_arguments)]
fn world(
    config: &str,
    resolution: Option<(u32, u32)>,
    views: Option<u32>,
    mesh: Option<&Path>,
    size: Option<f64>,
    up: &str,
    noiseless: bool,
) -> PyResult<World> {
    let mut cfg = match sim::SimConfig::builtin(config) {
        Some(c) => c,
        None => sim::SimConfig::read(Path::new(config)).map_err(|e| {
            let names: Vec<&str> = sim::config::BUILTIN.iter().map(|(n, _)| *n).collect();
            errors::ScanrigError::new_err(format!("config: {e} (the built-in configs are {})", names.join(", ")))
        })?,
    };
    if let Some((w, h)) = resolution {
        if w < 16 || h < 16 || w > 16384 || h > 16384 {
            return Err(PyValueError::new_err(format!("resolution: 16 to 16384 pixels a side, got {w}×{h}")));
        }
        cfg = cfg.with_camera_resolution(w, h);
    }
    if let Some(v) = views {
        // The command line's check (`scanrig sim --views`).
        if !(1..=3600).contains(&v) {
            return Err(PyValueError::new_err(format!("views must be 1 to 3600, got {v}")));
        }
        cfg.scan.views = v;
    }
    if noiseless {
        cfg.sensor.full_well_e = 0.0;
    }
    let up = match up {
        "y" => sim::UpAxis::Y,
        "z" => sim::UpAxis::Z,
        other => return Err(PyValueError::new_err(format!("up must be \"y\" or \"z\", got {other:?}"))),
    };
    let size = size.unwrap_or(cfg.scene.object_size_mm);
    if !(size > 0.0 && size.is_finite()) {
        return Err(PyValueError::new_err(format!("size must be a positive length in mm, got {size}")));
    }
    let (object, albedo) = sim::object_on_platter(&cfg, mesh, size, up, rig::Vector3::zeros()).map_err(errors::file)?;
    Ok(World { cfg, object, albedo })
}

fn method_of(method: Option<&str>, cfg: &sim::SimConfig) -> PyResult<Method> {
    Ok(match method {
        Some("structured-light") => Method::StructuredLight,
        Some("laser") => Method::Laser,
        None if cfg.rig.projector.is_some() => Method::StructuredLight,
        None => Method::Laser,
        Some(other) => {
            return Err(PyValueError::new_err(format!(
                "method must be \"structured-light\" or \"laser\", got {other:?}"
            )));
        }
    })
}

/// An image as an array: H×W for grey, H×W×3 for colour.
pub fn image_out<'py>(py: Python<'py>, img: Image8) -> Bound<'py, PyAny> {
    let (w, h) = (img.width as usize, img.height as usize);
    match img.channels {
        1 => Array2::from_shape_vec((h, w), img.data).expect("h×w").into_pyarray(py).into_any(),
        c => Array3::from_shape_vec((h, w, c as usize), img.data).expect("h×w×c").into_pyarray(py).into_any(),
    }
}

/// An image argument: H×W (grey) or H×W×3 (RGB) uint8.
pub fn image_in(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Image8> {
    if let Ok(a) = obj.extract::<PyReadonlyArray2<'_, u8>>() {
        let s = a.shape();
        return Ok(Image8::gray(s[1] as u32, s[0] as u32, a.as_array().iter().copied().collect()));
    }
    if let Ok(a) = obj.extract::<PyReadonlyArray3<'_, u8>>() {
        let s = a.shape();
        if s[2] != 3 {
            return Err(PyValueError::new_err(format!("{name}: expected H×W or H×W×3, got shape {s:?}")));
        }
        let data = a.as_array().iter().copied().collect();
        return Ok(Image8 { width: s[1] as u32, height: s[0] as u32, channels: 3, data });
    }
    Err(PyTypeError::new_err(format!("{name}: expected a numpy array of uint8, H×W (grey) or H×W×3 (RGB)")))
}

/// Renders one view of the simulated rig at turntable angle `angle_deg` without writing anything.
/// Returns a dict: frames (list of H×W uint8), patterns (list of dicts, as in a manifest), rig (the
/// rig's TOML text, exact), truth (points H×W×3 in the camera frame, mm, NaN where no surface; object
/// H×W bool; projector H×W×2, NaN where unlit).
#[pyfunction]
#[pyo3(signature = (angle_deg=0.0, *, config="structured-light", method=None, resolution=None, mesh=None, size=None, up="y", seed=1, view=0, noiseless=false))]
#[allow(clippy::too_many_arguments)]
fn simulate_view<'py>(
    py: Python<'py>,
    angle_deg: f64,
    config: &str,
    method: Option<&str>,
    resolution: Option<(u32, u32)>,
    mesh: Option<PathBuf>,
    size: Option<f64>,
    up: &str,
    seed: u64,
    view: usize,
    noiseless: bool,
) -> PyResult<Bound<'py, PyDict>> {
    if !angle_deg.is_finite() {
        return Err(PyValueError::new_err(format!("angle_deg must be a finite angle, got {angle_deg}")));
    }
    let w = world(config, resolution, None, mesh.as_deref(), size, up, noiseless)?;
    let method = method_of(method, &w.cfg)?;
    let rig_text = w.cfg.rig.to_toml_string();
    let simulated = interruptible(py, move || {
        let scene = sim::Scene::on_turntable(&w.cfg, &w.object, w.albedo);
        sim::scan::simulate_view(&w.cfg, &scene, method, angle_deg, seed, view)
    })?
    .map_err(errors::stage)?;
    let g = &simulated.geometry;
    let (width, height) = (g.width, g.height);
    let d = PyDict::new(py);
    let frames = PyList::empty(py);
    for f in simulated.frames {
        frames.append(image_out(py, f))?;
    }
    d.set_item("frames", frames)?;
    d.set_item("patterns", report(py, &simulated.patterns)?)?;
    d.set_item("rig", rig_text)?;
    let truth = PyDict::new(py);
    let points: Vec<f64> = g.point.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    truth.set_item("points", Array3::from_shape_vec((height, width, 3), points).expect("h×w×3").into_pyarray(py))?;
    let object: Vec<bool> = g.kind.iter().map(|&k| k == sim::PartKind::Object as u8).collect();
    truth.set_item("object", Array2::from_shape_vec((height, width), object).expect("h×w").into_pyarray(py))?;
    let projector: Vec<f64> = g.projector.iter().flat_map(|p| [p.x, p.y]).collect();
    truth.set_item(
        "projector",
        Array3::from_shape_vec((height, width, 2), projector).expect("h×w×2").into_pyarray(py),
    )?;
    d.set_item("truth", truth)?;
    Ok(d)
}

/// Simulates a turntable scan into the folder `out` as `scanrig sim` does (frames, manifest, rig.toml,
/// truth/), resuming a half-written one. Returns the report.
#[pyfunction]
#[pyo3(signature = (out, *, config="structured-light", method=None, views=None, resolution=None, mesh=None, size=None, up="y", seed=1, noiseless=false, truth=true, passes=1))]
#[allow(clippy::too_many_arguments)]
fn simulate_scan<'py>(
    py: Python<'py>,
    out: PathBuf,
    config: &str,
    method: Option<&str>,
    views: Option<u32>,
    resolution: Option<(u32, u32)>,
    mesh: Option<PathBuf>,
    size: Option<f64>,
    up: &str,
    seed: u64,
    noiseless: bool,
    truth: bool,
    passes: u32,
) -> PyResult<Bound<'py, PyAny>> {
    if !(1..=rig::scan_folder::MAX_PASSES).contains(&passes) {
        return Err(PyValueError::new_err(format!(
            "passes must be 1 to {}, got {passes}",
            rig::scan_folder::MAX_PASSES
        )));
    }
    let w = world(config, resolution, views, mesh.as_deref(), size, up, noiseless)?;
    let method = method_of(method, &w.cfg)?;
    rig::memory::check(sim::scan::memory_estimate(&w.cfg), "simulating these views", "choose a smaller resolution")
        .map_err(|e| errors::ScanrigError::new_err(e.to_string()))?;
    let opts = sim::ScanOptions { method, seed, truth };
    let r = interruptible(py, move || {
        // Each pass the object turned over as `scanrig sim --passes` turns it.
        let scenes = sim::scan::pass_scenes(&w.cfg, &w.object, &w.albedo, passes);
        let passes: Vec<sim::SimPass> =
            scenes.iter().map(|(scene, motion)| sim::SimPass { scene, motion: *motion }).collect();
        sim::simulate_passes(&w.cfg, &passes, Some(&w.object), opts, &out, |_, _| {})
            .map_err(|e| format!("simulating into {}: {e}", out.display()))
    })?
    .map_err(errors::ScanrigError::new_err)?;
    report(py, &r)
}

/// The capture program of `patterns`: a list of dicts as `simulate_view` and manifests give them.
fn patterns_in(py: Python<'_>, patterns: &Bound<'_, PyAny>) -> PyResult<Vec<Pattern>> {
    let text: String = py.import("json")?.call_method1("dumps", (patterns,))?.extract()?;
    serde_json::from_str(&text).map_err(|e| {
        PyValueError::new_err(format!(
            "patterns: {e} (a list of dicts such as {{\"kind\": \"gray\", \"axis\": \"columns\", \"bit\": 0, \"bits\": 10, \
             \"inverse\": false}}, as simulate_view gives)"
        ))
    })
}

/// Decodes one view's structured-light frames (Gray code with inverses, white and black, N-step phase
/// shift where present) into a projector map: H×W×3 float64 of projector column u, row v (NaN where
/// not decoded) and confidence, the layout of `scanrig decode`'s .npy. `frames` is a list of H×W
/// uint8 images; `patterns` says what each shows (default: OpenCV's GrayCodePattern order for a
/// projector of `projector` = (width, height), white and black last). Returns (map, report).
#[pyfunction]
#[pyo3(signature = (frames, *, projector, patterns=None, shadow_threshold=None, bit_threshold=None, gray_fit_radius=None))]
#[allow(clippy::too_many_arguments)]
fn decode<'py>(
    py: Python<'py>,
    frames: &Bound<'py, PyAny>,
    projector: (u32, u32),
    patterns: Option<&Bound<'py, PyAny>>,
    shadow_threshold: Option<f64>,
    bit_threshold: Option<u8>,
    gray_fit_radius: Option<usize>,
) -> PyResult<(Bound<'py, PyArray3<f64>>, Bound<'py, PyAny>)> {
    let list = frames
        .cast::<PyList>()
        .map_err(|_| PyTypeError::new_err("frames: expected a list of H×W uint8 numpy arrays"))?;
    let images: Vec<Image8> = list
        .iter()
        .enumerate()
        .map(|(k, f)| image_in(&f, &format!("frames[{k}]")).map(|i| i.to_gray()))
        .collect::<PyResult<_>>()?;
    let (pw, ph) = projector;
    if pw < 2 || ph < 2 {
        return Err(PyValueError::new_err(format!("projector: (width, height) in pixels, got {pw}×{ph}")));
    }
    let order = match patterns.filter(|p| !p.is_none()) {
        Some(p) => patterns_in(py, p)?,
        None => rig::gray_code_folders::opencv_order(pw, ph),
    };
    if order.len() != images.len() {
        return Err(PyValueError::new_err(format!(
            "frames: {} images, but the patterns name {} (OpenCV's order for a {pw}×{ph} projector: {} Gray-code \
             pairs, then white and black)",
            images.len(),
            order.len(),
            (rig::gray_code_folders::opencv_order(pw, ph).len() - 2) / 2
        )));
    }
    let d = ::process::DecodeParams::default();
    let params = ::process::DecodeParams {
        shadow_threshold: shadow_threshold.unwrap_or(d.shadow_threshold),
        bit_threshold: bit_threshold.unwrap_or(d.bit_threshold),
        gray_fit_radius: gray_fit_radius.unwrap_or(d.gray_fit_radius),
        ..d
    };
    // Checked by the library (`DecodeParams::validate`, the first thing decoding does).
    let (map, r) = interruptible(py, move || {
        let frames: Vec<(Pattern, &Image8)> = order.iter().copied().zip(images.iter()).collect();
        ::process::pipeline::stages::decode(&frames, (pw, ph), &params)
    })?
    .map_err(errors::stage)?;
    let a = map.to_npy();
    let data = a.to_f64();
    let out = Array3::from_shape_vec((map.height, map.width, 3), data).expect("h×w×3");
    Ok((out.into_pyarray(py), report(py, &r)?))
}

/// Triangulates a projector map (as `decode` gives) through the rig file `rig` (camera and projector
/// calibration): the camera ray against the projector's column surface, or the projector ray where
/// rows are decoded (eq. 2.3, least squares), then grid normals. Returns (grid dict in the camera
/// frame, mm; report) — `scanrig decode --rig R --out X.ply` writes the same grid.
#[pyfunction]
fn triangulate<'py>(
    py: Python<'py>,
    map: &Bound<'py, PyAny>,
    rig: PathBuf,
) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyAny>)> {
    let a: PyReadonlyArray3<'_, f64> = map
        .extract()
        .map_err(|_| PyTypeError::new_err("map: expected an H×W×3 numpy array of float64 (u, v, confidence)"))?;
    let s = a.shape().to_vec();
    if s[2] != 3 {
        return Err(PyValueError::new_err(format!("map: expected H×W×3 (u, v, confidence), got shape {s:?}")));
    }
    let npy =
        rig::npy::NpyArray { shape: s.clone(), data: rig::npy::NpyData::F64(a.as_array().iter().copied().collect()) };
    let map = ::process::ProjectorMap::from_npy(&npy).expect("H×W×3 checked");
    let r = rig::Rig::read(&rig).map_err(errors::file)?;
    let Some(projector) = r.projector else {
        return Err(errors::FileError::new_err(format!(
            "{} has no [projector]: triangulating Gray codes needs the projector's calibration",
            rig.display()
        )));
    };
    let (grid, report_) = interruptible(py, move || {
        let tri = ::process::triangulate::Triangulator::new(&r.camera, &projector);
        ::process::pipeline::stages::triangulate(
            &map,
            &tri,
            &::process::triangulate::TriangulateParams::default(),
            ::process::ProcessParams::default().normal_max_jump_mm,
        )
    })?
    .map_err(errors::stage)?;
    Ok((grid_out(py, grid)?, report(py, &report_)?))
}

/// One laser's line in one view, as `scanrig process` makes a laser view
/// (`views/view_NNN_laserK.ply`): the line's centre in each row of `frame` (H×W or H×W×3 uint8, as
/// stored: turned here as the rig's `[image]` says) in the laser's colour, searched within the rig's
/// working volume, each camera ray through one against laser `laser`'s plane (eq. 2.3). `off` is the
/// same view with every laser off (none: the background is estimated from the frame), `texture` the
/// view's colour frame. Returns (dict of points N×3 mm in the camera frame, pixels N×2, confidence N,
/// colors N×3 uint8 or None; report).
#[pyfunction]
#[pyo3(signature = (frame, rig, *, laser=0, off=None, texture=None, force=false))]
fn laser_line<'py>(
    py: Python<'py>,
    frame: &Bound<'py, PyAny>,
    rig: PathBuf,
    laser: usize,
    off: Option<&Bound<'py, PyAny>>,
    texture: Option<&Bound<'py, PyAny>>,
    force: bool,
) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyAny>)> {
    let r = rig::Rig::read(&rig).map_err(errors::file)?;
    if laser >= r.lasers.len() {
        return Err(PyValueError::new_err(format!(
            "laser: {laser}, but {} has {} [[lasers]] (0-based)",
            rig.display(),
            r.lasers.len()
        )));
    }
    // As `process` reads a scan's frames: turned as the rig's [image] says.
    let turn = |i: Image8| if r.image.is_identity() { i } else { i.transformed(&r.image) };
    let on = turn(image_in(frame, "frame")?);
    let off = off.filter(|o| !o.is_none()).map(|o| image_in(o, "off")).transpose()?.map(turn);
    let texture = texture.filter(|t| !t.is_none()).map(|t| image_in(t, "texture")).transpose()?.map(turn);
    let params = ::process::pipeline::ProcessParams::default().laser;
    let (line, rep, warnings) = interruptible(py, move || {
        use ::process::pipeline::stages;
        // Where the line is searched, and what that warns of (a rig without a working volume is
        // searched whole): said as a UserWarning, as `process` says it in its report.
        let (windows, warnings) = stages::laser_windows(&r, &r.lasers[laser], &params, force)?;
        let (texture, misfit) = stages::fitting_texture(texture.as_ref(), &r.camera);
        let frames = stages::LaserFrames { on: &on, off: off.as_ref(), texture };
        let warnings: Vec<String> = warnings.into_iter().chain(misfit.map(|w| format!("texture: {w}"))).collect();
        stages::laser_line(&frames, &r.camera, (laser, &r.lasers[laser]), windows.as_ref(), &params)
            .map(|(line, rep)| (line, rep, warnings))
    })?
    .map_err(errors::stage_as(&["force"]))?;
    errors::warn_each_as(py, &warnings, &["force"])?;
    let d = PyDict::new(py);
    let pixels: Vec<f32> = line.pixels.iter().flatten().copied().collect();
    let n = line.points.len();
    d.set_item("pixels", Array2::from_shape_vec((n, 2), pixels).expect("n×2").into_pyarray(py))?;
    d.set_item("confidence", crate::arrays::vec_out(py, line.confidence))?;
    d.set_item("colors", line.colors.map(|c| crate::arrays::colors_out(py, c)))?;
    d.set_item("points", crate::arrays::points_out(py, line.points))?;
    Ok((d, report(py, &rep)?))
}
