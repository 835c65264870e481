//! `scanrig info`: what a file holds, as text or JSON.

use crate::cli::InfoArgs;
use anyhow::{Result, bail};
use rig::ply::{PlyFile, PropertyKind};
use rig::{Aabb, PolyMesh, Rig};
use serde::Serialize;
use std::io::Write;
use std::path::Path;

/// The JSON `scanrig info --json` prints. Fields that do not apply to a file are omitted.
#[derive(Serialize, Default)]
struct FileInfo {
    /// The path as given.
    path: String,
    /// `ply`, `obj`, `off`, `rig` or `opencv-camera`.
    kind: &'static str,
    /// PLY encoding and version, e.g. `binary_little_endian 1.0`.
    #[serde(skip_serializing_if = "Option::is_none")]
    format: Option<String>,
    /// Length unit where the file says (`mm`, `m`).
    #[serde(skip_serializing_if = "Option::is_none")]
    units: Option<String>,
    /// PLY elements in file order, with their properties as `type name` or `list count item name`.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    elements: Vec<ElementInfo>,
    /// Number of vertices.
    #[serde(skip_serializing_if = "Option::is_none")]
    vertices: Option<usize>,
    /// Faces by size (for PLY `tristrips`, the triangles they make).
    #[serde(skip_serializing_if = "Option::is_none")]
    faces: Option<FaceInfo>,
    /// Whether vertices carry normals, colours, confidence.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    attributes: Vec<&'static str>,
    /// Axis-aligned bounds of the vertices, in the file's units.
    #[serde(skip_serializing_if = "Option::is_none")]
    bounding_box: Option<BoxInfo>,
    /// A range grid (scanrig's or Stanford's layout): columns, rows and cells holding a vertex.
    #[serde(skip_serializing_if = "Option::is_none")]
    range_grid: Option<GridInfo>,
    /// PLY `comment` lines.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    comments: Vec<String>,
    /// PLY `obj_info` lines.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    obj_info: Vec<String>,
    /// Summary lines for rigs and cameras.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    summary: Vec<String>,
}

#[derive(Serialize)]
struct ElementInfo {
    name: String,
    count: u64,
    properties: Vec<String>,
}

#[derive(Serialize)]
struct FaceInfo {
    total: usize,
    triangles: usize,
    quads: usize,
    larger: usize,
}

#[derive(Serialize)]
struct BoxInfo {
    min: [f64; 3],
    max: [f64; 3],
    diagonal: f64,
}

#[derive(Serialize)]
struct GridInfo {
    width: usize,
    height: usize,
    valid: usize,
}

fn box_info(b: Option<Aabb>) -> Option<BoxInfo> {
    b.map(|b| BoxInfo { min: b.min.coords.into(), max: b.max.coords.into(), diagonal: b.diagonal() })
}

fn face_info(m: &PolyMesh) -> FaceInfo {
    let s = m.face_sizes();
    FaceInfo { total: m.face_count(), triangles: s.triangles, quads: s.quads, larger: s.larger }
}

fn ply_info(path: &Path, info: &mut FileInfo) -> Result<()> {
    let ply: PlyFile = rig::ply::read(path)?;
    let h = &ply.header;
    info.format = Some(format!("{} 1.0", h.encoding.name()));
    info.units = h.units();
    info.comments = h.comments.clone();
    info.obj_info = h.obj_info.clone();
    info.elements = h
        .elements
        .iter()
        .map(|e| ElementInfo {
            name: e.name.clone(),
            count: e.count,
            properties: e
                .properties
                .iter()
                .map(|p| match p.kind {
                    PropertyKind::Scalar(t) => format!("{} {}", t.name(), p.name),
                    PropertyKind::List { count, item } => format!("list {} {} {}", count.name(), item.name(), p.name),
                })
                .collect(),
        })
        .collect();
    let located = |e: rig::ParseError| e.with_path(path);
    if ply.element("vertex").is_some() {
        let cloud = rig::ply::cloud_from_ply(&ply).map_err(located)?;
        info.vertices = Some(cloud.len());
        info.bounding_box = box_info(cloud.bounding_box());
        for (present, name) in [
            (cloud.normals.is_some(), "normals"),
            (cloud.colors.is_some(), "colors"),
            (cloud.confidence.is_some(), "confidence"),
            (cloud.view_id.is_some(), "view_id"),
        ] {
            if present {
                info.attributes.push(name);
            }
        }
    }
    if ply.element("face").is_some() || ply.element("tristrips").is_some() {
        info.faces = Some(face_info(&rig::ply::mesh_from_ply(&ply).map_err(located)?));
    }
    if rig::ply::is_range_grid(&ply) {
        let g = rig::ply::range_grid_from_ply(&ply).map_err(located)?;
        info.range_grid = Some(GridInfo { width: g.width, height: g.height, valid: g.valid_count() });
    }
    Ok(())
}

