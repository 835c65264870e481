//! Writing PLY: binary little-endian by default, ASCII on request.

use super::header::{Encoding, ScalarType};
use crate::error::Error;
use crate::math::{Point3, Vector3};
use crate::run_files::write_atomic;
use crate::{PointCloud, PolyMesh, RangeGrid, Sensor, SparseView};
use rayon::prelude::*;
use std::path::Path;

/// The type of written coordinates and normals.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Precision {
    /// `float`: what every viewer reads; ~0.1 µm resolution at a metre, far below scanner noise.
    #[default]
    F32,
    /// `double`: exact round trips of `f64` data.
    F64,
}

/// How to write a PLY file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WriteOptions {
    /// Body encoding (default binary little-endian).
    pub encoding: Encoding,
    /// Coordinate type (default `float`).
    pub precision: Precision,
    /// `comment` lines, e.g. `units mm`.
    pub comments: Vec<String>,
}

impl Default for WriteOptions {
    fn default() -> Self {
        WriteOptions { encoding: Encoding::BinaryLittleEndian, precision: Precision::F32, comments: Vec::new() }
    }
}

impl WriteOptions {
    /// ASCII with the default precision.
    pub fn ascii() -> Self {
        WriteOptions { encoding: Encoding::Ascii, ..Default::default() }
    }

    /// Adds a `comment units <unit>` line, which [`Header::units`](super::Header::units) reads back.
    pub fn with_units(mut self, unit: &str) -> Self {
        self.comments.push(format!("units {unit}"));
        self
    }

    /// The unit a `comment units …` line gives the data, where one does.
    pub fn units(&self) -> Option<&str> {
        self.comments.iter().find_map(|c| c.strip_prefix("units ")).map(str::trim)
    }

    /// These options for writing `points`: `float` coordinates become `double` where single
    /// precision would not hold them ([`crate::precision::Rounding::holds`]: an object far from the
    /// origin), whatever was asked.
    pub fn holding<'a>(&self, points: impl IntoIterator<Item = &'a Point3>) -> WriteOptions {
        let mut opts = self.clone();
        if opts.precision == Precision::F32 && !crate::precision::Rounding::of(points).holds() {
            opts.precision = Precision::F64;
        }
        opts
    }
}

struct Body {
    out: Vec<u8>,
    encoding: Encoding,
    first_on_line: bool,
}

impl Body {
    fn value(&mut self, t: ScalarType, v: f64) {
        use std::io::Write;
        match self.encoding {
            Encoding::Ascii => {
                if !self.first_on_line {
                    self.out.push(b' ');
                }
                self.first_on_line = false;
                // Rust's shortest round-trip formatting: parsing the text gives back the same value.
                let _ = match t {
                    ScalarType::F32 => write!(self.out, "{}", v as f32),
                    ScalarType::F64 => write!(self.out, "{v}"),
                    _ => write!(self.out, "{}", v as i64),
                };
            }
            enc => {
                let le = enc == Encoding::BinaryLittleEndian;
                macro_rules! put {
                    ($x:expr) => {
                        self.out.extend_from_slice(&if le { $x.to_le_bytes() } else { $x.to_be_bytes() })
                    };
                }
                match t {
                    ScalarType::I8 => put!(v as i8),
                    ScalarType::U8 => put!(v as u8),
                    ScalarType::I16 => put!(v as i16),
                    ScalarType::U16 => put!(v as u16),
                    ScalarType::I32 => put!(v as i32),
                    ScalarType::U32 => put!(v as u32),
                    ScalarType::F32 => put!(v as f32),
                    ScalarType::F64 => put!(v),
                }
            }
        }
    }

    fn end_entry(&mut self) {
        if self.encoding == Encoding::Ascii {
            self.out.push(b'\n');
            self.first_on_line = true;
        }
    }
}

