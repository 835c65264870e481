//! Reading and writing meshes and clouds by file extension (`.ply`, `.obj`, `.off`).

use crate::error::Error;
use crate::ply::WriteOptions;
use crate::{PointCloud, PolyMesh, obj, off, ply};
use std::path::Path;

/// The mesh and cloud formats this crate reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshFormat {
    /// Stanford PLY.
    Ply,
    /// Wavefront OBJ.
    Obj,
    /// Object File Format.
    Off,
}

impl MeshFormat {
    /// The format a path's extension names (case-insensitive).
    pub fn of(path: &Path) -> Option<MeshFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "ply" => Some(MeshFormat::Ply),
            "obj" => Some(MeshFormat::Obj),
            "off" => Some(MeshFormat::Off),
            _ => None,
        }
    }
}

fn format_of(path: &Path, expected: &'static str) -> Result<MeshFormat, Error> {
    MeshFormat::of(path).ok_or_else(|| Error::UnknownFileType { path: path.to_path_buf(), expected })
}

/// Reads a polygon mesh from PLY, OBJ or OFF.
pub fn read_mesh(path: &Path) -> Result<PolyMesh, Error> {
    match format_of(path, ".ply, .obj or .off")? {
        MeshFormat::Ply => ply::read_mesh(path),
        MeshFormat::Obj => obj::read(path).map(|o| o.mesh),
        MeshFormat::Off => off::read(path),
    }
}

/// Reads a point cloud from PLY (all attributes), OBJ (`v`, colours, `vn`) or OFF (vertices).
pub fn read_cloud(path: &Path) -> Result<PointCloud, Error> {
    match format_of(path, ".ply, .obj or .off")? {
        MeshFormat::Ply => ply::read_cloud(path),
        MeshFormat::Obj => obj::read(path).map(|o| PointCloud {
            colors: o.colors,
            normals: o.mesh.normals,
            ..PointCloud::from_positions(o.mesh.vertices)
        }),
        MeshFormat::Off => off::read(path).map(|m| PointCloud::from_positions(m.vertices)),
    }
}

/// Writes a polygon mesh as PLY (with `opts`) or OBJ, atomically.
pub fn write_mesh(path: &Path, mesh: &PolyMesh, opts: &WriteOptions) -> Result<(), Error> {
    match format_of(path, ".ply or .obj")? {
        MeshFormat::Ply => ply::write_mesh(path, mesh, opts),
        MeshFormat::Obj => obj::write_mesh(path, mesh),
        MeshFormat::Off => {
            Err(Error::UnknownFileType { path: path.to_path_buf(), expected: ".ply or .obj (OFF is read-only)" })
        }
    }
}

/// Writes a point cloud as PLY (with `opts`) or OBJ, atomically.
pub fn write_cloud(path: &Path, cloud: &PointCloud, opts: &WriteOptions) -> Result<(), Error> {
    match format_of(path, ".ply or .obj")? {
        MeshFormat::Ply => ply::write_cloud(path, cloud, opts),
        MeshFormat::Obj => obj::write_cloud(path, cloud),
        MeshFormat::Off => {
            Err(Error::UnknownFileType { path: path.to_path_buf(), expected: ".ply or .obj (OFF is read-only)" })
        }
    }
}
