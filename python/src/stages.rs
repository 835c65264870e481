//! The stages as functions: keyword parameters with the command line's defaults, arrays in, arrays
//! and a report dict out. Each checks its arrays, then runs the library's stage off the GIL.

use crate::arrays::{self, Rows, Xyz};
use crate::errors;
use crate::run::interruptible;
use ::process::pipeline::stages::{self, FuseParams, ReconstructParams};
use ::process::reconstruct::{adfft::AdFftParams, global_fft::FftParams};
use ::process::remesh::RemeshParams;
use numpy::PyArray2;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rig::{PointCloud, TriMesh};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(fuse, m)?)?;
    m.add_function(wrap_pyfunction!(reconstruct, m)?)?;
    m.add_function(wrap_pyfunction!(remesh, m)?)?;
    m.add_function(wrap_pyfunction!(icp, m)?)?;
    m.add_function(wrap_pyfunction!(align, m)?)?;
    m.add_function(wrap_pyfunction!(process_scan, m)?)?;
    Ok(())
}

/// A mesh handed back: vertices (V×3), faces of type `F`, and the report.
type Meshed<'py, F> = (Bound<'py, PyArray2<f64>>, F, Bound<'py, PyAny>);

/// A report as a dict with the JSON report's keys.
pub fn report<'py>(py: Python<'py>, r: &impl serde::Serialize) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(r).map_err(|e| PyValueError::new_err(e.to_string()))?;
    py.import("json")?.call_method1("loads", (text,))
}

pub fn cloud_out<'py>(py: Python<'py>, cloud: PointCloud) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("points", arrays::points_out(py, cloud.positions))?;
    d.set_item("normals", cloud.normals.map(|n| arrays::vectors_out(py, n)))?;
    d.set_item("colors", cloud.colors.map(|c| arrays::colors_out(py, c)))?;
    d.set_item("confidence", cloud.confidence.map(|c| arrays::vec_out(py, c)))?;
    Ok(d)
}

/// Mean-shift fusion of a registered cloud (thesis ch. 3, eqs. 3.2–3.10): noise removed by moving
/// each sample to the nearest maximum of a likelihood of anisotropic kernels, samples at the same
/// maximum merged, outliers dropped. Returns (cloud dict, kept mask, report).
#[pyfunction]
#[pyo3(signature = (points, normals=None, colors=None, confidence=None, *, k=None, kernel_spacing=None))]
fn fuse<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    normals: Option<&Bound<'py, PyAny>>,
    colors: Option<&Bound<'py, PyAny>>,
    confidence: Option<&Bound<'py, PyAny>>,
    k: Option<usize>,
    kernel_spacing: Option<f64>,
) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let xyz = Xyz::extract(points, "points")?;
    let n = xyz.len();
    let nrm = arrays::optional_xyz(normals, "normals", n)?;
    let colors = arrays::optional_colors(colors, n)?;
    let confidence = arrays::optional_f32(confidence, "confidence", n)?;
    // Read where they lie: fusion's Morton-ordered working copy is made from the arrays directly.
    let rows = xyz.into_rows(points);
    let normal_rows = nrm.zip(normals).map(|(x, obj)| x.into_rows(obj));
    let d = FuseParams::default();
    let mut params = d;
    if let Some(k) = k {
        params.mean_shift.k = k;
    }
    if let Some(s) = kernel_spacing {
        if !(s >= 0.0 && s.is_finite()) {
            return Err(PyValueError::new_err(format!("kernel_spacing must be 0 or a positive fraction, got {s}")));
        }
        params.mean_shift.kernel_spacing = s;
    }
    // The library's own limits (process::limits), as a ValueError naming the keyword.
    params.validate_for(n).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let (fused, r) = interruptible(py, move || {
        let cloud = rig::CloudRef {
            positions: rows.points(),
            normals: normal_rows.as_ref().map(Rows::vectors),
            colors: colors.as_deref(),
            confidence: confidence.as_deref(),
            view_id: None,
        };
        stages::fuse_borrowed(cloud, &params)
    })?
    .map_err(errors::stage)?;
    let kept = numpy::PyArray1::from_vec(py, fused.kept).into_any();
    Ok((cloud_out(py, fused.cloud)?, kept, report(py, &r)?))
}

