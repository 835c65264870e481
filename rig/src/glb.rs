//! glTF 2.0 binary (`.glb`): the format web viewers, Blender and game engines load directly. Written
//! here (one mesh or point primitive: positions, normals, colours, indices in one binary chunk); read
//! with the `gltf` crate, which checks the document.
//!
//! glTF's units are metres and its up axis +y; scanrig's object frame is millimetres with the turntable
//! axis +z. The data stay in millimetres and +z (exact, what other scanrig commands read back) and the
//! node carries the change: a scale of 1/1000 and −90° about x. Reading applies every node's transform
//! and undoes that convention, so any glTF file comes in as millimetres, +z up. Written through
//! [`crate::mesh_io`] (the commands' outputs), data in another unit (a PLY's `comment units m`) are
//! brought to millimetres first, and data that single precision would not hold are refused
//! ([`crate::precision`]); the pipeline's own `mesh.glb` is of its scan, in millimetres.

use crate::error::{Error, Location, ParseError, Problem};
use crate::math::{Matrix3, Point3, Vector3};
use crate::mesh::PolyMesh;
use crate::point_cloud::PointCloud;
use crate::run_files::{read_bytes, write_atomic};
use serde_json::json;
use std::path::Path;

/// The node transform from scanrig's frame (mm, +z up) to glTF's (m, +y up), as glTF's column-major
/// 4 × 4 matrix: x stays, z becomes y, y becomes −z, all scaled by 1/1000.
fn to_gltf() -> Matrix3 {
    Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -1.0, 0.0) * 1e-3
}

/// What goes in: vertices, optional normals and colours, and triangles (none for a point cloud).
struct Primitive<'a> {
    positions: &'a [Point3],
    normals: Option<&'a [Vector3]>,
    colors: Option<&'a [[u8; 3]]>,
    triangles: Option<Vec<[u32; 3]>>,
}

/// Appends `bytes` to the binary chunk as one buffer view (4-byte aligned), returning its index.
fn view(bin: &mut Vec<u8>, views: &mut Vec<serde_json::Value>, bytes: &[u8], target: u32) -> usize {
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len(), "target": target}));
    bin.extend_from_slice(bytes);
    views.len() - 1
}

