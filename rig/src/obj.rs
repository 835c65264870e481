//! Wavefront OBJ: the common subset (`v`, `vn`, `vt`, `f` with `v`, `v/vt`, `v//vn`, `v/vt/vn` corners,
//! negative relative indices, polygons of any size). Grouping, material and smoothing statements are
//! read past; an unknown statement is an error, so a file that is not OBJ is not read as an empty mesh.

use crate::error::{Error, Location, ParseError, Problem};
use crate::math::{Point3, Vector3};
use crate::run_files::{read_bytes, write_atomic};
use crate::{PointCloud, PolyMesh};
use std::io::Write;
use std::path::Path;

/// Statements read past: grouping, materials, smoothing, free-form geometry and display attributes.
const IGNORED: &[&str] = &[
    "vt",
    "vp",
    "o",
    "g",
    "s",
    "mg",
    "usemtl",
    "mtllib",
    "l",
    "p",
    "cstype",
    "deg",
    "bmat",
    "step",
    "curv",
    "curv2",
    "surf",
    "parm",
    "trim",
    "hole",
    "scrv",
    "sp",
    "end",
    "con",
    "bevel",
    "c_interp",
    "d_interp",
    "lod",
    "usemap",
    "maplib",
    "shadow_obj",
    "trace_obj",
    "ctech",
    "stech",
    "call",
    "csh",
];

/// What an OBJ file holds, beyond the mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjFile {
    /// Vertices, faces, and per-vertex normals where the file pairs each vertex with one normal.
    pub mesh: PolyMesh,
    /// Per-vertex colours from `v x y z r g b` lines, when every vertex has one: 0–1 floats scaled to
    /// 0–255; a file whose colours go above 1 (written 0–255, as some tools do) is read as 8-bit values.
    pub colors: Option<Vec<[u8; 3]>>,
    /// Number of `vn` lines.
    pub normal_count: usize,
    /// Number of `vt` lines.
    pub texcoord_count: usize,
    /// What the file holds that this reading does not keep (colours on only some vertices, normals
    /// given per face corner), one sentence each: nothing is dropped in silence.
    pub warnings: Vec<String>,
}

fn number(tok: &str, line: usize) -> Result<f64, ParseError> {
    tok.parse::<f64>()
        .map_err(|_| ParseError::new(Location::Line(line), Problem::NotANumber(tok.chars().take(40).collect())))
}

/// Resolves a 1-based (or negative, relative) OBJ index against the `count` items of `what` so far.
fn resolve(tok: &str, count: usize, what: &'static str, line: usize) -> Result<usize, ParseError> {
    let at = Location::Line(line);
    let shown = || tok.chars().take(40).collect::<String>();
    let i: i64 = tok.parse().map_err(|_| ParseError::new(at.clone(), Problem::NotANumber(shown())))?;
    let zero_based = if i < 0 { count as i64 + i } else { i - 1 };
    if i == 0 || zero_based < 0 || zero_based >= count as i64 {
        return Err(ParseError::new(at, Problem::IndexOutOfRange { index: shown().into(), what, count, first: 1 }));
    }
    Ok(zero_based as usize)
}