/// Watertight surface reconstruction from oriented points (thesis ch. 5): `method="fft"`, the
/// global FFT solution of the Poisson equation for the indicator (eqs. 5.16–5.17) on a 2^depth
/// grid, or `"adfft"`, local FFT solutions over an octree blended by a partition of unity (5.3);
/// then finished as `scanrig process` finishes its mesh, through the same stage (`stages::mesh`): the
/// base cut at `platter_z` (`base`), the surface cut at `top_z`, `trim`, and the check that the data
/// supports the mesh: not far from it, inside out, facing against its normals, leaving samples
/// out or coarsened by points far from the rest (an error unless `force`). What it warns of is a `UserWarning`. Returns
/// (vertices, triangles, report).
#[pyfunction]
#[pyo3(signature = (points, normals, *, method="fft", depth=None, error=None, smoothing_cells=None, memory_budget_gb=None, platter_z=None, top_z=None, base="flat", trim=None, force=false, samples_per_cell=None))]
#[allow(clippy::too_many_arguments)]
fn reconstruct<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    normals: &Bound<'py, PyAny>,
    method: &str,
    depth: Option<u32>,
    error: Option<f64>,
    smoothing_cells: Option<f64>,
    memory_budget_gb: Option<f64>,
    platter_z: Option<f64>,
    top_z: Option<f64>,
    base: &str,
    trim: Option<f64>,
    force: bool,
    samples_per_cell: Option<f64>,
) -> PyResult<Meshed<'py, Bound<'py, PyArray2<i64>>>> {
    let xyz = Xyz::extract(points, "points")?;
    let nrm = Xyz::extract(normals, "normals")?;
    if nrm.len() != xyz.len() {
        return Err(PyValueError::new_err(format!("normals: {} rows, but points has {}", nrm.len(), xyz.len())));
    }
    let budget = match memory_budget_gb {
        Some(b) if !(b > 0.0 && b.is_finite()) => {
            return Err(PyValueError::new_err(format!("memory_budget_gb must be a positive number of GB, got {b}")));
        }
        Some(b) => (b * 1e9) as u64,
        None => FftParams::default().memory_budget,
    };
    let params = match method {
        "fft" => {
            if error.is_some() {
                return Err(PyValueError::new_err(
                    "error steers AdFFT's octree; the global method (method=\"fft\") has none",
                ));
            }
            if samples_per_cell.is_some() {
                return Err(PyValueError::new_err(
                    "samples_per_cell adapts AdFFT's grid; the global method (method=\"fft\") keeps depth",
                ));
            }
            let d = FftParams::default();
            ReconstructParams::Fft(FftParams {
                depth: depth.unwrap_or(d.depth),
                smoothing_cells: smoothing_cells.unwrap_or(d.smoothing_cells),
                memory_budget: budget,
                ..d
            })
        }
        "adfft" => {
            if smoothing_cells.is_some() {
                return Err(PyValueError::new_err(
                    "smoothing_cells is the global method's (method=\"fft\"); AdFFT smooths per octree cell",
                ));
            }
            let d = AdFftParams::default();
            ReconstructParams::Adfft(AdFftParams {
                depth: depth.unwrap_or(d.depth),
                error,
                memory_budget: budget,
                samples_per_cell: samples_per_cell.unwrap_or(d.samples_per_cell),
                ..d
            })
        }
        other => return Err(PyValueError::new_err(format!("method must be \"fft\" or \"adfft\", got {other:?}"))),
    };
    let base = match base {
        "flat" => stages::Base::Flat,
        "open" => stages::Base::Open,
        "closed" => stages::Base::Closed,
        other => {
            return Err(PyValueError::new_err(format!("base must be \"flat\", \"open\" or \"closed\", got {other:?}")));
        }
    };
    let finish = stages::FinishParams { base, trim, ..Default::default() };
    // The mesh stage `process` runs (`stages::mesh`): reconstruction, the base cut at the platter
    // plane where one is given, the cut at the working volume's top, the trim, the support check.
    let mp = stages::MeshParams { reconstruct: params, finish, platter_z, top_z, force };
    let (rows, normal_rows) = (xyz.into_rows(points), nrm.into_rows(normals));
    let made = interruptible(py, move || {
        // Meshed where the arrays lie (C-ordered float64 rows are read in place).
        let cloud = rig::CloudRef { normals: Some(normal_rows.vectors()), ..rig::CloudRef::positions(rows.points()) };
        stages::mesh(cloud, &mp)
    })?
    .map_err(errors::stage_as(RECONSTRUCT_KEYWORDS))?;
    errors::warn_each_as(py, &made.warnings, RECONSTRUCT_KEYWORDS)?;
    let mesh = made.mesh;
    Ok((arrays::points_out(py, mesh.vertices), arrays::triangles_out(py, &mesh.faces), report(py, &made.report)?))
}