fn to_bytes(p: &Primitive<'_>) -> Vec<u8> {
    const ARRAY: u32 = 34962;
    const ELEMENTS: u32 = 34963;
    let (mut bin, mut views, mut accessors) = (Vec::new(), Vec::new(), Vec::new());
    let n = p.positions.len();
    let f32s = |v: &mut dyn Iterator<Item = f64>| v.flat_map(|x| (x as f32).to_le_bytes()).collect::<Vec<u8>>();
    let pos = f32s(&mut p.positions.iter().flat_map(|q| q.coords.iter().copied().collect::<Vec<_>>()));
    // POSITION must carry its bounds.
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for q in p.positions {
        for k in 0..3 {
            lo[k] = lo[k].min(q[k] as f32);
            hi[k] = hi[k].max(q[k] as f32);
        }
    }
    let bounds = |v: [f32; 3]| if n == 0 { json!([0, 0, 0]) } else { json!(v) };
    let v = view(&mut bin, &mut views, &pos, ARRAY);
    accessors.push(json!({"bufferView": v, "componentType": 5126, "count": n, "type": "VEC3",
        "min": bounds(lo), "max": bounds(hi)}));
    let mut attributes = json!({"POSITION": 0});
    if let Some(normals) = p.normals {
        let v = view(&mut bin, &mut views, &f32s(&mut normals.iter().flat_map(|q| [q.x, q.y, q.z])), ARRAY);
        accessors.push(json!({"bufferView": v, "componentType": 5126, "count": n, "type": "VEC3"}));
        attributes["NORMAL"] = json!(accessors.len() - 1);
    }
    if let Some(colors) = p.colors {
        // glTF's vertex colours are linear; a camera's 8-bit values are sRGB. Normalised unsigned shorts
        // keep the dark end's precision after the conversion; VEC4 keeps attributes 4-byte aligned.
        let linear = |c: u8| (srgb_to_linear(c as f64 / 255.0) * 65535.0).round() as u16;
        let bytes: Vec<u8> = colors
            .iter()
            .flat_map(|c| [linear(c[0]), linear(c[1]), linear(c[2]), 65535])
            .flat_map(u16::to_le_bytes)
            .collect();
        let v = view(&mut bin, &mut views, &bytes, ARRAY);
        accessors.push(json!({"bufferView": v, "componentType": 5123, "normalized": true, "count": n, "type": "VEC4"}));
        attributes["COLOR_0"] = json!(accessors.len() - 1);
    }
    let mut primitive = json!({"attributes": attributes, "mode": 0});
    if let Some(tris) = &p.triangles {
        let bytes: Vec<u8> = tris.iter().flatten().flat_map(|i| i.to_le_bytes()).collect();
        let v = view(&mut bin, &mut views, &bytes, ELEMENTS);
        accessors.push(json!({"bufferView": v, "componentType": 5125, "count": 3 * tris.len(), "type": "SCALAR"}));
        primitive["indices"] = json!(accessors.len() - 1);
        primitive["mode"] = json!(4);
        // Vertex colours show only under a material that lets them through; double-sided, because a
        // scan's open base is seen from inside.
        primitive["material"] = json!(0);
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let m = to_gltf();
    let matrix: Vec<f64> = (0..16)
        .map(|i| {
            if i == 15 {
                1.0
            } else if i % 4 == 3 || i >= 12 {
                0.0
            } else {
                m[(i % 4, i / 4)]
            }
        })
        .collect();
    let doc = json!({
        "asset": {"version": "2.0", "generator": format!("scanrig {}", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "matrix": matrix}],
        "meshes": [{"primitives": [primitive]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0, "roughnessFactor": 1}, "doubleSided": true}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len()}],
    });
    // Nothing to draw: a scene with an empty node (glTF has no accessor of zero elements).
    let doc = if n == 0 {
        json!({"asset": doc["asset"], "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{}]})
    } else {
        doc
    };
    let bin = if n == 0 { Vec::new() } else { bin };
    let mut json = serde_json::to_vec(&doc).unwrap_or_default();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let length = 12 + 8 + json.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
    let glb = gltf::binary::Glb {
        header: gltf::binary::Header { magic: *b"glTF", version: 2, length: length as u32 },
        json: json.into(),
        bin: (!bin.is_empty()).then(|| bin.into()),
    };
    glb.to_vec().unwrap_or_default()
}

/// sRGB's transfer curve, undone: an 8-bit camera value (as 0–1) to linear light.
fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// Linear light (0–1) to an 8-bit sRGB value.
fn linear_to_srgb(l: f64) -> u8 {
    let c = if l <= 0.003_130_8 { 12.92 * l } else { 1.055 * l.powf(1.0 / 2.4) - 0.055 };
    (c * 255.0).round().clamp(0.0, 255.0) as u8
}

/// A mesh as GLB bytes: its polygons fanned into triangles, with normals and colours where it has them
/// (a mesh without faces is written as its points).
pub fn mesh_to_bytes(mesh: &PolyMesh) -> Vec<u8> {
    let tris = mesh.triangulate();
    to_bytes(&Primitive {
        positions: &mesh.vertices,
        normals: mesh.normals.as_deref(),
        colors: mesh.colors.as_deref(),
        triangles: (!tris.faces.is_empty()).then_some(tris.faces),
    })
}

/// A point cloud as GLB bytes (a `POINTS` primitive with normals and colours where it has them).
pub fn cloud_to_bytes(cloud: &PointCloud) -> Vec<u8> {
    to_bytes(&Primitive {
        positions: &cloud.positions,
        normals: cloud.normals.as_deref(),
        colors: cloud.colors.as_deref(),
        triangles: None,
    })
}

/// Writes a mesh as GLB, atomically.
pub fn write_mesh(path: &Path, mesh: &PolyMesh) -> Result<(), Error> {
    write_atomic(path, &mesh_to_bytes(mesh))
}

/// Writes a point cloud as GLB, atomically.
pub fn write_cloud(path: &Path, cloud: &PointCloud) -> Result<(), Error> {
    write_atomic(path, &cloud_to_bytes(cloud))
}

/// Everything a GLB holds, merged: each node's primitives put where the scene puts them, back in
/// scanrig's frame. Triangle primitives give faces; point primitives add vertices only. What cannot be
/// kept is dropped as [`parse_reported`] says.
pub fn parse(bytes: &[u8]) -> Result<PolyMesh, ParseError> {
    parse_reported(bytes).map(|(mesh, _)| mesh)
}

/// [`parse`], with what it could not keep named, one sentence each: normals or colours that only some
/// vertices have (some primitives without them, a zero normal) are dropped with a warning. A primitive
/// whose NORMAL or COLOR_0 has fewer (or more) entries than its POSITION is refused.
pub fn parse_reported(bytes: &[u8]) -> Result<(PolyMesh, Vec<String>), ParseError> {
    let invalid = |m: String| ParseError::new(Location::File, Problem::Invalid(m));
    let (json, blob) = split_glb(bytes).map_err(invalid)?;
    check_accessors(json, blob.map_or(0, |b| b.len() as u64)).map_err(invalid)?;
    let root = gltf::json::Root::from_slice(json).map_err(|e| invalid(format!("its glTF JSON: {e}")))?;
    let doc = gltf::Document::from_json(root).map_err(|e| invalid(format!("not a valid glTF document: {e}")))?;
    let gltf = gltf::Gltf { document: doc, blob: blob.map(<[u8]>::to_vec) };
    let blob = gltf.blob.as_deref();
    let back = to_gltf().try_inverse().unwrap_or_else(Matrix3::identity);
    let mut out = PolyMesh::default();
    let (mut normals, mut colors): (Vec<Option<Vector3>>, Vec<Option<[u8; 3]>>) = (Vec::new(), Vec::new());
    // The scene's nodes; a file without scenes, every node that is no other's child.
    let roots: Vec<gltf::Node<'_>> = match gltf.default_scene().or_else(|| gltf.scenes().next()) {
        Some(s) => s.nodes().collect(),
        None => {
            let children: std::collections::HashSet<usize> =
                gltf.nodes().flat_map(|n| n.children().map(|c| c.index())).collect();
            gltf.nodes().filter(|n| !children.contains(&n.index())).collect()
        }
    };
    let mut stack: Vec<(gltf::Node<'_>, nalgebra::Matrix4<f64>)> =
        roots.into_iter().map(|n| (n, nalgebra::Matrix4::identity())).collect();
    // A node reached twice is a cycle or a shared subtree: refused, not walked forever (or exponentially).
    let mut seen = std::collections::HashSet::new();
    while let Some((node, parent)) = stack.pop() {
        if !seen.insert(node.index()) {
            return Err(invalid(format!("node {} is reached twice in the scene's tree", node.index())));
        }
        let local = nalgebra::Matrix4::from_column_slice(
            &node.transform().matrix().iter().flatten().map(|&x| x as f64).collect::<Vec<_>>(),
        );
        let world = parent * local;
        stack.extend(node.children().map(|c| (c, world)));
        let Some(mesh) = node.mesh() else { continue };
        let linear = world.fixed_view::<3, 3>(0, 0).into_owned();
        let shift = Vector3::new(world[(0, 3)], world[(1, 3)], world[(2, 3)]);
        let normal_matrix = linear.try_inverse().map(|m| m.transpose()).unwrap_or(linear);
        for prim in mesh.primitives() {
            let reader = prim.reader(|b| match b.source() {
                gltf::buffer::Source::Bin => blob,
                gltf::buffer::Source::Uri(_) => None,
            });
            let Some(positions) = reader.read_positions() else {
                return Err(invalid("a primitive has no POSITION, or its data lie outside the file".into()));
            };
            let first = out.vertices.len() as u32;
            for p in positions {
                let w = linear * Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64) + shift;
                let q = back * w;
                if !q.iter().all(|c| c.is_finite()) {
                    return Err(ParseError::new(
                        Location::Field("POSITION".into()),
                        Problem::NonFinite("a position".into()),
                    ));
                }
                out.vertices.push(Point3::from(q));
            }
            let count = out.vertices.len() - first as usize;
            let mut ns: Vec<Option<Vector3>> = vec![None; count];
            let attribute_count =
                |want: gltf::Semantic| prim.attributes().find(|(s, _)| *s == want).map(|(_, a)| a.count());
            for (name, semantic) in [("NORMAL", gltf::Semantic::Normals), ("COLOR_0", gltf::Semantic::Colors(0))] {
                if let Some(n) = attribute_count(semantic)
                    && n != count
                {
                    return Err(invalid(format!(
                        "mesh {} has a primitive whose {name} holds {n} entries for its {count} positions",
                        mesh.index()
                    )));
                }
            }
            if let Some(read) = reader.read_normals() {
                for (slot, n) in ns.iter_mut().zip(read) {
                    let v = back * (normal_matrix * Vector3::new(n[0] as f64, n[1] as f64, n[2] as f64));
                    *slot = v.try_normalize(1e-300);
                }
            }
            normals.extend(ns);
            let mut cs: Vec<Option<[u8; 3]>> = vec![None; count];
            if let Some(read) = reader.read_colors(0) {
                for (slot, c) in cs.iter_mut().zip(read.into_rgb_f32()) {
                    *slot = Some(c.map(|l| linear_to_srgb(l as f64)));
                }
            }
            colors.extend(cs);
            match prim.mode() {
                gltf::mesh::Mode::Triangles => {
                    let idx: Vec<u32> = match reader.read_indices() {
                        Some(i) => i.into_u32().collect(),
                        None => (0..count as u32).collect(),
                    };
                    if !idx.len().is_multiple_of(3) {
                        return Err(invalid(format!(
                            "a triangle primitive has {} indices, not a multiple of 3",
                            idx.len()
                        )));
                    }
                    for t in idx.chunks(3) {
                        if let Some(&bad) = t.iter().find(|&&i| i as usize >= count) {
                            return Err(invalid(format!("index {bad} is beyond its primitive's {count} vertices")));
                        }
                        out.push_face(&[first + t[0], first + t[1], first + t[2]]);
                    }
                }
                gltf::mesh::Mode::Points => {}
                other => {
                    return Err(invalid(format!(
                        "primitives of mode {other:?} are not read (triangles and points are)"
                    )));
                }
            }
        }
    }
    let mut warnings = Vec::new();
    let (with_normal, with_colour) =
        (normals.iter().filter(|n| n.is_some()).count(), colors.iter().filter(|c| c.is_some()).count());
    if with_normal == normals.len() && !normals.is_empty() {
        out.normals = Some(normals.into_iter().flatten().collect());
    } else if with_normal > 0 {
        warnings.push(format!(
            "its normals are not kept: {with_normal} of {} vertices have a usable one (some primitives have none, \
             or some normals are zero)",
            normals.len()
        ));
    }
    if with_colour == colors.len() && !colors.is_empty() {
        out.colors = Some(colors.into_iter().flatten().collect());
    } else if with_colour > 0 {
        warnings.push(format!(
            "its colours are not kept: {with_colour} of {} vertices have one (some primitives have none)",
            colors.len()
        ));
    }
    Ok((out, warnings))
}

