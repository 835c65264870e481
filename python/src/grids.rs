//! Range grids as arrays — H×W×3 float64 positions with NaN where the sensor saw nothing, the sensor
//! as ("center", xyz) or ("direction", xyz) — and the non-local denoising of ch. 4 on them.

use crate::arrays;
use crate::errors;
use crate::run::interruptible;
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use rig::RangeGrid;
use rig::math::{Point3, UnitVector3, Vector3};
use rig::range_grid::Sensor;
use std::path::PathBuf;

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(read_range_grid, m)?)?;
    m.add_function(wrap_pyfunction!(denoise, m)?)?;
    m.add_function(wrap_pyfunction!(register_views, m)?)?;
    Ok(())
}

/// A grid as a dict: points (H×W×3, NaN holes), normals (H×W×3 or None), confidence (H×W float32 or
/// None), sensor.
pub fn grid_out<'py>(py: Python<'py>, g: RangeGrid) -> PyResult<Bound<'py, PyDict>> {
    let (w, h) = (g.width, g.height);
    let cube = |v: Vec<f64>| Array3::from_shape_vec((h, w, 3), v).expect("h×w×3").into_pyarray(py);
    let d = PyDict::new(py);
    let points: Vec<f64> = (0..w * h)
        .flat_map(|i| if g.valid[i] { [g.points[i].x, g.points[i].y, g.points[i].z] } else { [f64::NAN; 3] })
        .collect();
    d.set_item("points", cube(points))?;
    d.set_item("normals", g.normals.map(|n| cube(n.iter().flat_map(|v| [v.x, v.y, v.z]).collect())))?;
    d.set_item("confidence", g.confidence.map(|c| Array2::from_shape_vec((h, w), c).expect("h×w").into_pyarray(py)))?;
    let sensor = match g.sensor {
        Sensor::Center(c) => ("center", vec![c.x, c.y, c.z]),
        Sensor::Direction(v) => ("direction", vec![v.x, v.y, v.z]),
        Sensor::PerCell(_) => ("per_cell", Vec::new()),
    };
    d.set_item("sensor", (sensor.0, arrays::vec_out(py, sensor.1)))?;
    Ok(d)
}

/// A grid from a dict as [`read_range_grid`] gives (points required; normals, confidence and sensor
/// optional, the sensor defaulting to a camera at the origin).
pub fn grid_in(d: &Bound<'_, PyAny>, name: &str) -> PyResult<RangeGrid> {
    let item = |k: &str| -> PyResult<Option<Bound<'_, PyAny>>> { Ok(d.get_item(k).ok().filter(|v| !v.is_none())) };
    let points = item("points")?.ok_or_else(|| PyValueError::new_err(format!("{name}: no \"points\"")))?;
    let p: PyReadonlyArray3<'_, f64> = points
        .extract()
        .map_err(|_| PyTypeError::new_err(format!("{name}[\"points\"]: expected an H×W×3 numpy array of float64")))?;
    let s = p.shape();
    if s[2] != 3 || s[0] == 0 || s[1] == 0 {
        return Err(PyValueError::new_err(format!("{name}[\"points\"]: expected H×W×3, got {s:?}")));
    }
    let (h, w) = (s[0], s[1]);
    let sensor = match item("sensor")? {
        None => Sensor::Center(Point3::origin()),
        Some(v) => {
            let (kind, xyz): (String, Vec<f64>) = v.extract().map_err(|_| {
                PyTypeError::new_err(format!("{name}[\"sensor\"]: expected (\"center\" or \"direction\", [x, y, z])"))
            })?;
            let xyz: [f64; 3] =
                xyz.try_into().map_err(|_| PyValueError::new_err(format!("{name}[\"sensor\"]: 3 numbers")))?;
            match kind.as_str() {
                "center" => Sensor::Center(Point3::from(xyz)),
                "direction" => Sensor::Direction(
                    UnitVector3::try_new(Vector3::from(xyz), 1e-12)
                        .ok_or_else(|| PyValueError::new_err(format!("{name}[\"sensor\"]: a zero direction")))?,
                ),
                other => {
                    return Err(PyValueError::new_err(format!(
                        "{name}[\"sensor\"]: \"center\" or \"direction\", got {other:?}"
                    )));
                }
            }
        }
    };
    let mut g = RangeGrid::empty(w, h, sensor);
    let a = p.as_array();
    for r in 0..h {
        for c in 0..w {
            let q = Point3::new(a[(r, c, 0)], a[(r, c, 1)], a[(r, c, 2)]);
            if q.iter().all(|v| v.is_finite()) {
                g.points[r * w + c] = q;
                g.valid[r * w + c] = true;
            }
        }
    }
    if let Some(n) = item("normals")? {
        let n: PyReadonlyArray3<'_, f64> = n.extract().map_err(|_| {
            PyTypeError::new_err(format!("{name}[\"normals\"]: expected an H×W×3 numpy array of float64"))
        })?;
        if n.shape() != s {
            return Err(PyValueError::new_err(format!("{name}[\"normals\"]: shape {:?}, points {s:?}", n.shape())));
        }
        let n = n.as_array();
        g.normals = Some(
            (0..h * w)
                .map(|i| Vector3::new(n[(i / w, i % w, 0)], n[(i / w, i % w, 1)], n[(i / w, i % w, 2)]))
                .collect(),
        );
    }
    if let Some(c) = item("confidence")? {
        let c: numpy::PyReadonlyArray2<'_, f32> = c.extract().map_err(|_| {
            PyTypeError::new_err(format!("{name}[\"confidence\"]: expected an H×W numpy array of float32"))
        })?;
        if c.shape() != [h, w] {
            return Err(PyValueError::new_err(format!("{name}[\"confidence\"]: shape {:?}, grid {h}×{w}", c.shape())));
        }
        g.confidence = Some(c.as_array().iter().copied().collect());
    }
    Ok(g)
}