/// The command line's options that `reconstruct`'s keyword arguments set, as its hints name them.
const RECONSTRUCT_KEYWORDS: &[&str] =
    &["force", "method", "depth", "samples-per-cell", "memory-budget", "base", "trim"];
/// The same for `remesh`.
const REMESH_KEYWORDS: &[&str] = &["force", "spacing", "features", "weight"];

/// Quad remeshing of a triangle mesh (thesis ch. 6): a harmonic field constrained by feature lines,
/// its streamlines in two families, and the quads they bound. Returns (vertices, faces as a list of
/// index lists, report). A remesh that cannot be right (edges of three faces or holes the input
/// lacks, surface far from it) is a `StageError` unless `force`, which returns it with a `UserWarning`.
#[pyfunction]
#[pyo3(signature = (vertices, faces, *, spacing=None, features=None, weight=None, force=false))]
#[allow(clippy::too_many_arguments)]
fn remesh<'py>(
    py: Python<'py>,
    vertices: &Bound<'py, PyAny>,
    faces: &Bound<'py, PyAny>,
    spacing: Option<f64>,
    features: Option<f64>,
    weight: Option<f64>,
    force: bool,
) -> PyResult<Meshed<'py, Vec<Vec<u32>>>> {
    let v = Xyz::extract(vertices, "vertices")?;
    let f = arrays::faces(faces, v.len())?;
    if f.iter().any(|t| t.len() != 3) {
        return Err(PyValueError::new_err("faces: remesh takes triangles (F×3)"));
    }
    let mesh =
        TriMesh { vertices: v.points().to_vec(), faces: f.iter().map(|t| [t[0], t[1], t[2]]).collect(), normals: None };
    let d = RemeshParams::default();
    if let Some(s) = spacing
        && !(s > 0.0 && s.is_finite())
    {
        return Err(PyValueError::new_err(format!("spacing must be a positive distance, got {s}")));
    }
    let params = RemeshParams {
        spacing,
        feature_angle: match features {
            Some(a) if a <= 0.0 => None,
            Some(a) => Some(a),
            None => d.feature_angle,
        },
        weight: weight.unwrap_or(d.weight),
        ..d
    };
    let (quads, r, warnings) = interruptible(py, move || {
        let mut warnings = stages::check_remesh_input(&mesh, force)?;
        let (quads, r) = stages::remesh(&mesh, &params)?;
        warnings.extend(stages::check_remesh(&r, force)?);
        Ok::<_, stages::StageError>((quads, r, warnings))
    })?
    .map_err(errors::stage_as(REMESH_KEYWORDS))?;
    errors::warn_each_as(py, &warnings, REMESH_KEYWORDS)?;
    let faces: Vec<Vec<u32>> = quads.faces().map(|f| f.to_vec()).collect();
    Ok((arrays::points_out(py, quads.vertices), faces, report(py, &r)?))
}