/// Parses OBJ text.
pub fn parse(bytes: &[u8]) -> Result<ObjFile, ParseError> {
    let text = String::from_utf8_lossy(bytes);
    let mut mesh = PolyMesh::default();
    // Each colour as written, with its line: the scale (0–1 or 0–255) is decided once all are read.
    let mut colors: Vec<([f64; 3], usize)> = Vec::new();
    let mut normals: Vec<Vector3> = Vec::new();
    let mut texcoord_count = 0usize;
    // The normal each vertex is paired with by the faces; any vertex paired with two different normals
    // means the file's normals are per corner, which a per-vertex mesh cannot hold.
    let mut vertex_normal: Vec<Option<usize>> = Vec::new();
    let mut normals_consistent = true;
    // Whether every corner names the normal with its vertex's own index, as scanrig (and MeshLab) write.
    let mut paired_by_index = true;
    let mut face = Vec::new();
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let content = raw.split('#').next().unwrap_or("");
        let mut toks = content.split_whitespace();
        let Some(kw) = toks.next() else { continue };
        let nums = |toks: std::str::SplitWhitespace<'_>| toks.map(|t| number(t, line)).collect::<Result<Vec<_>, _>>();
        match kw {
            "v" => {
                let v = nums(toks)?;
                if v.len() < 3 {
                    return Err(ParseError::new(
                        Location::Line(line),
                        Problem::Invalid(format!("`v` needs 3 coordinates, has {}", v.len())),
                    ));
                }
                if v.iter().take(3).any(|c| !c.is_finite()) {
                    return Err(ParseError::new(Location::Line(line), Problem::NonFinite("vertex position".into())));
                }
                mesh.vertices.push(Point3::new(v[0], v[1], v[2]));
                vertex_normal.push(None);
                if v.len() == 6 {
                    colors.push(([v[3], v[4], v[5]], line));
                }
            }
            "vn" => {
                let v = nums(toks)?;
                if v.len() != 3 {
                    return Err(ParseError::new(
                        Location::Line(line),
                        Problem::Invalid(format!("`vn` needs 3 components, has {}", v.len())),
                    ));
                }
                normals.push(Vector3::new(v[0], v[1], v[2]));
            }
            "f" => {
                face.clear();
                for corner in toks {
                    let mut parts = corner.split('/');
                    let v = resolve(parts.next().unwrap_or(""), mesh.vertices.len(), "vertex", line)?;
                    let _vt = parts
                        .next()
                        .filter(|s| !s.is_empty())
                        .map(|t| resolve(t, texcoord_count, "texture coordinate", line))
                        .transpose()?;
                    let vn = parts
                        .next()
                        .filter(|s| !s.is_empty())
                        .map(|t| resolve(t, normals.len(), "normal", line))
                        .transpose()?;
                    paired_by_index &= vn == Some(v);
                    match (vertex_normal[v], vn) {
                        (_, None) => normals_consistent = false,
                        (None, Some(n)) => vertex_normal[v] = Some(n),
                        (Some(old), Some(n)) if old != n && normals[old] != normals[n] => normals_consistent = false,
                        _ => {}
                    }
                    face.push(v as u32);
                }
                if face.len() < 3 {
                    return Err(ParseError::new(Location::Line(line), Problem::DegenerateFace(face.len())));
                }
                mesh.push_face(&face);
            }
            "vt" => texcoord_count += 1,
            _ if IGNORED.contains(&kw) => {}
            _ => {
                let shown: String = kw.chars().take(40).collect();
                return Err(ParseError::new(
                    Location::Line(line),
                    Problem::Invalid(format!("unknown OBJ statement `{shown}`")),
                ));
            }
        }
    }
    if !normals.is_empty() && normals.len() == mesh.vertices.len() && paired_by_index {
        // The n-th normal belongs to the n-th vertex (also a point cloud written as `v`/`vn` pairs).
        mesh.normals = Some(normals.clone());
    } else if normals_consistent && !normals.is_empty() && vertex_normal.iter().all(Option::is_some) {
        mesh.normals = Some(vertex_normal.iter().map(|n| normals[n.unwrap()]).collect());
    }
    let mut warnings = Vec::new();
    if !normals.is_empty() && mesh.normals.is_none() {
        warnings.push(format!(
            "its {} normals (`vn`) are not kept: the faces do not give each vertex one normal",
            normals.len()
        ));
    }
    let colors = if colors.is_empty() {
        None
    } else if colors.len() != mesh.vertices.len() {
        warnings.push(format!(
            "its vertex colours are not kept: {} of {} vertices have one",
            colors.len(),
            mesh.vertices.len()
        ));
        None
    } else {
        // Written 0–1 (the usual) or 0–255 (some tools): any value above 1 says the latter.
        let max = colors.iter().flat_map(|(c, _)| *c).fold(0.0f64, f64::max);
        let (scale, top, range) = if max > 1.0 { (1.0, 255.0, "0–255") } else { (255.0, 1.0, "0–1") };
        let mut out = Vec::with_capacity(colors.len());
        for (c, line) in colors {
            if let Some(x) = c.iter().find(|x| !(0.0..=top).contains(*x)) {
                let msg = format!("vertex colour {x} is outside {range}, the range the file's other colours are in");
                return Err(ParseError::new(Location::Line(line), Problem::Invalid(msg)));
            }
            out.push(c.map(|x| (x * scale).round() as u8));
        }
        Some(out)
    };
    Ok(ObjFile { mesh, colors, normal_count: normals.len(), texcoord_count, warnings })
}

