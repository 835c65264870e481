//! NumPy arrays in and out. Inputs are borrowed where their layout is already ours (C-contiguous
//! float64 N×3 is `&[Point3]` as it lies), copied only where the library needs an owned cloud; the
//! wrong shape or dtype is a `ValueError`/`TypeError` naming the argument, never a crash.

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use rig::math::{Point3, Vector3};

/// An N×3 float64 argument, borrowed: `&[Point3]` without a copy when it is C-contiguous.
pub struct Xyz<'py> {
    array: PyReadonlyArray2<'py, f64>,
    copy: Option<Vec<Point3>>,
}

impl<'py> Xyz<'py> {
    /// Checks `obj` (argument `name`) is an N×3 float64 array.
    pub fn extract(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Self> {
        let array: PyReadonlyArray2<'py, f64> = obj.extract().map_err(|_| {
            PyTypeError::new_err(format!(
                "{name}: expected a 2-D numpy array of float64 with 3 columns (N×3), got {}",
                describe(obj)
            ))
        })?;
        let shape = array.shape();
        if shape[1] != 3 {
            return Err(PyValueError::new_err(format!(
                "{name}: expected N×3 (x, y, z per row), got shape {}×{}",
                shape[0], shape[1]
            )));
        }
        // A strided view (a column slice) or Fortran order is gathered once into our layout. (NumPy's
        // "contiguous" includes Fortran order, whose buffer read as rows would be the transpose.)
        let copy = if array.is_c_contiguous() {
            None
        } else {
            let a = array.as_array();
            Some(a.rows().into_iter().map(|r| Point3::new(r[0], r[1], r[2])).collect())
        };
        Ok(Xyz { array, copy })
    }

    /// The rows as points.
    pub fn points(&self) -> &[Point3] {
        match &self.copy {
            Some(c) => c,
            None => bytemuck::cast_slice(self.array.as_slice().expect("checked contiguous")),
        }
    }

    /// The rows as vectors (normals).
    pub fn vectors(&self) -> &[Vector3] {
        bytemuck::cast_slice(bytemuck::cast_slice::<Point3, f64>(self.points()))
    }

    /// Rows.
    pub fn len(&self) -> usize {
        self.array.shape()[0]
    }

    /// The rows for a worker thread: the array's buffer with the array object held (so it lives,
    /// and, referenced, cannot be resized), or the gathered copy itself.
    pub fn into_rows(self, obj: &Bound<'py, PyAny>) -> Rows {
        match self.copy {
            Some(copy) => Rows { ptr: copy.as_ptr(), len: copy.len(), _owner: None, _copy: Some(copy) },
            None => {
                let points = self.points();
                Rows { ptr: points.as_ptr(), len: points.len(), _owner: Some(obj.clone().unbind()), _copy: None }
            }
        }
    }
}

/// N×3 rows handed to a worker thread, read where they lie (see [`Xyz::into_rows`]). The caller
/// must not write into an array while a call that was given it runs (Python code could, from
/// another thread, while the GIL is released; the docstrings say not to).
pub struct Rows {
    ptr: *const Point3,
    len: usize,
    _owner: Option<Py<PyAny>>,
    _copy: Option<Vec<Point3>>,
}

// SAFETY: `ptr` points into a NumPy array's buffer kept alive by `_owner` (NumPy never moves the
// data of a referenced array: ndarray.resize refuses), or into `_copy`, whose heap buffer does not
// move with the struct; the worker only reads it.
unsafe impl Send for Rows {}

impl Rows {
    /// The rows as points.
    pub fn points(&self) -> &[Point3] {
        // SAFETY: see the `Send` impl; ptr/len came from a live `&[Point3]`.
        unsafe { std::slice::from_raw_parts(self.ptr, self.len) }
    }

    /// The rows as vectors (normals).
    pub fn vectors(&self) -> &[Vector3] {
        bytemuck::cast_slice(bytemuck::cast_slice::<Point3, f64>(self.points()))
    }
}

/// What an argument that is not the array asked for is, for the message.
fn describe(obj: &Bound<'_, PyAny>) -> String {
    let dtype = obj.getattr("dtype").map(|d| d.to_string()).unwrap_or_default();
    let shape = obj.getattr("shape").map(|s| s.to_string()).unwrap_or_default();
    let kind = obj.get_type().name().map(|n| n.to_string()).unwrap_or_else(|_| "an object".into());
    if dtype.is_empty() { kind } else { format!("{kind} of dtype {dtype} and shape {shape}") }
}

/// An optional N×3 argument that must have `rows` rows.
pub fn optional_xyz<'py>(obj: Option<&Bound<'py, PyAny>>, name: &str, rows: usize) -> PyResult<Option<Xyz<'py>>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else { return Ok(None) };
    let xyz = Xyz::extract(obj, name)?;
    if xyz.len() != rows {
        return Err(PyValueError::new_err(format!("{name}: {} rows, but points has {rows}", xyz.len())));
    }
    Ok(Some(xyz))
}

/// An optional N×3 uint8 colour argument.
pub fn optional_colors(obj: Option<&Bound<'_, PyAny>>, rows: usize) -> PyResult<Option<Vec<[u8; 3]>>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else { return Ok(None) };
    let array: PyReadonlyArray2<'_, u8> = obj.extract().map_err(|_| {
        PyTypeError::new_err(format!("colors: expected an N×3 numpy array of uint8, got {}", describe(obj)))
    })?;
    let shape = array.shape();
    if shape[1] != 3 || shape[0] != rows {
        return Err(PyValueError::new_err(format!(
            "colors: expected {rows}×3 (r, g, b per point), got shape {}×{}",
            shape[0], shape[1]
        )));
    }
    Ok(Some(array.as_array().rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect()))
}

