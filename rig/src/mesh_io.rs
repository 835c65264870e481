//! Reading and writing meshes and clouds by file extension: `.ply`, `.obj`, `.off` (read), `.stl`,
//! `.glb` and `.e57` (clouds).

use crate::error::Error;
use crate::ply::{Encoding, WriteOptions};
use crate::{PointCloud, PolyMesh, e57, glb, obj, off, ply, stl};
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
    /// STL (binary or ASCII), triangles only.
    Stl,
    /// glTF 2.0 binary.
    Glb,
    /// ASTM E57 point clouds.
    E57,
}

impl MeshFormat {
    /// The format a path's extension names (case-insensitive).
    pub fn of(path: &Path) -> Option<MeshFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "ply" => Some(MeshFormat::Ply),
            "obj" => Some(MeshFormat::Obj),
            "off" => Some(MeshFormat::Off),
            "stl" => Some(MeshFormat::Stl),
            "glb" => Some(MeshFormat::Glb),
            "e57" => Some(MeshFormat::E57),
            _ => None,
        }
    }
}

const READ: &str = ".ply, .obj, .off, .stl, .glb or .e57";

fn format_of(path: &Path, expected: &'static str) -> Result<MeshFormat, Error> {
    MeshFormat::of(path).ok_or_else(|| Error::UnknownFileType { path: path.to_path_buf(), expected })
}

/// Reads a polygon mesh from PLY, OBJ, OFF, STL or GLB (an E57 file holds clouds, not meshes). What a
/// reader cannot keep is dropped; [`read_mesh_reported`] names it.
pub fn read_mesh(path: &Path) -> Result<PolyMesh, Error> {
    match format_of(path, ".ply, .obj, .off, .stl or .glb")? {
        MeshFormat::Ply => ply::read_mesh(path),
        MeshFormat::Obj => obj::read(path).map(|o| PolyMesh { colors: o.colors, ..o.mesh }),
        MeshFormat::Off => off::read(path),
        MeshFormat::Stl => stl::read(path),
        MeshFormat::Glb => glb::read(path),
        MeshFormat::E57 => Err(Error::UnknownFileType {
            path: path.to_path_buf(),
            expected: "a mesh (.ply, .obj, .off, .stl or .glb); an E57 file holds point clouds",
        }),
    }
}

/// Reads a point cloud from PLY (all attributes), OBJ (`v`, colours, `vn`), OFF or STL (vertices), GLB
/// (vertices, normals, colours) or E57 (points, colours). What a reader cannot keep is dropped;
/// [`read_cloud_reported`] names it.
pub fn read_cloud(path: &Path) -> Result<PointCloud, Error> {
    let of_mesh =
        |m: PolyMesh| PointCloud { colors: m.colors, normals: m.normals, ..PointCloud::from_positions(m.vertices) };
    match format_of(path, READ)? {
        MeshFormat::Ply => ply::read_cloud(path),
        MeshFormat::Obj => obj::read(path).map(|o| PointCloud {
            colors: o.colors,
            normals: o.mesh.normals,
            ..PointCloud::from_positions(o.mesh.vertices)
        }),
        MeshFormat::Off => off::read(path).map(|m| PointCloud::from_positions(m.vertices)),
        MeshFormat::Stl => stl::read(path).map(of_mesh),
        MeshFormat::Glb => glb::read(path).map(of_mesh),
        MeshFormat::E57 => e57::read(path),
    }
}

/// What a reader gave, with what it could not keep named: one sentence per warning, each starting with
/// the file's path. Nothing a reader drops goes unsaid; the command line prints the warnings.
#[derive(Debug, Clone, PartialEq)]
pub struct Reported<T> {
    /// What was read.
    pub value: T,
    /// What was not kept, and why.
    pub warnings: Vec<String>,
}

fn named(path: &Path, warnings: Vec<String>) -> Vec<String> {
    warnings.into_iter().map(|w| format!("{}: {w}", path.display())).collect()
}

/// [`read_mesh`], with what the reader could not keep named ([`Reported`]).
pub fn read_mesh_reported(path: &Path) -> Result<Reported<PolyMesh>, Error> {
    let (value, warnings) = match format_of(path, ".ply, .obj, .off, .stl or .glb")? {
        MeshFormat::Obj => obj::read(path).map(|o| (PolyMesh { colors: o.colors, ..o.mesh }, o.warnings))?,
        MeshFormat::Glb => glb::read_reported(path)?,
        MeshFormat::Off => off::read_reported(path)?,
        _ => (read_mesh(path)?, Vec::new()),
    };
    Ok(Reported { value, warnings: named(path, warnings) })
}

