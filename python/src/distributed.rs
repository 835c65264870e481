//! What `scanrig.distributed` (Ray) needs of the library: a processed folder packed and adopted
//! (a view's outputs carried from its worker to the scan's folder), and AdFFT with its sweep done in
//! slabs by a Python callable (Ray tasks), with the slab's leaf solves and sweep for the workers. Private to the
//! package (underscored): the public API is `scanrig.distributed`.

use crate::arrays::Xyz;
use crate::errors;
use crate::stages::report;
use ::process::pipeline::stages::ReconstructParams;
use ::process::reconstruct::adfft::{
    AdFftParams, CoarseChi, LeafGrid, LeafSolver, LeafTask, SolvedLeaf, reconstruct_adfft_slabs, slab_part, sweep_slab,
};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList, PyTuple};
use rig::TriMesh;
use std::ops::Range;
use std::path::PathBuf;

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(_pack, m)?)?;
    m.add_function(wrap_pyfunction!(_adopt, m)?)?;
    m.add_function(wrap_pyfunction!(_adfft_slabs, m)?)?;
    m.add_function(wrap_pyfunction!(_adfft_slab_parts, m)?)?;
    m.add_function(wrap_pyfunction!(_adfft_sweep_slab, m)?)?;
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

/// Writes packs (lists of (name, bytes)) of the scan in `scan` into `out` and merges their
/// records, once `out` is found to be that scan's folder. Returns the files written.
#[pyfunction]
fn _adopt(py: Python<'_>, scan: PathBuf, out: PathBuf, packs: Vec<Vec<(String, Vec<u8>)>>) -> PyResult<usize> {
    py.detach(|| ::process::pipeline::parts::adopt(&scan, &out, &packs)).map_err(errors::stage)
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

fn coarse_dict<'py>(py: Python<'py>, c: &CoarseChi) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("n", c.n)?;
    d.set_item("values", PyArray1::from_slice(py, &c.values))?;
    d.set_item("iso", c.iso)?;
    d.set_item("weight", c.weight)?;
    Ok(d)
}

fn coarse_from(d: &Bound<'_, PyAny>) -> PyResult<CoarseChi> {
    let get = |k: &str| d.get_item(k).map_err(|_| PyValueError::new_err(format!("coarse: no {k:?}")));
    let values: PyReadonlyArray1<'_, f32> =
        get("values")?.extract().map_err(|_| PyTypeError::new_err("coarse[\"values\"]: a float32 array"))?;
    Ok(CoarseChi {
        n: get("n")?.extract()?,
        values: values.as_array().to_vec(),
        iso: get("iso")?.extract()?,
        weight: get("weight")?.extract()?,
    })
}

fn part_out<'py>(py: Python<'py>, id: usize, s: SolvedLeaf) -> PyResult<Bound<'py, PyTuple>> {
    let [w0, w1, w2] = s.weight;
    PyTuple::new(
        py,
        [
            id.into_pyobject(py)?.into_any(),
            s.lo.to_vec().into_pyobject(py)?.into_any(),
            s.dims.to_vec().into_pyobject(py)?.into_any(),
            PyArray1::from_vec(py, s.values).into_any(),
            PyArray1::from_vec(py, w0).into_any(),
            PyArray1::from_vec(py, w1).into_any(),
            PyArray1::from_vec(py, w2).into_any(),
        ],
    )
}

fn part_in(obj: &Bound<'_, PyAny>, k: usize) -> PyResult<(usize, SolvedLeaf)> {
    let bad = || PyTypeError::new_err(format!("part {k}: expected (id, lo, dims, values, w0, w1, w2)"));
    type F32s<'a> = PyReadonlyArray1<'a, f32>;
    let (id, lo, dims, values, w0, w1, w2): (usize, Vec<usize>, Vec<usize>, F32s<'_>, F32s<'_>, F32s<'_>, F32s<'_>) =
        obj.extract().map_err(|_| bad())?;
    let three = |v: Vec<usize>| -> PyResult<[usize; 3]> { v.try_into().map_err(|_| bad()) };
    let leaf = SolvedLeaf {
        lo: three(lo)?,
        dims: three(dims)?,
        values: values.as_array().to_vec(),
        weight: [w0.as_array().to_vec(), w1.as_array().to_vec(), w2.as_array().to_vec()],
    };
    Ok((id, leaf))
}

