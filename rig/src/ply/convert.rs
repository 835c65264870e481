//! From a raw [`PlyFile`] to clouds, meshes and range grids.

use super::{Element, PlyFile};
use crate::error::{Location, ParseError, Problem};
use crate::math::{Point3, UnitVector3, Vector3};
use crate::range_grid::{RangeGrid, Sensor};
use crate::{PointCloud, PolyMesh, SparseView};

fn at(el: &Element, index: usize) -> Location {
    Location::Element { name: el.def.name.clone(), index: index as u64, line: None }
}

fn missing(what: String) -> ParseError {
    ParseError::new(Location::File, Problem::Missing(what))
}

fn vertex_element(ply: &PlyFile) -> Result<&Element, ParseError> {
    ply.element("vertex").ok_or_else(|| missing("element `vertex`".into()))
}

/// Positions from `x y z`, refusing NaN and infinities.
fn positions(v: &Element) -> Result<Vec<Point3>, ParseError> {
    let col = |n: &str| v.scalar(n).ok_or_else(|| missing(format!("scalar property `{n}` of element `vertex`")));
    let (x, y, z) = (col("x")?, col("y")?, col("z")?);
    (0..v.len())
        .map(|i| {
            let p = Point3::new(x[i], y[i], z[i]);
            if p.iter().all(|c| c.is_finite()) {
                Ok(p)
            } else {
                Err(ParseError::new(at(v, i), Problem::NonFinite(format!("position ({}, {}, {})", x[i], y[i], z[i]))))
            }
        })
        .collect()
}

fn normals(v: &Element) -> Option<Vec<Vector3>> {
    let (x, y, z) = (v.scalar("nx")?, v.scalar("ny")?, v.scalar("nz")?);
    Some((0..v.len()).map(|i| Vector3::new(x[i], y[i], z[i])).collect())
}

/// `red green blue` (or `diffuse_*`), scaled to 8 bits by their type: `uchar` as it is, `ushort` (16-bit
/// colour, 0–65535) scaled by 255/65535, float types 0–1 scaled by 255. A float colour above 1 is taken
/// as written 0–255 (as some tools do) when every value of the three channels is within 0–255. Any other
/// value outside its range (a negative one, an `int` colour above 255, a float beyond 255) is refused,
/// naming the entry: nothing is clamped in silence.
fn colors(v: &Element) -> Result<Option<Vec<[u8; 3]>>, ParseError> {
    let names = [["red", "green", "blue"], ["diffuse_red", "diffuse_green", "diffuse_blue"]];
    let Some((names, cols)) = names.iter().find_map(|n| Some((n, [v.scalar(n[0])?, v.scalar(n[1])?, v.scalar(n[2])?])))
    else {
        return Ok(None);
    };
    let ty = |name: &str| {
        v.def.properties.iter().find(|p| p.name == name).and_then(|p| match p.kind {
            super::PropertyKind::Scalar(t) => Some(t),
            _ => None,
        })
    };
    let mut out = vec![[0u8; 3]; v.len()];
    for (c, (name, col)) in names.iter().zip(cols).enumerate() {
        let t = ty(name).unwrap_or(super::ScalarType::U8);
        let is_float = !t.is_integer();
        let max = col.iter().fold(0.0f64, |m, &x| m.max(x));
        let (scale, top) = match t {
            super::ScalarType::U16 => (255.0 / 65535.0, 65535.0),
            _ if is_float && max <= 1.0 => (255.0, 1.0),
            _ => (1.0, 255.0),
        };
        for (i, &x) in col.iter().enumerate() {
            if !(0.0..=top).contains(&x) {
                let range = if is_float {
                    "0–1 (or 0–255 written as floats)"
                } else if top > 255.0 {
                    "0–65535"
                } else {
                    "0–255"
                };
                let msg = format!("colour `{name}` {x} is outside {range} for its type `{}`", t.name());
                return Err(ParseError::new(at(v, i), Problem::Invalid(msg)));
            }
            out[i][c] = (x * scale).round() as u8;
        }
    }
    Ok(Some(out))
}

/// The `vertex` element as a point cloud.
pub fn cloud_from_ply(ply: &PlyFile) -> Result<PointCloud, ParseError> {
    let v = vertex_element(ply)?;
    Ok(PointCloud {
        positions: positions(v)?,
        normals: normals(v),
        colors: colors(v)?,
        confidence: v.scalar("confidence").map(|c| c.iter().map(|&x| x as f32).collect()),
        view_id: v.scalar("view_id").map(|c| c.iter().map(|&x| x as u32).collect()),
    })
}

/// Checks a vertex index and converts it: a whole number (a float list type may hold 1.5 or NaN,
/// which would otherwise be cut to an index silently) within the vertices.
fn index(el: &Element, entry: usize, raw: f64, count: usize) -> Result<u32, ParseError> {
    if raw.fract() != 0.0 || !raw.is_finite() {
        return Err(ParseError::new(at(el, entry), Problem::FractionalIndex(raw.to_string())));
    }
    if raw >= 0.0 && raw < count as f64 {
        Ok(raw as u32)
    } else {
        let index = raw.to_string().into();
        Err(ParseError::new(at(el, entry), Problem::IndexOutOfRange { index, what: "vertex", count, first: 0 }))
    }
}