fn header(opts: &WriteOptions, elements: &[(&str, usize, Vec<String>)]) -> Vec<u8> {
    let mut h = format!("ply\nformat {} 1.0\n", opts.encoding.name());
    h += &format!("comment written by scanrig {}\n", env!("CARGO_PKG_VERSION"));
    for c in &opts.comments {
        h += &format!("comment {c}\n");
    }
    for (name, count, props) in elements {
        h += &format!("element {name} {count}\n");
        for p in props {
            h += &format!("property {p}\n");
        }
    }
    h += "end_header\n";
    h.into_bytes()
}

fn real(opts: &WriteOptions) -> ScalarType {
    match opts.precision {
        Precision::F32 => ScalarType::F32,
        Precision::F64 => ScalarType::F64,
    }
}

fn xyz_props(t: ScalarType, prefix: &str) -> Vec<String> {
    ["x", "y", "z"].iter().map(|a| format!("{} {prefix}{a}", t.name())).collect()
}

fn vertex_props(opts: &WriteOptions, normals: bool) -> Vec<String> {
    let mut props = xyz_props(real(opts), "");
    if normals {
        props.extend(xyz_props(real(opts), "n"));
    }
    props
}

const RGB: [&str; 3] = ["uchar red", "uchar green", "uchar blue"];

fn write_rgb(body: &mut Body, c: Option<&[u8; 3]>) {
    c.into_iter().flatten().for_each(|&v| body.value(ScalarType::U8, v as f64));
}

fn write_point(body: &mut Body, t: ScalarType, p: &Point3, n: Option<&Vector3>) {
    for c in p.iter() {
        body.value(t, *c);
    }
    for c in n.into_iter().flat_map(|n| n.iter()) {
        body.value(t, *c);
    }
}

/// A point cloud as PLY bytes: `x y z`, then `nx ny nz`, `red green blue` (uchar), `confidence` (float)
/// and `view_id` (uint) where present.
pub fn cloud_to_bytes(cloud: &PointCloud, opts: &WriteOptions) -> Vec<u8> {
    let opts = &opts.holding(&cloud.positions);
    let t = real(opts);
    let mut props = vertex_props(opts, cloud.normals.is_some());
    if cloud.colors.is_some() {
        props.extend(RGB.map(String::from));
    }
    if cloud.confidence.is_some() {
        props.push("float confidence".into());
    }
    // `int`, not `uint`: Open3D's attribute reader skips unsigned types other than uchar. (Ids beyond
    // int's range, which no scan has, keep `uint` rather than wrap.)
    let id_type = match &cloud.view_id {
        Some(ids) if ids.iter().any(|&v| v > i32::MAX as u32) => ScalarType::U32,
        _ => ScalarType::I32,
    };
    if cloud.view_id.is_some() {
        props.push(format!("{} view_id", id_type.name()));
    }
    let mut out = header(opts, &[("vertex", cloud.len(), props)]);
    // Runs of points written side by side and joined in order: the same bytes as one after another
    // (each entry starts a line afresh), in a fraction of the time on millions of points.
    let runs: Vec<Vec<u8>> = (0..cloud.len().div_ceil(CHUNK_POINTS))
        .into_par_iter()
        .map(|run| {
            let start = run * CHUNK_POINTS;
            let mut body = Body { out: Vec::new(), encoding: opts.encoding, first_on_line: true };
            for i in start..(start + CHUNK_POINTS).min(cloud.len()) {
                write_point(&mut body, t, &cloud.positions[i], cloud.normals.as_ref().map(|n| &n[i]));
                write_rgb(&mut body, cloud.colors.as_ref().map(|c| &c[i]));
                if let Some(c) = &cloud.confidence {
                    body.value(ScalarType::F32, c[i] as f64);
                }
                if let Some(v) = &cloud.view_id {
                    body.value(id_type, v[i] as f64);
                }
                body.end_entry();
            }
            body.out
        })
        .collect();
    out.reserve(runs.iter().map(Vec::len).sum());
    runs.iter().for_each(|r| out.extend_from_slice(r));
    out
}