/// Reads a range grid (PLY with grid_col/grid_row or a range_grid element, as scanrig and the
/// Stanford scans write them), with the data's "units" as `read_cloud` gives them.
#[pyfunction]
fn read_range_grid(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyDict>> {
    let g = py.detach(|| rig::ply::read_range_grid(&path)).map_err(errors::file)?;
    let d = grid_out(py, g)?;
    d.set_item("units", rig::data_units(&path).map_err(errors::file)?)?;
    Ok(d)
}

/// Non-local denoising of a range grid (thesis ch. 4): each valid cell moved along its line of sight
/// by the weighted mean of its neighbours' offsets, weighted by patch similarity. `frames` is one
/// grid dict or a list of them (a sequence); `current` picks the frame to filter and `temporal` how
/// many frames either side join its neighbourhoods (the time-varying filter). Returns (grid, report).
#[pyfunction]
#[pyo3(signature = (frames, *, current=0, temporal=0))]
fn denoise<'py>(
    py: Python<'py>,
    frames: &Bound<'py, PyAny>,
    current: usize,
    temporal: usize,
) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyAny>)> {
    let grids: Vec<RangeGrid> = match frames.cast::<PyList>() {
        Ok(list) => {
            list.iter().enumerate().map(|(k, f)| grid_in(&f, &format!("frames[{k}]"))).collect::<PyResult<_>>()?
        }
        Err(_) => vec![grid_in(frames, "frames")?],
    };
    if current >= grids.len() {
        return Err(PyValueError::new_err(format!("current = {current}, but {} frames were given", grids.len())));
    }
    // The command line's check (`scanrig denoise --temporal`).
    if temporal > grids.len() {
        return Err(PyValueError::new_err(format!(
            "temporal = {temporal} reaches past the {} frames given",
            grids.len()
        )));
    }
    let params = ::process::pipeline::stages::DenoiseStage::default();
    let (clean, r) =
        interruptible(py, move || ::process::pipeline::stages::denoise(&grids, current, temporal, &params))?
            .map_err(errors::stage)?;
    Ok((grid_out(py, clean)?, crate::stages::report(py, &r)?))
}

/// Multi-view registration of a turntable scan's range grids (thesis ch. 2.2): each grid (camera
/// frame, mm) placed by the turntable pose of its angle, the poses refined by multi-view ICP, the
/// views cropped to the object (above the platter, inside its radius) and merged. `rig` is the rig
/// file (its turntable axis). A correction beyond the tolerance a turntable can be off raises
/// `StageError` unless `force` (then that view keeps its turntable pose). Returns (cloud dict in the
/// object frame, poses as a list of dicts with their 4×4 `object_from_camera`, report).
#[pyfunction(name = "register")]
#[pyo3(signature = (grids, angles_deg, rig, *, force=false))]
fn register_views<'py>(
    py: Python<'py>,
    grids: &Bound<'py, PyAny>,
    angles_deg: Vec<f64>,
    rig: PathBuf,
    force: bool,
) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    use ::process::merge::views::ViewGrid;
    use ::process::pipeline::stages;
    let list = grids.cast::<PyList>().map_err(|_| PyTypeError::new_err("grids: expected a list of grid dicts"))?;
    let grids: Vec<RangeGrid> =
        list.iter().enumerate().map(|(k, g)| grid_in(&g, &format!("grids[{k}]"))).collect::<PyResult<_>>()?;
    if angles_deg.len() != grids.len() {
        return Err(PyValueError::new_err(format!(
            "angles_deg: {} angles for {} grids (one turntable angle per view)",
            angles_deg.len(),
            grids.len()
        )));
    }
    if let Some(a) = angles_deg.iter().find(|a| !a.is_finite()) {
        return Err(PyValueError::new_err(format!("angles_deg: {a} is not an angle")));
    }
    let r = rig::Rig::read(&rig).map_err(errors::file)?;
    let Some(axis) = r.turntable else {
        return Err(errors::FileError::new_err(format!(
            "{} has no [turntable]: registering a turntable scan needs its axis",
            rig.display()
        )));
    };
    let crop = ::process::merge::CropParams { radius_mm: r.platter_radius_mm, ..Default::default() };
    let params = ::process::register::register_scan::RegisterParams::default();
    let (cloud, poses, rep) = interruptible(py, move || {
        let views: Vec<ViewGrid> =
            grids.iter().zip(&angles_deg).enumerate().map(|(v, (g, a))| ViewGrid::grid(v, *a, g)).collect();
        let (cloud, poses, rep) = stages::register(&views, &axis, &crop, &params)?;
        let warnings = rep.check(&params.tolerance, force)?;
        Ok::<_, stages::StageError>((cloud, poses, (rep, warnings)))
    })?
    .map_err(errors::stage_as(&["force"]))?;
    errors::warn_each_as(py, &rep.1, &["force"])?;
    Ok((crate::stages::cloud_out(py, cloud)?, crate::stages::report(py, &poses)?, crate::stages::report(py, &rep.0)?))
}