/// Point-to-plane ICP of `moving` onto `target` (thesis ch. 2.2), from `initial` (4×4, default the
/// identity). `moving` is read in place when it is C-contiguous float64. Returns (4×4 transform,
/// report).
#[pyfunction]
#[pyo3(signature = (moving, moving_normals, target, target_normals, *, initial=None, max_iterations=None, start_distance=None))]
#[allow(clippy::too_many_arguments)]
fn icp<'py>(
    py: Python<'py>,
    moving: &Bound<'py, PyAny>,
    moving_normals: &Bound<'py, PyAny>,
    target: &Bound<'py, PyAny>,
    target_normals: &Bound<'py, PyAny>,
    initial: Option<&Bound<'py, PyAny>>,
    max_iterations: Option<usize>,
    start_distance: Option<f64>,
) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyAny>)> {
    use ::process::register::icp::{IcpParams, IcpTarget, icp as run_icp};
    let m = Xyz::extract(moving, "moving")?;
    let mn = Xyz::extract(moving_normals, "moving_normals")?;
    let t = Xyz::extract(target, "target")?;
    let tn = Xyz::extract(target_normals, "target_normals")?;
    if mn.len() != m.len() || tn.len() != t.len() {
        return Err(PyValueError::new_err("moving_normals and target_normals need one row per point"));
    }
    let start = match initial.filter(|o| !o.is_none()) {
        None => rig::math::Isometry3::identity(),
        Some(o) => isometry(o)?,
    };
    let d = IcpParams::default();
    let params = IcpParams {
        max_iterations: max_iterations.unwrap_or(d.max_iterations),
        start_distance: start_distance.unwrap_or(d.start_distance),
        ..d
    };
    let (rows, row_normals) = (m.into_rows(moving), mn.into_rows(moving_normals));
    let target = IcpTarget::new(t.points().to_vec(), tn.vectors().to_vec(), None);
    let result = interruptible(py, move || run_icp(rows.points(), row_normals.vectors(), &target, &start, &params))?;
    let (pose, r) = result.map_err(errors::stage)?;
    Ok((pose_out(py, &pose), report(py, &r)?))
}

/// Global registration (issue 40): `moving` aligned onto `fixed` with no pose to start from, by
/// local shape descriptors, a robust search and ICP — as `scanrig align` and a scan's passes are.
/// The matching spacing is `voxel` (default 1/100 of `fixed`'s bounding-box diagonal). An
/// ambiguous or unsupported match (a sphere, unrelated objects) raises `StageError` with the
/// reason unless `force`, which returns the best guess with a `UserWarning`. Returns (4×4 transform
/// taking `moving` into `fixed`'s frame, report).
#[pyfunction]
#[pyo3(signature = (moving, fixed, *, voxel=None, seed=None, force=false))]
fn align<'py>(
    py: Python<'py>,
    moving: &Bound<'py, PyAny>,
    fixed: &Bound<'py, PyAny>,
    voxel: Option<f64>,
    seed: Option<u64>,
    force: bool,
) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyAny>)> {
    use ::process::register::global::{GlobalError, GlobalParams, align_global};
    let m = Xyz::extract(moving, "moving")?;
    let f = Xyz::extract(fixed, "fixed")?;
    let (m, f) = (m.points().to_vec(), f.points().to_vec());
    // An option the library refuses is a ValueError naming the keyword, as the others are.
    let keyword = |e: GlobalError| match e {
        GlobalError::Param(p) => PyValueError::new_err(format!("voxel={}: {}", p.value, p.why)),
        other => errors::stage(other),
    };
    let seed = seed.unwrap_or(GlobalParams::default().seed);
    let params = GlobalParams::for_clouds(&m, &f, voxel, seed).map_err(keyword)?;
    // Arrays carry no unit: one object in metres and in mm fails as too few points or matches, and
    // the sizes' ratio is named with the failure (as `scanrig align` names it).
    let hint = ::process::register::global::sizes_apart(&m, &f).map_or(String::new(), |h| format!("; {h}"));
    let failed = |e: GlobalError| match e {
        GlobalError::Param(_) => keyword(e),
        other => errors::StageError::new_err(format!("{}{hint}", errors::chain(&other))),
    };
    let a = interruptible(py, move || align_global(&m, &f, &params))?.map_err(failed)?;
    if !a.aligned {
        let what = format!("moving could not be aligned onto fixed: {}{hint}", a.why);
        if !force {
            return Err(errors::StageError::new_err(format!("{what}; force=True returns the best guess anyway")));
        }
        errors::warn_each(py, &[format!("{what} (returned anyway: force=True)")])?;
    }
    let r = report(py, &a)?;
    r.set_item("voxel", params.voxel)?;
    Ok((pose_out(py, &a.pose), r))
}