/// A GLB container's JSON chunk and binary chunk (if any). Split here rather than by `gltf` 1.4, whose
/// splitter overflows on a header that claims less than itself.
fn split_glb(bytes: &[u8]) -> Result<(&[u8], Option<&[u8]>), String> {
    let word = |at: usize| bytes.get(at..at + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize);
    if bytes.get(..4) != Some(b"glTF") {
        return Err("not a glTF binary (it does not start with `glTF`)".into());
    }
    match word(4) {
        Some(2) => {}
        Some(v) => return Err(format!("glTF binary version {v}; version 2 is read")),
        None => return Err("the file ends inside the 12-byte glTF header".into()),
    }
    let length = word(8).ok_or("the file ends inside the 12-byte glTF header")?;
    if length > bytes.len() || length < 12 {
        return Err(format!("the header says {length} bytes, the file has {}", bytes.len()));
    }
    // A chunk: its type, its bytes and where the next one starts.
    type Chunk<'a> = Option<(u32, &'a [u8], usize)>;
    let chunk = |at: usize| -> Result<Chunk<'_>, String> {
        if at >= length {
            return Ok(None);
        }
        let (Some(n), Some(kind)) = (word(at), word(at + 4)) else {
            return Err(format!("the chunk header at byte {at} is cut off"));
        };
        let end = (at + 8)
            .checked_add(n)
            .filter(|&e| e <= length)
            .ok_or(format!("the chunk at byte {at} runs past the file's end"))?;
        Ok(Some((kind as u32, &bytes[at + 8..end], end)))
    };
    const JSON: u32 = 0x4E4F_534A;
    const BIN: u32 = 0x004E_4942;
    let Some((JSON, json, next)) = chunk(12)? else { return Err("the first chunk is not the JSON chunk".into()) };
    let bin = match chunk(next)? {
        Some((BIN, bin, _)) => Some(bin),
        _ => None,
    };
    Ok((json, bin))
}

