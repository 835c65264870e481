//! Point-to-surface distances to a triangle mesh for the tests that measure against reference meshes
//! such as bun_zipper.ply (the library's [`MeshDistance`]).
#![allow(dead_code)]

use rig::TriMesh;
use std::path::Path;

pub use process::reconstruct::mesh_distance::MeshDistance as SurfaceDistance;

/// bun_zipper.ply in millimetres (the file is in metres).
pub fn zipper_mm(path: &Path) -> TriMesh {
    let mut m = rig::read_mesh(path).unwrap().triangulate();
    m.vertices.iter_mut().for_each(|v| *v *= 1000.0);
    m
}