/// An optional length-N float32 argument (confidence).
pub fn optional_f32(obj: Option<&Bound<'_, PyAny>>, name: &str, rows: usize) -> PyResult<Option<Vec<f32>>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else { return Ok(None) };
    let array: PyReadonlyArray1<'_, f32> = obj.extract().map_err(|_| {
        PyTypeError::new_err(format!("{name}: expected a 1-D numpy array of float32, got {}", describe(obj)))
    })?;
    if array.len() != rows {
        return Err(PyValueError::new_err(format!("{name}: {} values, but points has {rows}", array.len())));
    }
    Ok(Some(array.as_array().to_vec()))
}

/// An F×K face array (int32 or int64, K ≥ 3), checked against the vertex count.
pub fn faces(obj: &Bound<'_, PyAny>, vertices: usize) -> PyResult<Vec<Vec<u32>>> {
    let rows: Vec<Vec<i64>> = if let Ok(a) = obj.extract::<PyReadonlyArray2<'_, i64>>() {
        a.as_array().rows().into_iter().map(|r| r.to_vec()).collect()
    } else if let Ok(a) = obj.extract::<PyReadonlyArray2<'_, i32>>() {
        a.as_array().rows().into_iter().map(|r| r.iter().map(|&v| v as i64).collect()).collect()
    } else {
        return Err(PyTypeError::new_err(format!(
            "faces: expected an F×3 (or F×4) numpy array of int32 or int64 vertex indices, got {}",
            describe(obj)
        )));
    };
    if rows.first().is_some_and(|r| r.len() < 3) {
        return Err(PyValueError::new_err("faces: a face needs at least 3 corners"));
    }
    for (f, r) in rows.iter().enumerate() {
        if let Some(&v) = r.iter().find(|&&v| v < 0 || v as usize >= vertices) {
            return Err(PyValueError::new_err(format!(
                "faces: face {f} names vertex {v}, but there are {vertices} vertices (0 to {})",
                vertices as i64 - 1
            )));
        }
    }
    Ok(rows.into_iter().map(|r| r.into_iter().map(|v| v as u32).collect()).collect())
}

/// An F×3 int64 triangle array, as [`triangles_out`] makes it, checked against the vertex count
/// (read row by row, with no vector per face: a slab of AdFFT's sweep hands back a million).
pub fn triangles_in(obj: &Bound<'_, PyAny>, vertices: usize) -> PyResult<Vec<[u32; 3]>> {
    let a: PyReadonlyArray2<'_, i64> = obj.extract().map_err(|_| {
        PyTypeError::new_err(format!("triangles: expected an F×3 numpy array of int64, got {}", describe(obj)))
    })?;
    if a.shape()[1] != 3 {
        return Err(PyValueError::new_err(format!("triangles: expected F×3, got F×{}", a.shape()[1])));
    }
    a.as_array()
        .rows()
        .into_iter()
        .enumerate()
        .map(|(f, r)| {
            let corner = |c: usize| match u32::try_from(r[c]) {
                Ok(v) if (v as usize) < vertices => Ok(v),
                _ => Err(PyValueError::new_err(format!(
                    "triangles: triangle {f} names vertex {}, but there are {vertices} vertices",
                    r[c]
                ))),
            };
            Ok([corner(0)?, corner(1)?, corner(2)?])
        })
        .collect()
}

/// Points as an N×3 float64 array (the vector handed over, not copied).
pub fn points_out<'py>(py: Python<'py>, points: Vec<Point3>) -> Bound<'py, PyArray2<f64>> {
    let n = points.len();
    let flat: Vec<f64> = bytemuck::cast_vec(points);
    Array2::from_shape_vec((n, 3), flat).expect("n×3").into_pyarray(py)
}

/// Vectors as an N×3 float64 array.
pub fn vectors_out<'py>(py: Python<'py>, v: Vec<Vector3>) -> Bound<'py, PyArray2<f64>> {
    points_out(py, bytemuck::cast_vec(v))
}

/// Colours as an N×3 uint8 array.
pub fn colors_out<'py>(py: Python<'py>, c: Vec<[u8; 3]>) -> Bound<'py, PyArray2<u8>> {
    let n = c.len();
    Array2::from_shape_vec((n, 3), c.into_iter().flatten().collect()).expect("n×3").into_pyarray(py)
}

/// Triangles as an F×3 int64 array.
pub fn triangles_out<'py>(py: Python<'py>, faces: &[[u32; 3]]) -> Bound<'py, PyArray2<i64>> {
    let flat: Vec<i64> = faces.iter().flatten().map(|&v| v as i64).collect();
    Array2::from_shape_vec((faces.len(), 3), flat).expect("f×3").into_pyarray(py)
}

/// A vector as a 1-D array.
pub fn vec_out<'py, T: numpy::Element>(py: Python<'py>, v: Vec<T>) -> Bound<'py, PyArray1<T>> {
    v.into_pyarray(py)
}

/// Where the bindings read an N×3 argument from: the array's own buffer when it is C-contiguous
/// float64 (no copy), else a gathered copy. For the test that no copy is made.
#[pyfunction]
pub fn _read_address(points: &Bound<'_, PyAny>) -> PyResult<usize> {
    Ok(Xyz::extract(points, "points")?.points().as_ptr() as usize)
}