/// Points per run of a cloud's body written on one thread.
const CHUNK_POINTS: usize = 1 << 16;

/// A polygon mesh as PLY bytes: vertices (with normals and `red green blue` where present), faces as
/// `list uchar int vertex_indices` (quads as 4-lists). A face with more than 255 corners does not fit a
/// `uchar` count; such a mesh gets a `ushort` (or `uint`) count, which PLY readers take as well, so
/// every polygon is written as it is. Faces of mixed sizes (a quad-dominant mesh) are written as ASCII
/// even when binary is asked for, and the header says so: binary readers that size every list by the
/// first (trimesh: "PLY is unexpected length!") cannot read them otherwise.
pub fn mesh_to_bytes(mesh: &PolyMesh, opts: &WriteOptions) -> Vec<u8> {
    let opts = &opts.holding(&mesh.vertices);
    let t = real(opts);
    let largest = mesh.faces().map(|f| f.len()).max().unwrap_or(0);
    let smallest = mesh.faces().map(|f| f.len()).min().unwrap_or(0);
    let mut opts = opts.clone();
    if smallest != largest && opts.encoding != Encoding::Ascii {
        opts.encoding = Encoding::Ascii;
        opts.comments.push("ascii: faces of mixed sizes, which binary PLY readers size wrongly".into());
    }
    let (count_type, count_name) = match largest {
        0..=255 => (ScalarType::U8, "uchar"),
        256..=65_535 => (ScalarType::U16, "ushort"),
        _ => (ScalarType::U32, "uint"),
    };
    let mut props = vertex_props(&opts, mesh.normals.is_some());
    if mesh.colors.is_some() {
        props.extend(RGB.map(String::from));
    }
    let elements = [
        ("vertex", mesh.vertices.len(), props),
        ("face", mesh.face_count(), vec![format!("list {count_name} int vertex_indices")]),
    ];
    let mut body = Body { out: header(&opts, &elements), encoding: opts.encoding, first_on_line: true };
    for (i, p) in mesh.vertices.iter().enumerate() {
        write_point(&mut body, t, p, mesh.normals.as_ref().map(|n| &n[i]));
        write_rgb(&mut body, mesh.colors.as_ref().map(|c| &c[i]));
        body.end_entry();
    }
    for f in mesh.faces() {
        body.value(count_type, f.len() as f64);
        f.iter().for_each(|&v| body.value(ScalarType::I32, v as f64));
        body.end_entry();
    }
    body.out
}

/// Writes a point cloud atomically (see [`cloud_to_bytes`]).
pub fn write_cloud(path: &Path, cloud: &PointCloud, opts: &WriteOptions) -> Result<(), Error> {
    write_atomic(path, &cloud_to_bytes(cloud, opts))
}

/// Writes a polygon mesh atomically (see [`mesh_to_bytes`]).
pub fn write_mesh(path: &Path, mesh: &PolyMesh, opts: &WriteOptions) -> Result<(), Error> {
    write_atomic(path, &mesh_to_bytes(mesh, opts))
}

