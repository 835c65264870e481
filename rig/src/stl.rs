//! STL, the file slicers print from: binary (the default, as every slicer and CAD tool writes it) or
//! ASCII on request; both read back. Binary writing and ASCII reading are the `stl_io` crate's (see the
//! README's list of crates); ASCII writing and binary reading are the few lines of their layouts below
//! (stl_io decides binary or ASCII by the first bytes alone, and many binary headers start with "solid").
//!
//! STL holds triangles only, each with its own copy of its corners: polygons are fanned into triangles
//! on writing, and reading merges corners with identical coordinates back into shared vertices, so a
//! closed mesh reads back closed.

use crate::error::{Error, Location, ParseError, Problem};
use crate::math::{Point3, Vector3};
use crate::mesh::{PolyMesh, TriMesh};
use crate::run_files::{read_bytes, write_atomic};
use std::path::Path;

/// A face's unit normal (counter-clockwise seen from outside), zero for a degenerate face as the format
/// allows.
fn face_normal(m: &TriMesh, f: &[u32; 3]) -> [f32; 3] {
    let [a, b, c] = f.map(|i| m.vertices[i as usize]);
    let n = (b - a).cross(&(c - a)).try_normalize(1e-300).unwrap_or_else(Vector3::zeros);
    [n.x as f32, n.y as f32, n.z as f32]
}

/// A mesh as binary STL bytes (80-byte header naming scanrig, then the triangles).
pub fn mesh_to_binary(mesh: &PolyMesh) -> Vec<u8> {
    let m = mesh.triangulate();
    let v = |i: u32| {
        let p = m.vertices[i as usize];
        stl_io::Vertex::new([p.x as f32, p.y as f32, p.z as f32])
    };
    let triangles: Vec<stl_io::Triangle> = m
        .faces
        .iter()
        .map(|f| stl_io::Triangle { normal: stl_io::Normal::new(face_normal(&m, f)), vertices: f.map(v) })
        .collect();
    let mut out = Vec::with_capacity(84 + 50 * triangles.len());
    // Writing into memory cannot fail.
    stl_io::write_stl(&mut out, triangles.iter()).unwrap_or_default();
    let title = format!("binary STL written by scanrig {}", env!("CARGO_PKG_VERSION"));
    // The header is free text; it must not start with "solid", which readers take for ASCII.
    out[..title.len().min(80)].copy_from_slice(&title.as_bytes()[..title.len().min(80)]);
    out
}

/// A mesh as ASCII STL bytes (`solid … facet normal … outer loop … vertex …`).
pub fn mesh_to_ascii(mesh: &PolyMesh, name: &str) -> Vec<u8> {
    use std::fmt::Write;
    let m = mesh.triangulate();
    let mut s = format!("solid {name}\n");
    for f in &m.faces {
        let n = face_normal(&m, f);
        let _ = writeln!(s, "  facet normal {:e} {:e} {:e}\n    outer loop", n[0], n[1], n[2]);
        for &i in f {
            let p = m.vertices[i as usize];
            let _ = writeln!(s, "      vertex {:e} {:e} {:e}", p.x as f32, p.y as f32, p.z as f32);
        }
        s += "    endloop\n  endfacet\n";
    }
    s += &format!("endsolid {name}\n");
    s.into_bytes()
}

/// Writes a mesh as STL, binary or ASCII, atomically.
pub fn write_mesh(path: &Path, mesh: &PolyMesh, ascii: bool) -> Result<(), Error> {
    let name = path.file_stem().map(|s| s.to_string_lossy().replace(char::is_whitespace, "_"));
    let bytes = if ascii { mesh_to_ascii(mesh, name.as_deref().unwrap_or("mesh")) } else { mesh_to_binary(mesh) };
    write_atomic(path, &bytes)
}

/// Parses STL bytes (binary or ASCII) into a triangle mesh with shared vertices. A file whose size is
/// exactly what its binary header counts is binary (its free-text header may well start with "solid");
/// otherwise text starting with `solid` is ASCII.
pub fn parse(bytes: &[u8]) -> Result<PolyMesh, ParseError> {
    let invalid = |m: String| ParseError::new(Location::File, Problem::Invalid(m));
    let counted = (bytes.len() >= 84).then(|| u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64);
    let binary = counted.is_some_and(|n| 84 + 50 * n == bytes.len() as u64);
    let text = bytes.trim_ascii_start();
    let (vertices, faces): (Vec<Point3>, Vec<[u32; 3]>) = if binary {
        binary_triangles(&bytes[84..])
    } else if text.starts_with(b"solid") {
        ascii_solids(text)?
    } else if bytes.len() < 84 {
        return Err(ParseError::new(Location::File, Problem::Truncated("the 84-byte binary STL header".into())));
    } else {
        let n = counted.unwrap_or(0);
        return Err(invalid(format!(
            "the binary header counts {n} triangles ({} bytes) but the file has {} bytes",
            84 + 50 * n,
            bytes.len()
        )));
    };
    if let Some(i) = vertices.iter().position(|p| !p.coords.iter().all(|c| c.is_finite())) {
        return Err(ParseError::new(Location::Field(format!("vertex {i}")), Problem::NonFinite("a coordinate".into())));
    }
    Ok(PolyMesh::from_faces(vertices, faces))
}