/// A rigid motion as a 4×4 float64 array.
fn pose_out<'py>(py: Python<'py>, pose: &rig::math::Isometry3) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = rig::math::rows_of(pose).concat();
    let out = numpy::ndarray::Array2::from_shape_vec((4, 4), flat).expect("4×4");
    numpy::IntoPyArray::into_pyarray(out, py)
}

/// A rigid 4×4 transform argument.
fn isometry(obj: &Bound<'_, PyAny>) -> PyResult<rig::math::Isometry3> {
    use numpy::{PyReadonlyArray2, PyUntypedArrayMethods};
    let a: PyReadonlyArray2<'_, f64> =
        obj.extract().map_err(|_| PyValueError::new_err("initial: expected a 4×4 numpy array of float64"))?;
    if a.shape() != [4, 4] {
        return Err(PyValueError::new_err(format!("initial: expected 4×4, got {:?}", a.shape())));
    }
    let a = a.as_array();
    let r = rig::math::Matrix3::from_fn(|i, j| a[(i, j)]);
    // Only a rotation and a translation: a scaled or sheared matrix is refused, not silently fixed.
    if (r.transpose() * r - rig::math::Matrix3::identity()).norm() > 1e-6 || (r.determinant() - 1.0).abs() > 1e-6 {
        return Err(PyValueError::new_err("initial: the upper 3×3 block is not a rotation"));
    }
    let rotation = rig::math::UnitQuaternion::from_matrix(&r);
    Ok(rig::math::Isometry3::from_parts(rig::math::Translation3::new(a[(0, 3)], a[(1, 3)], a[(2, 3)]), rotation))
}

/// Processes a scan folder as `scanrig process` does (decode or find lines, triangulate, denoise,
/// merge, register, fuse, close, reconstruct, remesh), writing into `out` (default SCAN/processed);
/// resumes where an earlier run stopped. `until` names the last stage to run, `views` limits the run
/// to those views (a distributed run's per-view part). Returns the report.
#[pyfunction(name = "process")]
#[pyo3(signature = (scan, out=None, *, force=false, until=None, views=None))]
fn process_scan<'py>(
    py: Python<'py>,
    scan: std::path::PathBuf,
    out: Option<std::path::PathBuf>,
    force: bool,
    until: Option<&str>,
    views: Option<Vec<usize>>,
) -> PyResult<Bound<'py, PyAny>> {
    let out = out.unwrap_or_else(|| scan.join("processed"));
    let until = match until {
        None => ::process::Stage::Remesh,
        Some(name) => ::process::Stage::from_name(name).ok_or_else(|| {
            let names: Vec<&str> = ::process::Stage::ALL.iter().map(|s| s.name()).collect();
            PyValueError::new_err(format!("until must be one of {}, got {name:?}", names.join(", ")))
        })?,
    };
    let params = ::process::pipeline::ProcessParams { force, until, views, ..Default::default() };
    let r = interruptible(py, move || ::process::pipeline::process_scan(&scan, &out, &params, |_, _, _| {}))?
        .map_err(errors::stage_as(&["force"]))?;
    report(py, &r)
}