/// A range grid as a point cloud every reader opens: its valid cells as `vertex` (with normals,
/// `red green blue` and `confidence` where the grid has them), each with its cell as `int grid_col
/// grid_row`, the grid's size as `obj_info num_cols/num_rows`, and the sensor as a `comment sensor …`
/// line; [`range_grid_from_ply`](super::range_grid_from_ply) reads it back, and reads Stanford's
/// `range_grid` element too. (Written as Stanford's layout, a list of 0 or 1 index per cell, the file
/// was one that binary readers which size every list by the first, trimesh among them, refuse.)
pub fn range_grid_to_bytes(grid: &RangeGrid, opts: &WriteOptions) -> Vec<u8> {
    let opts = &opts.holding(valid_points(grid));
    let t = real(opts);
    let mut props = vertex_props(opts, grid.normals.is_some());
    if grid.colors.is_some() {
        props.extend(RGB.map(String::from));
    }
    if grid.confidence.is_some() {
        props.push("float confidence".into());
    }
    props.extend(["int grid_col", "int grid_row"].map(String::from));
    let valid: Vec<usize> = (0..grid.valid.len()).filter(|&i| grid.valid[i]).collect();
    let opts = with_sensor(opts, &grid.sensor);
    let head = with_size(header(&opts, &[("vertex", valid.len(), props)]), grid.width, grid.height);
    let mut body = Body { out: head, encoding: opts.encoding, first_on_line: true };
    for &i in &valid {
        write_point(&mut body, t, &grid.points[i], grid.normals.as_ref().map(|n| &n[i]));
        write_rgb(&mut body, grid.colors.as_ref().map(|c| &c[i]));
        if let Some(c) = &grid.confidence {
            body.value(ScalarType::F32, c[i] as f64);
        }
        body.value(ScalarType::I32, (i % grid.width) as f64);
        body.value(ScalarType::I32, (i / grid.width) as f64);
        body.end_entry();
    }
    body.out
}

/// A range grid's valid points (the rest hold nothing written).
pub(super) fn valid_points(grid: &RangeGrid) -> impl Iterator<Item = &Point3> {
    grid.points.iter().zip(&grid.valid).filter(|(_, v)| **v).map(|(p, _)| p)
}

/// The options with the sensor as a `comment sensor …` line (a per-cell sensor is not written).
fn with_sensor(opts: &WriteOptions, sensor: &Sensor) -> WriteOptions {
    let mut opts = opts.clone();
    match sensor {
        Sensor::Center(c) => opts.comments.push(format!("sensor center {} {} {}", c.x, c.y, c.z)),
        Sensor::Direction(d) => opts.comments.push(format!("sensor direction {} {} {}", d.x, d.y, d.z)),
        Sensor::PerCell(_) => {}
    }
    opts
}

/// The header with the image size as `obj_info num_cols/num_rows`, before the elements as in the
/// Stanford files.
fn with_size(mut head: Vec<u8>, width: usize, height: usize) -> Vec<u8> {
    let info = format!("obj_info num_cols {width}\nobj_info num_rows {height}\n");
    let at = head.windows(8).position(|w| w == b"element ").expect("the header has elements");
    head.splice(at..at, info.into_bytes());
    head
}

/// A sparse view as PLY bytes: a plain point cloud every reader opens (`x y z`, `float confidence`),
/// each vertex with the pixel it was seen at (`float px_col px_row`), the image size as
/// `obj_info num_cols/num_rows` and the sensor as a `comment sensor …` line, which
/// [`sparse_view_from_ply`](super::sparse_view_from_ply) reads back.
pub fn sparse_view_to_bytes(view: &SparseView, opts: &WriteOptions) -> Vec<u8> {
    let opts = &opts.holding(&view.points);
    let t = real(opts);
    let mut props = vertex_props(opts, false);
    if view.colors.is_some() {
        props.extend(RGB.map(String::from));
    }
    props.extend(["float confidence", "float px_col", "float px_row"].map(String::from));
    let opts = with_sensor(opts, &view.sensor);
    let head = with_size(header(&opts, &[("vertex", view.len(), props)]), view.width, view.height);
    let mut body = Body { out: head, encoding: opts.encoding, first_on_line: true };
    for i in 0..view.len() {
        write_point(&mut body, t, &view.points[i], None);
        write_rgb(&mut body, view.colors.as_ref().map(|c| &c[i]));
        body.value(ScalarType::F32, view.confidence[i] as f64);
        body.value(ScalarType::F32, view.pixels[i][0] as f64);
        body.value(ScalarType::F32, view.pixels[i][1] as f64);
        body.end_entry();
    }
    body.out
}

/// Writes a range grid atomically (see [`range_grid_to_bytes`]).
pub fn write_range_grid(path: &Path, grid: &RangeGrid, opts: &WriteOptions) -> Result<(), Error> {
    write_atomic(path, &range_grid_to_bytes(grid, opts))
}