/// The accessors a primitive's reading follows, checked before `gltf` 1.4 follows them: its POSITION
/// bounds check indexes the accessors directly, and its readers assert (in debug builds) that an
/// accessor's component type is the one read and its stride at least an element, so a damaged file
/// would crash rather than be refused. Checked here: each accessor read exists, is not sparse, has the
/// type its attribute needs, and lies inside its buffer view, which lies inside the binary chunk.
fn check_accessors(json: &[u8], blob: u64) -> Result<(), String> {
    use serde_json::Value;
    // glTF's JSON is UTF-8; a reader that skips what it does not know would not notice otherwise.
    let doc = serde_json::from_slice::<Value>(json).map_err(|e| format!("its JSON chunk is not valid JSON: {e}"))?;
    let list = |key: &str| doc.get(key).and_then(Value::as_array).cloned().unwrap_or_default();
    let (accessors, views) = (list("accessors"), list("bufferViews"));
    let num = |v: &Value, key: &str| v.get(key).and_then(Value::as_u64);
    // (attribute, allowed component types and the byte size of each, allowed element types)
    let check = |what: &str, index: u64, components: &[(u64, u64)], types: &[(&str, u64)]| -> Result<(), String> {
        let a = accessors.get(index as usize).ok_or(format!("{what} is accessor {index}, which is not in the file"))?;
        if a.get("sparse").is_some() {
            return Err(format!("{what}: sparse accessors are not read"));
        }
        let component = num(a, "componentType").unwrap_or(0);
        let size = components
            .iter()
            .find(|c| c.0 == component)
            .map(|c| c.1)
            .ok_or(format!("{what}: component type {component} is not one this attribute takes"))?;
        let ty = a.get("type").and_then(Value::as_str).unwrap_or("");
        let n = types
            .iter()
            .find(|t| t.0 == ty)
            .map(|t| t.1)
            .ok_or(format!("{what}: type `{ty}` is not one this attribute takes"))?;
        let element = size * n;
        let count = num(a, "count").unwrap_or(0);
        if count == 0 {
            return Err(format!("{what}: an accessor of no elements (glTF asks for at least 1)"));
        }
        let Some(v) = num(a, "bufferView") else { return Ok(()) };
        let view = views.get(v as usize).ok_or(format!("{what}: buffer view {v} is not in the file"))?;
        let stride = num(view, "byteStride").unwrap_or(element);
        let (vo, vl) = (num(view, "byteOffset").unwrap_or(0), num(view, "byteLength").unwrap_or(0));
        let end = num(a, "byteOffset").unwrap_or(0).checked_add(stride.saturating_mul(count - 1));
        let end = end.and_then(|e| e.checked_add(element));
        if stride < element || end.is_none_or(|e| e > vl) || vo.checked_add(vl).is_none_or(|e| e > blob) {
            return Err(format!(
                "{what}: its {count} elements do not lie inside their buffer view and the binary chunk"
            ));
        }
        Ok(())
    };
    const FLOAT: &[(u64, u64)] = &[(5126, 4)];
    const COLOUR: &[(u64, u64)] = &[(5126, 4), (5121, 1), (5123, 2)];
    const INDEX: &[(u64, u64)] = &[(5121, 1), (5123, 2), (5125, 4)];
    for (m, mesh) in list("meshes").iter().enumerate() {
        let prims = mesh.get("primitives").and_then(Value::as_array).cloned().unwrap_or_default();
        for (p, prim) in prims.iter().enumerate() {
            let at = |name: &str| format!("meshes[{m}].primitives[{p}].{name}");
            let attr = |name: &str| prim.get("attributes").and_then(|a| a.get(name)).and_then(Value::as_u64);
            if let Some(i) = attr("POSITION") {
                check(&at("POSITION"), i, FLOAT, &[("VEC3", 3)])?;
            }
            if let Some(i) = attr("NORMAL") {
                check(&at("NORMAL"), i, FLOAT, &[("VEC3", 3)])?;
            }
            if let Some(i) = attr("COLOR_0") {
                check(&at("COLOR_0"), i, COLOUR, &[("VEC3", 3), ("VEC4", 4)])?;
            }
            if let Some(i) = num(prim, "indices") {
                check(&at("indices"), i, INDEX, &[("SCALAR", 1)])?;
            }
        }
    }
    Ok(())
}