/// Every solid of an ASCII STL file (a file may hold several, one after another: all are kept, their
/// corners with identical coordinates merged across solids), each read by `stl_io`. Text after the last
/// `endsolid` that is not another solid is refused, naming its line.
fn ascii_solids(text: &[u8]) -> Result<(Vec<Point3>, Vec<[u32; 3]>), ParseError> {
    let invalid = |m: String| ParseError::new(Location::File, Problem::Invalid(m));
    // Each solid's text: from its `solid` line to the line after its `endsolid`.
    let mut solids: Vec<(usize, &[u8])> = Vec::new();
    let (mut start, mut start_line, mut pos) = (0usize, 1usize, 0usize);
    for (k, line) in text.split_inclusive(|&b| b == b'\n').enumerate() {
        pos += line.len();
        if line.trim_ascii_start().starts_with(b"endsolid") {
            solids.push((start_line, &text[start..pos]));
            start = pos;
            start_line = k + 2;
        }
    }
    let rest = &text[start..];
    if !rest.trim_ascii().is_empty() || solids.is_empty() {
        // The last solid without its `endsolid` is read as it is (stl_io says what is wrong with it).
        if !rest.trim_ascii_start().starts_with(b"solid") && !solids.is_empty() {
            return Err(ParseError::new(
                Location::Line(
                    start_line + rest.iter().take_while(|b| b.is_ascii_whitespace()).filter(|&&b| b == b'\n').count(),
                ),
                Problem::TrailingData(
                    String::from_utf8_lossy(&rest.trim_ascii()[..rest.trim_ascii().len().min(40)]).into(),
                ),
            ));
        }
        solids.push((start_line, rest));
    }
    let mut index: std::collections::HashMap<[u32; 3], u32> = std::collections::HashMap::new();
    let (mut vertices, mut faces) = (Vec::new(), Vec::new());
    for (n, (line, solid)) in solids.iter().enumerate() {
        let solid = solid.trim_ascii_start();
        // stl_io wants `solid ` at the very start; files start with blanks, or `solid` and a newline.
        let mut normal = b"solid ".to_vec();
        normal.extend_from_slice(&solid[5.min(solid.len())..]);
        let stl = stl_io::read_stl(&mut std::io::Cursor::new(normal)).map_err(|e| {
            let which = if solids.len() > 1 {
                format!(" (solid {} of {}, from line {line})", n + 1, solids.len())
            } else {
                String::new()
            };
            invalid(format!("not a readable ASCII STL file{which}: {e}"))
        })?;
        let map: Vec<u32> = stl
            .vertices
            .iter()
            .map(|v| {
                let xyz = [v[0], v[1], v[2]];
                *index.entry(xyz.map(f32::to_bits)).or_insert_with(|| {
                    vertices.push(Point3::new(xyz[0] as f64, xyz[1] as f64, xyz[2] as f64));
                    (vertices.len() - 1) as u32
                })
            })
            .collect();
        faces.extend(stl.faces.iter().map(|f| f.vertices.map(|i| map[i])));
    }
    Ok((vertices, faces))
}

/// Binary STL's 50-byte records (normal, three corners, attribute), corners with identical bits merged.
fn binary_triangles(records: &[u8]) -> (Vec<Point3>, Vec<[u32; 3]>) {
    let f = |b: &[u8], k: usize| f32::from_le_bytes([b[4 * k], b[4 * k + 1], b[4 * k + 2], b[4 * k + 3]]);
    let mut index: std::collections::HashMap<[u32; 3], u32> = std::collections::HashMap::new();
    let mut vertices = Vec::new();
    let faces = records
        .chunks_exact(50)
        .map(|r| {
            std::array::from_fn(|c| {
                let xyz = [f(r, 3 + 3 * c), f(r, 4 + 3 * c), f(r, 5 + 3 * c)];
                *index.entry(xyz.map(f32::to_bits)).or_insert_with(|| {
                    vertices.push(Point3::new(xyz[0] as f64, xyz[1] as f64, xyz[2] as f64));
                    (vertices.len() - 1) as u32
                })
            })
        })
        .collect();
    (vertices, faces)
}

