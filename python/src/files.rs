//! Every file format scanrig reads and writes (PLY, OBJ, STL, GLB, E57, PTS/XYZ — by extension), as
//! arrays.

use crate::arrays::{self, Xyz};
use crate::errors;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(read_cloud, m)?)?;
    m.add_function(wrap_pyfunction!(write_cloud, m)?)?;
    m.add_function(wrap_pyfunction!(read_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(write_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(read_image, m)?)?;
    m.add_function(wrap_pyfunction!(write_image, m)?)?;
    m.add_function(wrap_pyfunction!(write_range_grid, m)?)?;
    Ok(())
}

/// Reads a point cloud (any format scanrig reads, by extension). Returns a dict of arrays: points
/// (N×3 float64), normals, colors (N×3 uint8), confidence (float32), view_id (uint32) — None where
/// the file has none — and units (the data's unit, [`rig::data_units`]; None: millimetres). What
/// the file holds that cannot be kept is named in a `UserWarning`.
#[pyfunction]
fn read_cloud(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyDict>> {
    let read = py.detach(|| rig::read_cloud_reported(&path)).map_err(errors::file)?;
    errors::warn_each(py, &read.warnings)?;
    let cloud = read.value;
    let d = PyDict::new(py);
    d.set_item("points", arrays::points_out(py, cloud.positions))?;
    d.set_item("normals", cloud.normals.map(|n| arrays::vectors_out(py, n)))?;
    d.set_item("colors", cloud.colors.map(|c| arrays::colors_out(py, c)))?;
    d.set_item("confidence", cloud.confidence.map(|c| arrays::vec_out(py, c)))?;
    d.set_item("view_id", cloud.view_id.map(|c| arrays::vec_out(py, c)))?;
    d.set_item("units", rig::data_units(&path).map_err(errors::file)?)?;
    Ok(d)
}

/// Write options for data in `units` (None: millimetres, unsaid): PLY and OBJ say the unit in a
/// comment, E57, glTF and STL are written converted from it, as the commands write their inputs'
/// units (a unit scanrig cannot convert is refused for those three by the writer, by name).
pub fn write_options(units: Option<&Bound<'_, PyAny>>, name: &str) -> PyResult<rig::ply::WriteOptions> {
    let opts = rig::ply::WriteOptions::default();
    let Some(units) = units.filter(|u| !u.is_none()) else { return Ok(opts) };
    let unit: String = units
        .extract()
        .map_err(|_| PyTypeError::new_err(format!("{name}: expected a unit's name (\"mm\", \"m\", …) or None")))?;
    // A comment line holds one word: anything else would not read back as the unit.
    if unit.is_empty() || unit.chars().any(|c| c.is_whitespace() || c.is_control()) {
        return Err(PyValueError::new_err(format!(
            "{name}: {unit:?} is not a unit's name (one word, as \"mm\" or \"m\")"
        )));
    }
    Ok(opts.with_units(&unit))
}

/// Writes a point cloud; the format follows the extension (binary PLY by default, float32
/// coordinates as every viewer reads, float64 where float32 would round them). `units` is the
/// data's unit (as `read_cloud` gives it; None: millimetres). What the format cannot hold (OBJ,
/// glTF and E57 have no confidence) is a `UserWarning`.
#[pyfunction]
#[pyo3(signature = (path, points, normals=None, colors=None, confidence=None, *, units=None))]
fn write_cloud(
    py: Python<'_>,
    path: PathBuf,
    points: &Bound<'_, PyAny>,
    normals: Option<&Bound<'_, PyAny>>,
    colors: Option<&Bound<'_, PyAny>>,
    confidence: Option<&Bound<'_, PyAny>>,
    units: Option<&Bound<'_, PyAny>>,
) -> PyResult<()> {
    let opts = write_options(units, "units")?;
    let xyz = Xyz::extract(points, "points")?;
    let n = xyz.len();
    let cloud = rig::PointCloud {
        positions: xyz.points().to_vec(),
        normals: arrays::optional_xyz(normals, "normals", n)?.map(|v| v.vectors().to_vec()),
        colors: arrays::optional_colors(colors, n)?,
        confidence: arrays::optional_f32(confidence, "confidence", n)?,
        view_id: None,
    };
    py.detach(|| rig::write_cloud(&path, &cloud, &opts)).map_err(errors::file)?;
    // What the format has no field for is said, as `scanrig convert` says it.
    errors::warn_each(py, &rig::cloud_losses(&path, &cloud))
}

/// Reads a mesh (PLY, OBJ, STL, GLB). Returns a dict: vertices (V×3), faces (a list of index lists:
/// triangles, quads, polygons as in the file), triangles (F×3, the faces fanned), normals, colors,
/// units ([`rig::data_units`]). What the file holds that cannot be kept is named in a
/// `UserWarning`.
#[pyfunction]
fn read_mesh(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyDict>> {
    let read = py.detach(|| rig::read_mesh_reported(&path)).map_err(errors::file)?;
    errors::warn_each(py, &read.warnings)?;
    let mesh = read.value;
    let tri = mesh.triangulate();
    let d = PyDict::new(py);
    d.set_item("faces", mesh.faces().map(|f| f.to_vec()).collect::<Vec<_>>())?;
    d.set_item("triangles", arrays::triangles_out(py, &tri.faces))?;
    d.set_item("normals", mesh.normals.map(|n| arrays::vectors_out(py, n)))?;
    d.set_item("colors", mesh.colors.map(|c| arrays::colors_out(py, c)))?;
    d.set_item("vertices", arrays::points_out(py, mesh.vertices))?;
    d.set_item("units", rig::data_units(&path).map_err(errors::file)?)?;
    Ok(d)
}

/// Writes a mesh; the format follows the extension. `faces` is an F×3 (or F×4) integer array;
/// `units` the data's unit (as `read_mesh` gives it; None: millimetres). What the format cannot hold
/// (quads in STL or glTF, colours in STL) is a `UserWarning`.
#[pyfunction]
#[pyo3(signature = (path, vertices, faces, colors=None, *, units=None))]
fn write_mesh(
    py: Python<'_>,
    path: PathBuf,
    vertices: &Bound<'_, PyAny>,
    faces: &Bound<'_, PyAny>,
    colors: Option<&Bound<'_, PyAny>>,
    units: Option<&Bound<'_, PyAny>>,
) -> PyResult<()> {
    let opts = write_options(units, "units")?;
    let v = Xyz::extract(vertices, "vertices")?;
    let f = arrays::faces(faces, v.len())?;
    let mut mesh = rig::PolyMesh { vertices: v.points().to_vec(), ..Default::default() };
    for face in &f {
        mesh.push_face(face);
    }
    mesh.colors = arrays::optional_colors(colors, v.len())?;
    py.detach(|| rig::write_mesh(&path, &mesh, &opts)).map_err(errors::file)?;
    errors::warn_each(py, &rig::mesh_losses(&path, &mesh))
}

/// Reads an image (PNG or JPEG): H×W uint8 for grey, H×W×3 for colour.
#[pyfunction]
fn read_image(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyAny>> {
    let img = py.detach(|| rig::image::read_image(&path)).map_err(errors::file)?;
    Ok(crate::capture::image_out(py, img))
}

/// Writes an image (H×W or H×W×3 uint8): PNG, or JPEG (quality 95) for .jpg/.jpeg.
#[pyfunction]
fn write_image(py: Python<'_>, path: PathBuf, image: &Bound<'_, PyAny>) -> PyResult<()> {
    let img = crate::capture::image_in(image, "image")?;
    let jpeg = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("jpg") || e.eq_ignore_ascii_case("jpeg"));
    py.detach(|| match jpeg {
        true => rig::write_atomic(&path, &rig::image::jpeg_bytes(&img, 95)),
        false => rig::image::write_png(&path, &img, false),
    })
    .map_err(errors::file)
}

/// Writes a range grid (a dict as read_range_grid gives) as a PLY with grid_col/grid_row, float32,
/// as scanrig writes its grids; its "units", where it has them, in a `comment units`.
#[pyfunction]
fn write_range_grid(py: Python<'_>, path: PathBuf, grid: &Bound<'_, PyAny>) -> PyResult<()> {
    let g = crate::grids::grid_in(grid, "grid")?;
    let opts = write_options(grid.get_item("units").ok().as_ref(), "grid[\"units\"]")?;
    py.detach(|| rig::ply::write_range_grid(&path, &g, &opts)).map_err(errors::file)
}