/// Reads a GLB file (see [`parse`]).
pub fn read(path: &Path) -> Result<PolyMesh, Error> {
    parse(&read_bytes(path)?).map_err(|e| e.with_path(path))
}

/// Reads a GLB file with what could not be kept named (see [`parse_reported`]).
pub fn read_reported(path: &Path) -> Result<(PolyMesh, Vec<String>), Error> {
    parse_reported(&read_bytes(path)?).map_err(|e| e.with_path(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_coloured_mesh_and_a_cloud_round_trip_in_millimetres() {
        let v = [[0.0, 0.0, 0.0], [10.5, 0.0, 0.0], [0.0, 10.0, 0.25], [0.0, 0.0, 10.0]].map(Point3::from).to_vec();
        let mut m = PolyMesh::from_faces(v.clone(), [vec![0u32, 2, 1], vec![0, 1, 3], vec![0, 3, 2], vec![1, 2, 3]]);
        m.colors = Some(vec![[255, 0, 0], [0, 255, 0], [0, 0, 255], [12, 34, 56]]);
        m.normals = Some(m.triangulate().vertex_normals());
        let back = parse(&mesh_to_bytes(&m)).unwrap();
        assert_eq!(back.face_count(), 4);
        assert_eq!(back.colors, m.colors);
        for (a, b) in back.vertices.iter().zip(&m.vertices) {
            assert!((a - b).norm() < 1e-5, "{a} vs {b}");
        }
        for (a, b) in back.normals.as_ref().unwrap().iter().zip(m.normals.as_ref().unwrap()) {
            assert!((a - b).norm() < 1e-6, "{a} vs {b}");
        }
        assert_eq!(back.faces().collect::<Vec<_>>(), m.faces().collect::<Vec<_>>());
        assert_eq!(parse(&cloud_to_bytes(&PointCloud::default())).unwrap().vertices.len(), 0);
        let cloud = PointCloud { colors: Some(vec![[1, 2, 3]; 4]), ..PointCloud::from_positions(v) };
        let back = parse(&cloud_to_bytes(&cloud)).unwrap();
        assert_eq!((back.vertices.len(), back.face_count()), (4, 0));
        assert_eq!(back.colors, cloud.colors);
    }

    #[test]
    fn broken_files_are_refused_by_name() {
        let m = PolyMesh::from_faces(vec![Point3::origin(); 3], [[0u32, 1, 2]]);
        let b = mesh_to_bytes(&m);
        let e = parse(&b[..b.len() - 5]).unwrap_err().to_string();
        assert!(e.contains("the header says"), "{e}");
        assert!(parse(b"glTF\x02\0\0\0").is_err());
        assert!(parse(b"").is_err());
    }

    /// Colours go out linear, as glTF defines them, and come back as the camera's sRGB values.
    #[test]
    fn colours_are_linear_in_the_file_and_srgb_when_read() {
        for c in 0..=255u8 {
            assert_eq!(linear_to_srgb(srgb_to_linear(c as f64 / 255.0)), c);
        }
        assert!((srgb_to_linear(128.0 / 255.0) - 0.2158).abs() < 1e-3);
        // A mesh without faces goes out as points, a valid file.
        let m = PolyMesh { vertices: vec![Point3::origin(); 3], ..Default::default() };
        assert_eq!(parse(&mesh_to_bytes(&m)).unwrap().vertices.len(), 3);
    }

    /// A node that is its own child would be walked forever.
    #[test]
    fn a_cyclic_node_tree_is_refused() {
        let mut json =
            br#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"children":[0]}]}"#.to_vec();
        while !json.len().is_multiple_of(4) {
            json.push(b' ');
        }
        let glb = gltf::binary::Glb {
            header: gltf::binary::Header { magic: *b"glTF", version: 2, length: (20 + json.len()) as u32 },
            json: json.into(),
            bin: None,
        };
        let e = parse(&glb.to_vec().unwrap()).unwrap_err().to_string();
        assert!(e.contains("reached twice") || e.contains("valid glTF"), "{e}");
    }
}
