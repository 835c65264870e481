//! Quad remeshing (ch. 6).

use super::StageError;
use crate::pipeline::records::{Fingerprint, StageCode};
use crate::remesh::{RemeshParams, RemeshReport};
use rig::math::Real;
use rig::{PolyMesh, TriMesh};
use serde_json::json;

/// A quad mesh of a triangle mesh (ch. 6).
pub fn remesh(mesh: &TriMesh, params: &RemeshParams) -> Result<(PolyMesh, RemeshReport), StageError> {
    remesh_counting(mesh, params, &std::sync::atomic::AtomicUsize::new(0))
}

/// [`remesh`], counting its phases in `phases` (up to
/// [`REMESH_PHASES`](crate::remesh::quad_remesh::REMESH_PHASES)) for a progress display ([`crate::pipeline::watch`]).
pub fn remesh_counting(
    mesh: &TriMesh,
    params: &RemeshParams,
    phases: &std::sync::atomic::AtomicUsize,
) -> Result<(PolyMesh, RemeshReport), StageError> {
    params.validate()?;
    if let (Some(spacing), Some(b)) = (params.spacing, mesh.bounding_box()) {
        let diagonal = b.diagonal();
        let default = crate::remesh::quad_remesh::DEFAULT_SPACING * diagonal;
        // Quads grow with (default / spacing)²: 50× finer is 2,500× the faces of the default remesh.
        if spacing < default / crate::remesh::quad_remesh::MAX_SPACING_RATIO {
            let smallest = default / crate::remesh::quad_remesh::MAX_SPACING_RATIO;
            return Err(StageError::SpacingTooSmall { spacing, diagonal, ratio: default / spacing, smallest });
        }
        // Streamlines farther apart than half the mesh's size cross it once or never: no quads.
        if spacing > diagonal / 2.0 {
            return Err(StageError::Implausible {
                what: format!("--spacing {spacing:.4e} is more than half the mesh's size ({diagonal:.4} across)"),
                hint: format!("no quads fit; give a spacing below {:.4} (the default is {default:.4})", diagonal / 2.0),
            });
        }
    }
    let (mut quads, mut report) = crate::remesh::quad_remesh::remesh_counting(mesh, params, phases)?;
    if quads.face_count() == 0 {
        return Err(StageError::Implausible {
            what: format!("the remesh of {} triangles has no faces", mesh.faces.len()),
            hint: "the mesh may be degenerate (no area) or the --spacing too coarse for it".into(),
        });
    }
    // What the splitter leaves of n-gons, and quads that fold, are cut into triangles: readers
    // (Open3D) refuse non-convex polygons, and a fan folds them. Kept only when asked for.
    if params.split_polygons {
        let (readable, cut) = quads.with_readable_faces();
        quads = readable;
        let sizes = quads.face_sizes();
        let q = &mut report.quality;
        (q.faces, q.quads, q.triangles, q.polygons) = (quads.face_count(), sizes.quads, sizes.triangles, sizes.larger);
        q.quad_fraction = sizes.quads as Real / q.faces.max(1) as Real;
        report.split.cut_for_readers = cut;
    }
    // Readers triangulate polygons by fans from the first corner; start each where that adds no
    // non-manifold diagonal.
    quads.rotate_faces_for_fans();
    Ok((quads, report))
}

/// The remesh stage's code version.
pub const REMESH: StageCode = StageCode { stage: "remesh", version: 1 };

/// What the quad mesh is made from besides its triangle mesh: the remeshing parameters.
pub fn remesh_fingerprint(params: &RemeshParams) -> Fingerprint {
    Fingerprint::new(REMESH, json!({ "remesh": params }))
}
