//! What `scanrig.distributed` (Ray) needs of the library: a processed folder packed and adopted
//! (a view's outputs carried from its worker to the scan's folder), and AdFFT with its leaves solved
//! by a Python callable (Ray tasks) and the leaf solve itself for the workers. Private to the
//! package (underscored): the public API is `scanrig.distributed`.

use crate::arrays::Xyz;
use crate::errors;
use crate::stages::report;
use ::process::reconstruct::adfft::{AdFftParams, LeafGrid, LeafSolver, LeafTask, SolvedLeaf, reconstruct_adfft_with};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList, PyTuple};
use std::path::PathBuf;

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(_pack, m)?)?;
    m.add_function(wrap_pyfunction!(_adopt, m)?)?;
    m.add_function(wrap_pyfunction!(_adfft_with, m)?)?;
    m.add_function(wrap_pyfunction!(_adfft_solve, m)?)?;
    m.add_function(wrap_pyfunction!(_complete_views, m)?)?;
    Ok(())
}

/// The views of a scan folder that are complete, read as every command reads them (`rig::Manifest`:
/// the manifest checked, its `scan.progress` journal applied, a view without `complete` refused) —
/// not parsed again in Python.
#[pyfunction]
fn _complete_views(py: Python<'_>, scan: PathBuf) -> PyResult<Vec<usize>> {
    let m = py.detach(|| rig::Manifest::read(&scan)).map_err(errors::file)?;
    Ok(m.views.iter().enumerate().filter(|(_, v)| v.complete).map(|(i, _)| i).collect())
}

/// Every output a processed folder holds, with its records: a list of (name, bytes).
#[pyfunction]
fn _pack(py: Python<'_>, out: PathBuf) -> PyResult<Bound<'_, PyList>> {
    let files = py.detach(|| ::process::pipeline::parts::pack(&out)).map_err(errors::stage)?;
    let list = PyList::empty(py);
    for (name, bytes) in files {
        list.append((name, PyBytes::new(py, &bytes)))?;
    }
    Ok(list)
}

/// Writes packs (lists of (name, bytes)) into `out` and merges their records. Returns the files written.
#[pyfunction]
fn _adopt(py: Python<'_>, out: PathBuf, packs: Vec<Vec<(String, Vec<u8>)>>) -> PyResult<usize> {
    py.detach(|| ::process::pipeline::parts::adopt(&out, &packs)).map_err(errors::stage)
}

fn grid_dict<'py>(py: Python<'py>, g: &LeafGrid) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("origin", g.origin.to_vec())?;
    d.set_item("h", g.h)?;
    d.set_item("n", g.n)?;
    d.set_item("scale", g.scale)?;
    d.set_item("smoothing_cells", g.smoothing_cells)?;
    Ok(d)
}

fn grid_from(d: &Bound<'_, PyAny>) -> PyResult<LeafGrid> {
    let get = |k: &str| d.get_item(k).map_err(|_| PyValueError::new_err(format!("grid: no {k:?}")));
    let origin: Vec<f64> = get("origin")?.extract()?;
    Ok(LeafGrid {
        origin: origin.try_into().map_err(|_| PyValueError::new_err("grid[\"origin\"]: 3 numbers"))?,
        h: get("h")?.extract()?,
        n: get("n")?.extract()?,
        scale: get("scale")?.extract()?,
        smoothing_cells: get("smoothing_cells")?.extract()?,
    })
}

/// Leaves as an L×4 array: centre x, y, z and edge.
fn tasks_out<'py>(py: Python<'py>, tasks: &[LeafTask]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = tasks.iter().flat_map(|t| [t.centre[0], t.centre[1], t.centre[2], t.edge]).collect();
    Array2::from_shape_vec((tasks.len(), 4), flat).expect("l×4").into_pyarray(py)
}

fn solved_out<'py>(py: Python<'py>, s: SolvedLeaf) -> PyResult<Bound<'py, PyTuple>> {
    let [w0, w1, w2] = s.weight;
    PyTuple::new(
        py,
        [
            s.lo.to_vec().into_pyobject(py)?.into_any(),
            s.dims.to_vec().into_pyobject(py)?.into_any(),
            PyArray1::from_vec(py, s.values).into_any(),
            PyArray1::from_vec(py, w0).into_any(),
            PyArray1::from_vec(py, w1).into_any(),
            PyArray1::from_vec(py, w2).into_any(),
        ],
    )
}

