//! `scanrig view FILE…`: any cloud or mesh scanrig reads (PLY, OBJ, OFF, STL, GLB, E57), one layer
//! each, in the viewer.

use crate::PageError;
use crate::escape::esc;
use crate::page::{Page, facts, file_links, relative_link};
use crate::scene::{Scene, count};
use std::path::{Path, PathBuf};

/// One file as read: a mesh when it has faces, else a cloud.
fn add(scene: &mut Scene, path: &Path) -> Result<String, PageError> {
    let name = path.file_name().map_or(path.display().to_string(), |n| n.to_string_lossy().into_owned());
    let is_e57 = rig::mesh_io::MeshFormat::of(path) == Some(rig::mesh_io::MeshFormat::E57);
    // A PLY cloud has no face element, which the mesh reader refuses: then it is read as a cloud
    // (and if that fails too, the mesh reader's complaint is the one to show).
    let (mesh, mesh_error) = match is_e57 {
        true => (None, None),
        false => match rig::read_mesh(path) {
            Ok(m) => (Some(m), None),
            Err(e) => (None, Some(e)),
        },
    };
    match mesh {
        Some(m) if m.face_count() > 0 => {
            let t = m.triangulate();
            scene.add_mesh(&name, &t, m.colors.as_deref(), true, None);
            Ok(format!(
                "mesh: {} vertices, {} faces ({} triangles){}",
                count(m.vertices.len()),
                count(m.face_count()),
                count(t.faces.len()),
                if m.colors.is_some() { ", coloured" } else { "" }
            ))
        }
        _ => {
            let c = match (rig::read_cloud(path), mesh_error) {
                (Ok(c), _) => c,
                (Err(_), Some(e)) | (Err(e), None) => return Err(e.into()),
            };
            if c.positions.is_empty() {
                return Err(PageError::Missing(format!("{}: nothing to show (no points, no faces)", path.display())));
            }
            scene.add_points(&name, &c.positions, c.colors.as_deref(), true, None);
            Ok(format!(
                "cloud: {} points{}{}",
                count(c.positions.len()),
                if c.colors.is_some() { ", coloured" } else { "" },
                if c.normals.is_some() { ", with normals" } else { "" }
            ))
        }
    }
}

/// The page showing `files`; `dir` is where it will be written (links are relative to it), or
/// `None` when it is served (no links: the server offers only the page).
pub fn build(files: &[PathBuf], dir: Option<&Path>) -> Result<String, PageError> {
    if files.is_empty() {
        return Err(PageError::Missing(
            "no file to view: give one or more PLY, OBJ, OFF, STL, GLB or E57 files".into(),
        ));
    }
    let mut scene = Scene::new();
    let mut rows = Vec::new();
    for f in files {
        let what = add(&mut scene, f)?;
        rows.push((f.display().to_string(), esc(&what)));
    }
    let names: Vec<String> =
        files.iter().map(|f| f.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned())).collect();
    let mut page = Page::new(&format!("scanrig view: {}", names.join(", ")), "Clouds and meshes as scanrig reads them");
    let rows: Vec<(&str, String)> = rows.iter().map(|(k, v)| (k.as_str(), v.clone())).collect();
    page.section("files", "Files", facts(&rows));
    page.viewer_section("view3d", "3D view", scene);
    if let Some(dir) = dir {
        let links: Vec<String> = files.iter().map(|f| relative_link(f, dir)).collect();
        page.section("links", "Open the files", file_links(&links));
    }
    Ok(page.render())
}

/// Writes the page for `files` to `out` atomically; returns its size in bytes.
pub fn write(files: &[PathBuf], out: &Path) -> Result<usize, PageError> {
    let html = build(files, Some(out.parent().unwrap_or(Path::new("."))))?;
    rig::write_atomic(out, html.as_bytes())?;
    Ok(html.len())
}