fn layers_from(layers: Vec<(usize, usize)>) -> Vec<Range<usize>> {
    layers.into_iter().map(|(a, b)| a..b).collect()
}

/// Vertices and triangles.
type Triangles<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<i64>>);

/// Vertices, triangles and the report.
type Mesh<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<i64>>, Bound<'py, PyAny>);

/// AdFFT with its sweep in `slabs` slabs done by `run(tasks, grid, weights, coarse, layers)`:
/// `tasks` an L×4 array (centre, edge), `grid` and `coarse` dicts, `weights` the samples' area
/// weights, `layers` each slab's cube layers as (first, end); it returns each slab's (vertices,
/// triangles) in order, as `_adfft_sweep_slab` makes them. The octree, the coarse χ, the joining
/// and the clean-up run here (thesis 5.3); the solved leaves never do. The mesh is checked as
/// `reconstruct`'s is: none, or one far from the points, inside out, facing against their normals,
/// leaving some out or coarsened by points far from the rest unless `force`, raises `StageError`;
/// what else is wrong is a `UserWarning`.
#[pyfunction]
#[pyo3(signature = (points, normals, run, *, slabs=2, depth=None, error=None, samples_per_cell=None, force=false))]
#[allow(clippy::too_many_arguments)]
fn _adfft_slabs<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    normals: &Bound<'py, PyAny>,
    run: &Bound<'py, PyAny>,
    slabs: usize,
    depth: Option<u32>,
    error: Option<f64>,
    samples_per_cell: Option<f64>,
    force: bool,
) -> PyResult<Mesh<'py>> {
    let xyz = Xyz::extract(points, "points")?;
    let nrm = Xyz::extract(normals, "normals")?;
    if nrm.len() != xyz.len() {
        return Err(PyValueError::new_err(format!("normals: {} rows, but points has {}", nrm.len(), xyz.len())));
    }
    if !(1..=4096).contains(&slabs) {
        return Err(PyValueError::new_err(format!("slabs: 1 to 4096, got {slabs}")));
    }
    let d = AdFftParams::default();
    let params = AdFftParams {
        depth: depth.unwrap_or(d.depth),
        error,
        samples_per_cell: samples_per_cell.unwrap_or(d.samples_per_cell),
        ..d
    };
    ReconstructParams::Adfft(params).validate().map_err(|e| PyValueError::new_err(e.to_string()))?;
    let cloud = rig::CloudRef { normals: Some(nrm.vectors()), ..rig::CloudRef::positions(xyz.points()) };
    // The callable's own exception, if it raised one, is what the caller sees.
    let mut raised: Option<PyErr> = None;
    let run = run.clone().unbind();
    let result = py.detach(|| {
        reconstruct_adfft_slabs(cloud, &params, slabs, |job| {
            Python::attach(|py| -> PyResult<Vec<TriMesh>> {
                let w = PyArray1::from_slice(py, job.weights);
                let layers: Vec<(usize, usize)> = job.layers.iter().map(|l| (l.start, l.end)).collect();
                let args =
                    (tasks_out(py, &job.tasks), grid_dict(py, &job.grid)?, w, coarse_dict(py, &job.coarse)?, layers);
                let back = run.bind(py).call1(args)?;
                back.try_iter()?
                    .enumerate()
                    .map(|(s, item)| {
                        let item = item?;
                        let bad = || PyTypeError::new_err(format!("slab {s}: expected (vertices, triangles)"));
                        let (v, f): (Bound<'_, PyAny>, Bound<'_, PyAny>) = item.extract().map_err(|_| bad())?;
                        let vertices = Xyz::extract(&v, "vertices")?.points().to_vec();
                        let faces = crate::arrays::triangles_in(&f, vertices.len())?;
                        Ok(TriMesh { vertices, faces, normals: None })
                    })
                    .collect()
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
    let (mesh, r) = result.map_err(errors::stage_as(&["force", "depth", "samples-per-cell"]))?;
    let stage_report = ::process::pipeline::stages::ReconstructReport::Adfft(r);
    // The single process's checks of its mesh (`scanrig.reconstruct`, `scanrig process`): no surface
    // refused, and a mesh inside out, facing against its samples' normals, far from them, leaving
    // some out or coarsened by points apart (each unless `force`), the report's own warnings given.
    // Without them a distributed mesh was returned in silence whatever it was.
    let warnings = py
        .detach(|| ::process::pipeline::stages::checked_reconstruction(&mesh, &stage_report, cloud, force))
        .map_err(errors::stage_as(&["force", "depth", "samples-per-cell"]))?;
    errors::warn_each_as(py, &warnings, &["force", "depth", "samples-per-cell"])?;
    Ok((
        crate::arrays::points_out(py, mesh.vertices),
        crate::arrays::triangles_out(py, &mesh.faces),
        report(py, &stage_report)?,
    ))
}

/// Solves AdFFT leaves for a sweep in slabs (a worker's task): `tasks` L×4 (centre, edge) with
/// their ids, from the samples and their weights, each cut to every slab of `layers` it reaches.
/// Returns one list per slab of parts (id, lo, dims, values, w0, w1, w2).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn _adfft_slab_parts<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    normals: &Bound<'py, PyAny>,
    weights: PyReadonlyArray1<'py, f64>,
    tasks: PyReadonlyArray2<'py, f64>,
    ids: Vec<usize>,
    grid: &Bound<'py, PyAny>,
    layers: Vec<(usize, usize)>,
) -> PyResult<Bound<'py, PyList>> {
    let xyz = Xyz::extract(points, "points")?;
    let nrm = Xyz::extract(normals, "normals")?;
    if nrm.len() != xyz.len() || weights.len() != xyz.len() {
        return Err(PyValueError::new_err("points, normals and weights need one row per sample"));
    }
    if tasks.shape()[1] != 4 || tasks.shape()[0] != ids.len() {
        return Err(PyValueError::new_err("tasks: expected L×4 (centre x, y, z, edge), one row per id"));
    }
    let grid = grid_from(grid)?;
    let layers = layers_from(layers);
    grid.check(&layers).map_err(PyValueError::new_err)?;
    let tasks: Vec<LeafTask> =
        tasks.as_array().rows().into_iter().map(|r| LeafTask { centre: [r[0], r[1], r[2]], edge: r[3] }).collect();
    let weights = weights.as_array().to_vec();
    let (p, n) = (xyz.points(), nrm.vectors());
    let parts: Vec<Vec<(usize, SolvedLeaf)>> = py.detach(|| {
        use rayon::prelude::*;
        let solver = LeafSolver::new(p, n, weights);
        // Each leaf cut into its parts as soon as it is solved, and the whole solve dropped: the task
        // holds its batch's values once, not solved and cut side by side.
        let cut: Vec<Vec<Option<SolvedLeaf>>> = tasks
            .par_iter()
            .map(|t| {
                let solved = solver.solve(t, &grid);
                layers.iter().map(|l| slab_part(&solved, l, grid.n)).collect()
            })
            .collect();
        let mut parts: Vec<Vec<(usize, SolvedLeaf)>> = vec![Vec::new(); layers.len()];
        for (&id, leaf) in ids.iter().zip(cut) {
            for (slab, part) in parts.iter_mut().zip(leaf) {
                slab.extend(part.map(|p| (id, p)));
            }
        }
        parts
    });
    let out = PyList::empty(py);
    for slab in parts {
        let list = PyList::empty(py);
        for (id, part) in slab {
            list.append(part_out(py, id, part)?)?;
        }
        out.append(list)?;
    }
    Ok(out)
}

/// One slab of AdFFT's sweep (a worker's task): marching cubes over the blend of `layer`'s cube
/// layers (first, end), from `parts` (as `_adfft_slab_parts` gives them, from every task) and the
/// coarse χ. Returns (vertices, triangles).
#[pyfunction]
fn _adfft_sweep_slab<'py>(
    py: Python<'py>,
    parts: &Bound<'py, PyAny>,
    coarse: &Bound<'py, PyAny>,
    grid: &Bound<'py, PyAny>,
    layer: (usize, usize),
) -> PyResult<Triangles<'py>> {
    let parts: Vec<(usize, SolvedLeaf)> =
        parts.try_iter()?.enumerate().map(|(k, item)| part_in(&item?, k)).collect::<PyResult<_>>()?;
    let coarse = coarse_from(coarse)?;
    let grid = grid_from(grid)?;
    let mesh = py
        .detach(|| sweep_slab(parts, &coarse, &grid, layer.0..layer.1))
        .map_err(|e| PyValueError::new_err(format!("sweeping a slab: {e}")))?;
    Ok((crate::arrays::points_out(py, mesh.vertices), crate::arrays::triangles_out(py, &mesh.faces)))
}