fn solved_in(obj: &Bound<'_, PyAny>, k: usize) -> PyResult<SolvedLeaf> {
    let bad = || PyTypeError::new_err(format!("solved leaf {k}: expected (lo, dims, values, w0, w1, w2)"));
    type F32s<'a> = PyReadonlyArray1<'a, f32>;
    let (lo, dims, values, w0, w1, w2): (Vec<usize>, Vec<usize>, F32s<'_>, F32s<'_>, F32s<'_>, F32s<'_>) =
        obj.extract().map_err(|_| bad())?;
    let three = |v: Vec<usize>| -> PyResult<[usize; 3]> { v.try_into().map_err(|_| bad()) };
    Ok(SolvedLeaf {
        lo: three(lo)?,
        dims: three(dims)?,
        values: values.as_array().to_vec(),
        weight: [w0.as_array().to_vec(), w1.as_array().to_vec(), w2.as_array().to_vec()],
    })
}

/// Vertices, triangles and the report.
type Mesh<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<i64>>, Bound<'py, PyAny>);

/// AdFFT with its leaves solved by `solve(tasks, grid, weights)`: `tasks` an L×4 array (centre,
/// edge), `grid` a dict, `weights` the samples' area weights; it returns L solved leaves in order,
/// as `_adfft_solve` gives them. The octree, coarse χ and blend run here (thesis 5.3, eqs. 5.19–5.20).
#[pyfunction]
#[pyo3(signature = (points, normals, solve, *, depth=None, error=None))]
fn _adfft_with<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    normals: &Bound<'py, PyAny>,
    solve: &Bound<'py, PyAny>,
    depth: Option<u32>,
    error: Option<f64>,
) -> PyResult<Mesh<'py>> {
    let xyz = Xyz::extract(points, "points")?;
    let nrm = Xyz::extract(normals, "normals")?;
    if nrm.len() != xyz.len() {
        return Err(PyValueError::new_err(format!("normals: {} rows, but points has {}", nrm.len(), xyz.len())));
    }
    let d = AdFftParams::default();
    let params = AdFftParams { depth: depth.unwrap_or(d.depth), error, ..d };
    let cloud = rig::CloudRef { normals: Some(nrm.vectors()), ..rig::CloudRef::positions(xyz.points()) };
    // The callable's own exception, if it raised one, is what the caller sees.
    let mut raised: Option<PyErr> = None;
    let solve = solve.clone().unbind();
    let result = py.detach(|| {
        reconstruct_adfft_with(cloud, &params, |tasks, grid, weights| {
            Python::attach(|py| -> PyResult<Vec<SolvedLeaf>> {
                let w = PyArray1::from_slice(py, weights);
                let back = solve.bind(py).call1((tasks_out(py, tasks), grid_dict(py, grid)?, w))?;
                back.try_iter()?.enumerate().map(|(k, item)| solved_in(&item?, k)).collect()
            })
            .map_err(|e| {
                let text = e.to_string();
                raised = Some(e);
                text
            })
        })
    });
    if let Some(e) = raised {
        return Err(e);
    }
    let (mesh, r) = result.map_err(errors::stage)?;
    let stage_report = ::process::pipeline::stages::ReconstructReport::Adfft(r);
    Ok((
        crate::arrays::points_out(py, mesh.vertices),
        crate::arrays::triangles_out(py, &mesh.faces),
        report(py, &stage_report)?,
    ))
}

/// Solves AdFFT leaves (a worker's task): `tasks` L×4 (centre, edge), `grid` as `_adfft_with`
/// hands it, from the samples and their weights. Returns the solved leaves in order.
#[pyfunction]
fn _adfft_solve<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    normals: &Bound<'py, PyAny>,
    weights: PyReadonlyArray1<'py, f64>,
    tasks: PyReadonlyArray2<'py, f64>,
    grid: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyList>> {
    let xyz = Xyz::extract(points, "points")?;
    let nrm = Xyz::extract(normals, "normals")?;
    if nrm.len() != xyz.len() || weights.len() != xyz.len() {
        return Err(PyValueError::new_err("points, normals and weights need one row per sample"));
    }
    if tasks.shape()[1] != 4 {
        return Err(PyValueError::new_err("tasks: expected L×4 (centre x, y, z, edge)"));
    }
    let grid = grid_from(grid)?;
    let tasks: Vec<LeafTask> =
        tasks.as_array().rows().into_iter().map(|r| LeafTask { centre: [r[0], r[1], r[2]], edge: r[3] }).collect();
    let weights = weights.as_array().to_vec();
    let (p, n) = (xyz.points(), nrm.vectors());
    let solved: Vec<SolvedLeaf> = py.detach(|| {
        use rayon::prelude::*;
        let solver = LeafSolver::new(p, n, weights);
        tasks.par_iter().map(|t| solver.solve(t, &grid)).collect()
    });
    let list = PyList::empty(py);
    for s in solved {
        list.append(solved_out(py, s)?)?;
    }
    Ok(list)
}