fn describe(path: &Path) -> Result<FileInfo> {
    let mut info = FileInfo { path: path.display().to_string(), ..Default::default() };
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
    match ext.as_str() {
        "ply" => {
            info.kind = "ply";
            ply_info(path, &mut info)?;
        }
        "obj" => {
            info.kind = "obj";
            let obj = rig::obj::read(path)?;
            info.units = rig::obj::stated_units(path)?;
            info.vertices = Some(obj.mesh.vertices.len());
            info.faces = Some(face_info(&obj.mesh));
            info.bounding_box = box_info(obj.mesh.bounding_box());
            if obj.normal_count > 0 {
                info.summary
                    .push(format!("{} vn normals, {} vt texture coordinates", obj.normal_count, obj.texcoord_count));
            }
        }
        "off" => {
            info.kind = "off";
            let mesh = rig::off::read(path)?;
            info.vertices = Some(mesh.vertices.len());
            info.faces = Some(face_info(&mesh));
            info.bounding_box = box_info(mesh.bounding_box());
        }
        "toml" => {
            info.kind = "rig";
            info.units = Some("mm".into());
            let rig = Rig::read(path)?;
            info.summary = rig_summary(&rig);
        }
        "yml" | "yaml" => {
            info.kind = "opencv-camera";
            let cam = rig::opencv_yaml::read_camera(path)?;
            info.summary.push(camera_line("camera", &cam));
        }
        _ => bail!(
            "{}: unrecognised file type; expected .ply, .obj, .off, .toml (rig) or .yml (OpenCV camera)",
            path.display()
        ),
    }
    Ok(info)
}

fn camera_line(what: &str, c: &rig::PinholeCamera) -> String {
    let d = c.distortion.to_opencv();
    format!(
        "{what}: {}×{} px, fx {:.3} fy {:.3} cx {:.3} cy {:.3}, distortion k1 {} k2 {} p1 {} p2 {} k3 {}",
        c.width, c.height, c.fx, c.fy, c.cx, c.cy, d[0], d[1], d[2], d[3], d[4]
    )
}

fn rig_summary(rig: &Rig) -> Vec<String> {
    let mut s = vec![
        format!("name: {}", if rig.name.is_empty() { "(unnamed)" } else { &rig.name }),
        camera_line("camera", &rig.camera),
    ];
    if let Some(p) = &rig.projector {
        s.push(camera_line("projector", &p.lens));
        let c = p.center_in_camera();
        s.push(format!(
            "projector centre in the camera frame: ({:.2}, {:.2}, {:.2}) mm, baseline {:.2} mm",
            c.x,
            c.y,
            c.z,
            c.coords.norm()
        ));
    }
    for l in &rig.lasers {
        let n = l.plane.normal;
        s.push(format!("laser {}: plane ({:.5}, {:.5}, {:.5})·X = {:.3} mm", l.name, n.x, n.y, n.z, l.plane.distance));
    }
    if let Some(t) = &rig.turntable {
        let (p, d) = (t.point, t.direction);
        s.push(format!(
            "turntable: centre ({:.2}, {:.2}, {:.2}) mm, axis ({:.5}, {:.5}, {:.5})",
            p.x, p.y, p.z, d.x, d.y, d.z
        ));
    }
    s
}

fn print_text(info: &FileInfo, out: &mut impl Write) -> std::io::Result<()> {
    match &info.format {
        Some(f) => writeln!(out, "{}: {} {}", info.path, info.kind.to_uppercase(), f)?,
        None => writeln!(out, "{}: {}", info.path, info.kind)?,
    }
    if let Some(u) = &info.units {
        writeln!(out, "  units: {u}")?;
    }
    for e in &info.elements {
        writeln!(out, "  element {} {}: {}", e.name, e.count, e.properties.join(", "))?;
    }
    if let Some(v) = info.vertices {
        let attrs =
            if info.attributes.is_empty() { String::new() } else { format!(" (with {})", info.attributes.join(", ")) };
        writeln!(out, "  vertices: {v}{attrs}")?;
    }
    if let Some(f) = &info.faces {
        writeln!(out, "  faces: {} ({} triangles, {} quads, {} larger)", f.total, f.triangles, f.quads, f.larger)?;
    }
    if let Some(g) = &info.range_grid {
        writeln!(out, "  range grid: {} × {}, {} valid cells", g.width, g.height, g.valid)?;
    }
    if let Some(b) = &info.bounding_box {
        let unit = info.units.as_deref().unwrap_or("");
        writeln!(
            out,
            "  bounding box: ({:.6}, {:.6}, {:.6}) – ({:.6}, {:.6}, {:.6}), diagonal {:.6} {unit}",
            b.min[0], b.min[1], b.min[2], b.max[0], b.max[1], b.max[2], b.diagonal
        )?;
    }
    for c in &info.comments {
        writeln!(out, "  comment {c}")?;
    }
    for line in &info.summary {
        writeln!(out, "  {line}")?;
    }
    Ok(())
}

pub fn run(args: &InfoArgs) -> Result<()> {
    let info = describe(&args.file)?;
    let mut out = std::io::stdout().lock();
    if args.json {
        serde_json::to_writer_pretty(&mut out, &info)?;
        writeln!(out)?;
    } else {
        print_text(&info, &mut out)?;
    }
    Ok(())
}