/// A mesh from `face` (lists of any size) or, failing that, `tristrips`.
pub fn mesh_from_ply(ply: &PlyFile) -> Result<PolyMesh, ParseError> {
    let v = vertex_element(ply)?;
    let mut mesh = PolyMesh { vertices: positions(v)?, normals: normals(v), colors: colors(v)?, ..Default::default() };
    let n = mesh.vertices.len();
    if let Some(f) = ply.element("face") {
        let (_, offsets, values) = f.first_list().ok_or_else(|| missing("a list property of element `face`".into()))?;
        mesh.indices.reserve(values.len());
        mesh.offsets.reserve(f.len());
        let mut face = Vec::new();
        for i in 0..f.len() {
            let raw = &values[offsets[i]..offsets[i + 1]];
            if raw.len() < 3 {
                return Err(ParseError::new(at(f, i), Problem::DegenerateFace(raw.len())));
            }
            face.clear();
            for &r in raw {
                face.push(index(f, i, r, n)?);
            }
            mesh.push_face(&face);
        }
    } else if let Some(s) = ply.element("tristrips") {
        let (_, offsets, values) =
            s.first_list().ok_or_else(|| missing("a list property of element `tristrips`".into()))?;
        for i in 0..s.len() {
            // Strips are separated by −1; each new vertex makes a triangle with the two before it, every
            // other one reversed to keep a consistent orientation; repeated vertices are stitching.
            for strip in values[offsets[i]..offsets[i + 1]].split(|&x| x == -1.0) {
                let strip: Vec<u32> = strip.iter().map(|&r| index(s, i, r, n)).collect::<Result<_, _>>()?;
                for k in 2..strip.len() {
                    let (a, b, c) = (strip[k - 2], strip[k - 1], strip[k]);
                    if a == b || b == c || a == c {
                        continue;
                    }
                    mesh.push_face(&if k % 2 == 0 { [a, b, c] } else { [b, a, c] });
                }
            }
        }
    } else {
        return Err(missing("element `face` or `tristrips`".into()));
    }
    Ok(mesh)
}

/// The image size from `obj_info num_cols` and `num_rows`.
fn image_size(ply: &PlyFile) -> Result<(usize, usize), ParseError> {
    let dim = |key: &str| {
        ply.header
            .obj_info_value(key)
            .and_then(|s| s.parse::<usize>().ok())
            .ok_or_else(|| missing(format!("`obj_info {key}` (the scan's image size)")))
    };
    Ok((dim("num_cols")?, dim("num_rows")?))
}

/// The sensor, where a `comment sensor center|direction x y z` line gives it (scanrig writes one);
/// otherwise the Cyberware convention of a sensor toward +z.
fn sensor(ply: &PlyFile) -> Sensor {
    ply.header
        .comments
        .iter()
        .find_map(|c| {
            let w: Vec<&str> = c.split_whitespace().collect();
            let v = |k: usize| w.get(k).and_then(|s| s.parse::<f64>().ok());
            match (w.first(), w.get(1)) {
                (Some(&"sensor"), Some(&"center")) => Some(Sensor::Center(Point3::new(v(2)?, v(3)?, v(4)?))),
                (Some(&"sensor"), Some(&"direction")) => {
                    UnitVector3::try_new(Vector3::new(v(2)?, v(3)?, v(4)?), 1e-12).map(Sensor::Direction)
                }
                _ => None,
            }
        })
        .unwrap_or(Sensor::Direction(UnitVector3::new_unchecked(Vector3::z())))
}

/// The largest image a sparse view may claim: 2³⁰ pixels (a 32768 × 32768 sensor).
const MAX_SPARSE_PIXELS: usize = 1 << 30;
/// The most cells a range grid may have: more than any camera (134 megapixels).
const MAX_GRID_CELLS: usize = 1 << 27;

/// A sparse view (see [`sparse_view_to_bytes`](super::sparse_view_to_bytes)): vertices with
/// `px_col px_row` and, where present, `confidence` (else 1); the image size from `obj_info`. A pixel
/// outside the image or not finite is refused, naming the vertex; so is an image no camera has
/// (empty, or over 2³⁰ pixels: a grid of it could not be allocated).
pub fn sparse_view_from_ply(ply: &PlyFile) -> Result<SparseView, ParseError> {
    let v = vertex_element(ply)?;
    let points = positions(v)?;
    let (width, height) = image_size(ply)?;
    if width == 0 || height == 0 || width.checked_mul(height).is_none_or(|n| n > MAX_SPARSE_PIXELS) {
        let msg = format!("obj_info gives a {width} × {height} image, which no camera has");
        return Err(ParseError::new(Location::File, Problem::Invalid(msg)));
    }
    let col = |n: &str| v.scalar(n).ok_or_else(|| missing(format!("scalar property `{n}` of element `vertex`")));
    let (cols, rows) = (col("px_col")?, col("px_row")?);
    let mut view = SparseView::empty(width, height, sensor(ply));
    let conf = v.scalar("confidence");
    for (i, p) in points.into_iter().enumerate() {
        let (c, r) = (cols[i], rows[i]);
        // Pixel centres run from 0 to size − 1; half a pixel beyond is still on the sensor.
        let inside = |x: f64, n: usize| x.is_finite() && x >= -0.5 && x <= n as f64 - 0.5;
        if !inside(c, width) || !inside(r, height) {
            let msg = format!("pixel ({c}, {r}) lies outside the {width} × {height} image");
            return Err(ParseError::new(at(v, i), Problem::Invalid(msg)));
        }
        view.push(p, [c as f32, r as f32], conf.map_or(1.0, |k| k[i] as f32));
    }
    view.colors = colors(v)?;
    Ok(view)
}