/// Reads an STL file (binary or ASCII).
pub fn read(path: &Path) -> Result<PolyMesh, Error> {
    parse(&read_bytes(path)?).map_err(|e| e.with_path(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetrahedron() -> PolyMesh {
        let v = [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [0.0, 0.0, 10.0]].map(Point3::from).to_vec();
        PolyMesh::from_faces(v, [[0u32, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    }

    #[test]
    fn binary_and_ascii_round_trip_to_the_same_closed_mesh() {
        let m = tetrahedron();
        for bytes in [mesh_to_binary(&m), mesh_to_ascii(&m, "t")] {
            let back = parse(&bytes).unwrap();
            assert_eq!(back.vertices.len(), 4, "corners merge back into shared vertices");
            assert_eq!(back.face_count(), 4);
            let mut got: Vec<[Point3; 3]> =
                back.faces().map(|f| [0, 1, 2].map(|k| back.vertices[f[k] as usize])).collect();
            let mut want: Vec<[Point3; 3]> = m.faces().map(|f| [0, 1, 2].map(|k| m.vertices[f[k] as usize])).collect();
            let key = |t: &[Point3; 3]| format!("{t:?}");
            got.sort_by_key(key);
            want.sort_by_key(key);
            assert_eq!(got, want);
            assert!((back.triangulate().signed_volume() - m.triangulate().signed_volume()).abs() < 1e-9);
        }
        assert!(!mesh_to_binary(&m).starts_with(b"solid"), "a binary header must not look like ASCII");
    }

    #[test]
    fn truncated_and_garbage_files_are_refused() {
        let b = mesh_to_binary(&tetrahedron());
        let e = parse(&b[..b.len() - 7]).unwrap_err().to_string();
        assert!(e.contains("counts 4 triangles"), "{e}");
        assert!(parse(&b[..50]).unwrap_err().to_string().contains("84-byte"));
        let e = parse(b"solid x\n  facet normal 0 0 1\n    outer loop\n      vertex 1 2\n").unwrap_err().to_string();
        assert!(e.contains("not a readable ASCII STL"), "{e}");
        // ASCII after blank lines, and `solid` alone on its line, read; a binary header saying "solid" too.
        let ascii = String::from_utf8(mesh_to_ascii(&tetrahedron(), "t")).unwrap();
        assert_eq!(parse(format!("\n  {ascii}").as_bytes()).unwrap().face_count(), 4);
        assert_eq!(parse(ascii.replacen("solid t", "solid", 1).as_bytes()).unwrap().face_count(), 4);
        let mut b = mesh_to_binary(&tetrahedron());
        b[..8].copy_from_slice(b"solid x\n");
        assert_eq!(parse(&b).unwrap().face_count(), 4);
        let e = parse(format!("{ascii}garbage after the end\n").as_bytes()).unwrap_err().to_string();
        assert!(e.contains("garbage after the end") && e.contains("line"), "{e}");
    }

    /// An ASCII file with two solids keeps both (issue 37: the second was dropped in silence).
    #[test]
    fn every_solid_of_an_ascii_file_is_kept() {
        let t = tetrahedron();
        let far = PolyMesh::from_faces(
            t.vertices.iter().map(|p| p + Vector3::new(100.0, 0.0, 0.0)).collect(),
            [[0u32, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        );
        let two = [mesh_to_ascii(&t, "a"), mesh_to_ascii(&far, "b")].concat();
        let m = parse(&two).unwrap();
        assert_eq!((m.vertices.len(), m.face_count()), (8, 8));
        let volume = m.triangulate().signed_volume();
        assert!((volume - 2.0 * t.triangulate().signed_volume()).abs() < 1e-6, "{volume}");
        // Two solids sharing a corner merge it; a broken second solid is named.
        let same = [mesh_to_ascii(&t, "a"), mesh_to_ascii(&t, "b")].concat();
        assert_eq!(parse(&same).unwrap().vertices.len(), 4);
        let broken = [
            mesh_to_ascii(&t, "a"),
            b"solid b\n  facet normal 0 0 1\n    outer loop\n      vertex 1 2\nendsolid b\n".to_vec(),
        ]
        .concat();
        let e = parse(&broken).unwrap_err().to_string();
        assert!(e.contains("solid 2 of 2"), "{e}");
    }
}