/// Reads an OBJ file.
pub fn read(path: &Path) -> Result<ObjFile, Error> {
    parse(&read_bytes(path)?).map_err(|e| e.with_path(path))
}

fn write_vertices(out: &mut Vec<u8>, positions: &[Point3], colors: Option<&[[u8; 3]]>, normals: Option<&[Vector3]>) {
    for (i, p) in positions.iter().enumerate() {
        let _ = write!(out, "v {} {} {}", p.x, p.y, p.z);
        if let Some(c) = colors {
            let _ = write!(out, " {} {} {}", c[i][0] as f64 / 255.0, c[i][1] as f64 / 255.0, c[i][2] as f64 / 255.0);
        }
        out.push(b'\n');
    }
    for n in normals.into_iter().flatten() {
        let _ = writeln!(out, "vn {} {} {}", n.x, n.y, n.z);
    }
}

/// The comment lines scanrig starts an OBJ file with: who wrote it, and the data's unit where it is
/// known (`# units m`, which [`stated_units`] reads back: OBJ has no unit of its own, and a file
/// without one is taken for millimetres).
fn header(units: Option<&str>) -> Vec<u8> {
    let mut out = format!("# written by scanrig {}\n", env!("CARGO_PKG_VERSION")).into_bytes();
    if let Some(u) = units {
        let _ = writeln!(out, "# units {u}");
    }
    out
}

/// The unit an OBJ file's leading comments give its data (`# units m`, as scanrig writes them), or
/// `None`. Only the comments before the first statement are read.
pub fn stated_units(path: &Path) -> Result<Option<String>, Error> {
    let bytes = crate::run_files::read_prefix(path, 1 << 16)?;
    for line in String::from_utf8_lossy(&bytes).lines() {
        let line = line.trim();
        let Some(comment) = line.strip_prefix('#') else {
            if line.is_empty() {
                continue;
            }
            break;
        };
        let mut words = comment.split_whitespace();
        if words.next() == Some("units") {
            return Ok(words.next().map(str::to_string));
        }
    }
    Ok(None)
}

/// A mesh as OBJ text: `v` (with colours, and `vn`, where the mesh has them), then `f` lines,
/// triangles and quads alike, in `units` where known (a `# units` comment). Coordinates are written
/// in shortest round-trip form, so reading gives back the same values.
pub fn mesh_to_bytes(mesh: &PolyMesh, units: Option<&str>) -> Vec<u8> {
    let mut out = header(units);
    write_vertices(&mut out, &mesh.vertices, mesh.colors.as_deref(), mesh.normals.as_deref());
    for f in mesh.faces() {
        out.push(b'f');
        for &v in f {
            let _ = if mesh.normals.is_some() { write!(out, " {0}//{0}", v + 1) } else { write!(out, " {}", v + 1) };
        }
        out.push(b'\n');
    }
    out
}

/// A point cloud as OBJ text: `v x y z [r g b]` and `vn` lines (OBJ has no place for confidence or
/// view ids; use PLY to keep them), in `units` where known (a `# units` comment).
pub fn cloud_to_bytes(cloud: &PointCloud, units: Option<&str>) -> Vec<u8> {
    let mut out = header(units);
    write_vertices(&mut out, &cloud.positions, cloud.colors.as_deref(), cloud.normals.as_deref());
    out
}

/// Writes a mesh as OBJ, atomically, saying its `units` where known.
pub fn write_mesh(path: &Path, mesh: &PolyMesh, units: Option<&str>) -> Result<(), Error> {
    write_atomic(path, &mesh_to_bytes(mesh, units))
}

/// Writes a point cloud as OBJ, atomically, saying its `units` where known.
pub fn write_cloud(path: &Path, cloud: &PointCloud, units: Option<&str>) -> Result<(), Error> {
    write_atomic(path, &cloud_to_bytes(cloud, units))
}