/// [`read_cloud`], with what the reader could not keep named ([`Reported`]).
pub fn read_cloud_reported(path: &Path) -> Result<Reported<PointCloud>, Error> {
    let of_mesh =
        |m: PolyMesh| PointCloud { colors: m.colors, normals: m.normals, ..PointCloud::from_positions(m.vertices) };
    let (value, warnings) = match format_of(path, READ)? {
        MeshFormat::Obj => obj::read(path).map(|o| {
            let cloud =
                PointCloud { colors: o.colors, normals: o.mesh.normals, ..PointCloud::from_positions(o.mesh.vertices) };
            (cloud, o.warnings)
        })?,
        MeshFormat::Glb => glb::read_reported(path).map(|(m, w)| (of_mesh(m), w))?,
        MeshFormat::E57 => e57::read_reported(path)?,
        MeshFormat::Off => off::read_reported(path).map(|(m, w)| (PointCloud::from_positions(m.vertices), w))?,
        _ => (read_cloud(path)?, Vec::new()),
    };
    Ok(Reported { value, warnings: named(path, warnings) })
}

/// Writes a polygon mesh as PLY (with `opts`), OBJ, STL (binary, or ASCII when `opts` ask for it) or GLB,
/// atomically. STL and GLB take the data in millimetres, from the unit `opts` give them, and are
/// refused where single precision would not hold them ([`crate::precision`]).
pub fn write_mesh(path: &Path, mesh: &PolyMesh, opts: &WriteOptions) -> Result<(), Error> {
    let in_mm = |format: &str| -> Result<std::borrow::Cow<'_, PolyMesh>, Error> {
        let k = millimetres_per_unit(path, opts, format)?;
        let mesh = if k == 1.0 {
            std::borrow::Cow::Borrowed(mesh)
        } else {
            std::borrow::Cow::Owned(PolyMesh {
                vertices: mesh.vertices.iter().map(|p| p * k).collect(),
                ..mesh.clone()
            })
        };
        single_precision(path, &mesh.vertices, format)?;
        Ok(mesh)
    };
    match format_of(path, ".ply, .obj, .stl or .glb")? {
        MeshFormat::Ply => ply::write_mesh(path, mesh, opts),
        MeshFormat::Obj => obj::write_mesh(path, mesh, opts.units()),
        MeshFormat::Stl => stl::write_mesh(path, &*in_mm("STL")?, opts.encoding == Encoding::Ascii),
        MeshFormat::Glb => glb::write_mesh(path, &*in_mm("glTF")?),
        MeshFormat::Off | MeshFormat::E57 => Err(Error::UnknownFileType {
            path: path.to_path_buf(),
            expected: ".ply, .obj, .stl or .glb for a mesh (OFF is read-only, E57 holds clouds)",
        }),
    }
}

/// Writes a point cloud as PLY (with `opts`), OBJ, GLB or E57, atomically.
pub fn write_cloud(path: &Path, cloud: &PointCloud, opts: &WriteOptions) -> Result<(), Error> {
    let in_mm = |format: &str| -> Result<std::borrow::Cow<'_, PointCloud>, Error> {
        let k = millimetres_per_unit(path, opts, format)?;
        Ok(if k == 1.0 {
            std::borrow::Cow::Borrowed(cloud)
        } else {
            let positions = cloud.positions.iter().map(|p| p * k).collect();
            std::borrow::Cow::Owned(PointCloud { positions, ..cloud.clone() })
        })
    };
    match format_of(path, ".ply, .obj, .glb or .e57")? {
        MeshFormat::Ply => ply::write_cloud(path, cloud, opts),
        MeshFormat::Obj => obj::write_cloud(path, cloud, opts.units()),
        MeshFormat::Glb => {
            let cloud = in_mm("glTF")?;
            single_precision(path, &cloud.positions, "glTF")?;
            glb::write_cloud(path, &cloud)
        }
        MeshFormat::E57 => e57::write_cloud(path, &*in_mm("E57")?),
        MeshFormat::Off | MeshFormat::Stl => Err(Error::UnknownFileType {
            path: path.to_path_buf(),
            expected: ".ply, .obj, .glb or .e57 for a point cloud (OFF is read-only, STL holds triangles)",
        }),
    }
}