/// A range scan on its grid, sized by `obj_info num_cols` and `num_rows`, with normals, colours and
/// confidence where the vertices have them, in either layout: scanrig's (each vertex with its cell as
/// `grid_col grid_row`) or Stanford's (a `range_grid` element: one list of 0 or 1 vertex index per cell,
/// row-major). The sensor comes from a `comment sensor …` line, else it is the Cyberware's: looking along
/// −z, so `Sensor::Direction(+z)`.
pub fn range_grid_from_ply(ply: &PlyFile) -> Result<RangeGrid, ParseError> {
    let v = vertex_element(ply)?;
    let pts = positions(v)?;
    let (w, h) = image_size(ply)?;
    // A grid is allocated whole: bounded by a camera's size (2²⁷ cells, 3 GB of grid), not the file's.
    let cells = w.checked_mul(h).filter(|&n| n <= MAX_GRID_CELLS).ok_or_else(|| {
        let msg = format!("obj_info gives a {w} × {h} grid, which no camera has");
        ParseError::new(Location::File, Problem::Invalid(msg))
    })?;
    // Each vertex's cell, whichever the layout.
    let mut placed: Vec<(usize, usize)> = Vec::with_capacity(pts.len());
    if let (Some(cols), Some(rows)) = (v.scalar("grid_col"), v.scalar("grid_row")) {
        for k in 0..pts.len() {
            let (c, r) = (cols[k], rows[k]);
            if c.fract() != 0.0 || r.fract() != 0.0 || !(0.0..w as f64).contains(&c) || !(0.0..h as f64).contains(&r) {
                let msg = format!("cell ({c}, {r}) is not a cell of the {w} × {h} grid");
                return Err(ParseError::new(at(v, k), Problem::Invalid(msg)));
            }
            placed.push((r as usize * w + c as usize, k));
        }
    } else {
        let g = ply
            .element("range_grid")
            .ok_or_else(|| missing("element `range_grid`, or vertex properties `grid_col` and `grid_row`".into()))?;
        if cells != g.len() {
            let msg = format!("range_grid has {} cells but obj_info says {w} × {h}", g.len());
            return Err(ParseError::new(Location::File, Problem::Invalid(msg)));
        }
        let (_, offsets, values) =
            g.first_list().ok_or_else(|| missing("a list property of element `range_grid`".into()))?;
        for cell in 0..g.len() {
            match &values[offsets[cell]..offsets[cell + 1]] {
                [] => {}
                [r] => placed.push((cell, index(g, cell, *r, pts.len())? as usize)),
                more => {
                    let msg = format!("a range-grid cell holds {} vertices; at most 1 is allowed", more.len());
                    return Err(ParseError::new(at(g, cell), Problem::Invalid(msg)));
                }
            }
        }
    }
    let mut grid = RangeGrid::empty(w, h, sensor(ply));
    let (vn, vc, vrgb) = (normals(v), v.scalar("confidence"), colors(v)?);
    let mut cell_normals = vn.as_ref().map(|_| vec![Vector3::zeros(); cells]);
    let mut cell_conf = vc.map(|_| vec![0.0f32; cells]);
    let mut cell_rgb = vrgb.as_ref().map(|_| vec![[0u8; 3]; cells]);
    for (cell, k) in placed {
        if grid.valid[cell] {
            let msg = format!("two vertices on grid cell ({}, {})", cell % w, cell / w);
            return Err(ParseError::new(at(v, k), Problem::Invalid(msg)));
        }
        grid.points[cell] = pts[k];
        grid.valid[cell] = true;
        if let (Some(dst), Some(src)) = (cell_normals.as_mut(), vn.as_ref()) {
            dst[cell] = src[k];
        }
        if let (Some(dst), Some(src)) = (cell_conf.as_mut(), vc) {
            dst[cell] = src[k] as f32;
        }
        if let (Some(dst), Some(src)) = (cell_rgb.as_mut(), vrgb.as_ref()) {
            dst[cell] = src[k];
        }
    }
    grid.normals = cell_normals;
    grid.confidence = cell_conf;
    grid.colors = cell_rgb;
    Ok(grid)
}