/// The output format's name in the sentences of [`mesh_losses`] and [`cloud_losses`].
fn format_name(format: Option<MeshFormat>) -> &'static str {
    match format {
        Some(MeshFormat::Stl) => "STL",
        Some(MeshFormat::Glb) => "glTF",
        Some(MeshFormat::E57) => "E57",
        Some(MeshFormat::Obj) => "OBJ",
        _ => "its format",
    }
}

/// What [`write_mesh`] to `path` leaves out of `mesh`, a sentence each naming the file (empty where
/// the format keeps everything): faces of four or more corners become triangles in STL and glTF,
/// vertex colours are lost in STL. Said, not dropped in silence, where a user names the file:
/// `convert` and the other commands' `-o`, and Python's writers.
pub fn mesh_losses(path: &Path, mesh: &PolyMesh) -> Vec<String> {
    let format = MeshFormat::of(path);
    let name = format_name(format);
    let mut lost = Vec::new();
    let polygons = mesh.faces().filter(|f| f.len() > 3).count();
    if matches!(format, Some(MeshFormat::Stl | MeshFormat::Glb)) && polygons > 0 {
        lost.push(format!(
            "{}: its faces of four or more corners ({polygons}) are written as triangles ({name} holds triangles only)",
            path.display()
        ));
    }
    if format == Some(MeshFormat::Stl) && mesh.colors.is_some() {
        lost.push(format!(
            "{}: the vertex colours are not kept (STL has none; PLY, OBJ and glTF keep them)",
            path.display()
        ));
    }
    lost
}

/// What [`write_cloud`] to `path` leaves out of `cloud` (see [`mesh_losses`]): OBJ, glTF and E57
/// have no field for the points' confidence or their view.
pub fn cloud_losses(path: &Path, cloud: &PointCloud) -> Vec<String> {
    let format = MeshFormat::of(path);
    if !matches!(format, Some(MeshFormat::Obj | MeshFormat::Glb | MeshFormat::E57)) {
        return Vec::new();
    }
    let not_kept = |what: &str| {
        format!("{}: {what} not kept ({} has no field for it; PLY keeps it)", path.display(), format_name(format))
    };
    let mut lost = Vec::new();
    lost.extend(cloud.confidence.is_some().then(|| not_kept("the points' confidence (fusion's weights) is")));
    lost.extend(cloud.view_id.is_some().then(|| not_kept("which view each point came from is")));
    lost
}

/// The unit of the data a file holds as scanrig reads them: a PLY's own (its `comment units`, or
/// metres for the Stanford scans' Cyberware header), an OBJ's (`# units`, as scanrig writes it),
/// millimetres for E57 and glTF (whose metres the readers turn into millimetres), `None` where the
/// file says nothing (scanrig takes millimetres). A writer given it back
/// ([`WriteOptions::with_units`]) keeps the unit through every format: before OBJ said none, a
/// cloud in metres went through it to E57 1000 times too small.
pub fn data_units(path: &Path) -> Result<Option<String>, Error> {
    Ok(match MeshFormat::of(path) {
        Some(MeshFormat::Ply) => ply::read_header(path)?.units(),
        Some(MeshFormat::Obj) => obj::stated_units(path)?,
        Some(MeshFormat::E57 | MeshFormat::Glb) => Some("mm".into()),
        _ => None,
    })
}

/// Millimetres in the data's unit (`opts`' `comment units …`; none: millimetres), for a format
/// written in a unit of its own (E57 and glTF: metres, STL: millimetres), or why not.
fn millimetres_per_unit(path: &Path, opts: &WriteOptions, format: &str) -> Result<f64, Error> {
    let Some(unit) = opts.units() else { return Ok(1.0) };
    crate::precision::millimetres_per(unit).ok_or_else(|| Error::Refused {
        path: path.to_path_buf(),
        why: format!(
            "the data's unit is {unit:?}, which scanrig cannot convert to {format}'s \
             (it knows mm, cm, m, µm and inches): write .ply or .obj, which keep the data's own numbers"
        ),
    })
}

/// Refuses `points` for a single-precision `format` where it would not hold them.
fn single_precision(path: &Path, points: &[crate::Point3], format: &str) -> Result<(), Error> {
    let r = crate::precision::Rounding::of(points);
    if r.holds() { Ok(()) } else { Err(Error::Refused { path: path.to_path_buf(), why: r.why_not(format) }) }
}
