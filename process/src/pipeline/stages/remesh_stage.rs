//! Quad remeshing (ch. 6).

use super::StageError;
use crate::pipeline::records::{Fingerprint, StageCode};
use crate::remesh::{RemeshParams, RemeshReport};
use rig::math::Real;
use rig::{PolyMesh, TriMesh};
use serde_json::json;

/// Refuses to remesh a mesh whose vertices include a few far from the rest, or another piece far
/// from the widest ([`super::apart()`]), unless `force`, else the warning to give: the quads'
/// default spacing follows the mesh's size, so a stray vertex makes them that much coarser (one
/// 10³⁰ mm out, an exporter's garbage, was refused only after the remesh, as quads straying 10²⁹ mm
/// from the input).
pub fn check_remesh_input(mesh: &TriMesh, force: bool) -> Result<Vec<String>, StageError> {
    let Some(a) = super::apart(&mesh.vertices).filter(|a| a.widening > super::MAX_WIDENING) else {
        return Ok(Vec::new());
    };
    let what = a.describe("the mesh's vertices", "the default quads, sized to the box, are that much coarser");
    if force {
        return Ok(vec![format!("{what} (--force)")]);
    }
    Err(StageError::Implausible {
        what,
        hint: match a.pieces {
            0 => "remove them (an exporter's stray vertices?); if they are a part of the object, --force keeps them",
            _ => a.hint(),
        }
        .into(),
    })
}

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
    // (Open3D) refuse non-convex polygons, and a fan folds them. Kept only when asked for. Readers
    // triangulate polygons by fans from the first corner: each is started where that adds no
    // non-manifold diagonal, or cut with a new vertex where no corner avoids it.
    if params.split_polygons {
        let (readable, cut) = quads.with_readable_faces();
        quads = readable;
        let sizes = quads.face_sizes();
        let q = &mut report.quality;
        (q.faces, q.quads, q.triangles, q.polygons) = (quads.face_count(), sizes.quads, sizes.triangles, sizes.larger);
        q.quad_fraction = sizes.quads as Real / q.faces.max(1) as Real;
        report.split.cut_for_readers = cut.cut;
        report.split.midpoints_for_readers = cut.midpoints;
    } else {
        quads.rotate_faces_for_fans();
    }
    // The edges as a file's readers will have them (the check below and process's reuse judge
    // these): what the cut or a fan repeats is an edge of three faces there. Polygons kept on
    // purpose (--keep-polygons) are counted as the polygons they are.
    let q = &mut report.quality;
    let counted = if params.split_polygons { quads.triangulate().to_poly() } else { quads.clone() };
    (q.boundary_edges, q.non_manifold_edges) = crate::remesh::quality::edge_counts(&counted);
    Ok((quads, report))
}

/// How far, in quads, the quad mesh may stray from its input before it cannot be right: a quad's
/// corners lie on the input, so only a quad spanning a thin part or a gap strays a whole quad. The
/// meshes in `../shared/data` at the default spacing (1 % of the diagonal): all 25 stray 0.2–3.1
/// quads (fandisk 0.2, armadillo 1.0, the beetle's and the coarse bunnies' open pieces 1.7–2.8, the
/// Newell teapot's knob, four patches a few quads across, 3.1); a strip narrower than the quads,
/// apart from the rest, gets none (24 quads off in the refusal's test).
pub const MAX_REMESH_GAP_QUADS: Real = 4.0;

/// What a quad remesh must keep of its input, checked before it is written (and again from its
/// record when `process` reuses it): no edge shared by three or more faces where the input has none
/// (two sides of a part thinner than the quads were joined), no hole in a closed input, nothing
/// farther from the input than [`MAX_REMESH_GAP_QUADS`] quads. An error unless `force`, else the
/// warnings to give.
pub fn check_remesh(report: &RemeshReport, force: bool) -> Result<Vec<String>, StageError> {
    let (q, spacing) = (&report.quality, report.spacing);
    // What is wrong, and what to do about it.
    let mut wrong: Vec<(String, String)> = Vec::new();
    let thin =
        format!("a part thinner than the quads ({spacing:.4e} apart) had its sides joined: give a smaller --spacing");
    // Where the input has such edges already, one of them may become several of the quads' (a
    // spacing finer than its triangles): only a manifold input is held to a manifold remesh.
    if report.input_non_manifold_edges == 0 && q.non_manifold_edges > 0 {
        let what = format!(
            "the quad mesh has {} edges shared by three or more faces where the input has none",
            q.non_manifold_edges
        );
        wrong.push((what, thin.clone()));
    }
    if report.input_boundary_edges == 0 && q.boundary_edges > 0 {
        let what = format!("the quad mesh has holes ({} boundary edges) where the input is closed", q.boundary_edges);
        wrong.push((what, thin));
    }
    if !q.hausdorff.is_finite() {
        // A vertex off in the infinite or a NaN would otherwise pass every comparison below.
        let what = format!("the quad mesh's distance from its input could not be measured ({})", q.hausdorff);
        wrong.push((what, "the input or the quads have a vertex that is not a finite number".into()));
    } else if spacing > 0.0 && q.hausdorff > MAX_REMESH_GAP_QUADS * spacing {
        // The coarsest Stanford bunny's small pieces get no quads.
        let what = format!(
            "the quad mesh strays {:.4e} from the input ({:.1} quads of {spacing:.4e}, over {MAX_REMESH_GAP_QUADS})",
            q.hausdorff,
            q.hausdorff / spacing
        );
        let hint = "a piece of the input got no quads (an open or separate piece the streamlines did not cover) or a \
                    part was cut short: remesh that piece on its own or remove it first";
        wrong.push((what, hint.into()));
    }
    if wrong.is_empty() {
        return Ok(Vec::new());
    }
    if force {
        return Ok(wrong.into_iter().map(|(w, _)| format!("{w} (--force)")).collect());
    }
    let (whats, mut hints): (Vec<String>, Vec<String>) = wrong.into_iter().unzip();
    hints.dedup();
    Err(StageError::Implausible {
        what: whats.join("; "),
        hint: format!("{}; --force keeps this remesh", hints.join("; ")),
    })
}

/// The remesh stage's code version.
/// (2: the report records the input's boundary and non-manifold edges, which the check on reuse
/// reads; 3: the cut for readers takes ear-clipping diagonals that repeat no edge where it can;
/// 4: a face no start cuts or fans without repeating an edge has the repeated diagonals split at
/// their midpoints, and the report's edges are counted as readers triangulate the faces; 5: parts of
/// the mesh that meet only at a vertex keep their own line graphs and boundary loops; 6: so do parts
/// that meet along edges of three or more faces; 7: each such face has its own boundary line along
/// that edge; 8: quads.obj says its unit, millimetres, as `scanrig remesh` writes it.)
pub const REMESH: StageCode = StageCode { stage: "remesh", version: 8 };

/// What the quad mesh is made from besides its triangle mesh: the remeshing parameters.
pub fn remesh_fingerprint(params: &RemeshParams) -> Fingerprint {
    Fingerprint::new(REMESH, json!({ "remesh": params }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The check reads only the report (it runs again from a reused step's record): each finding by
    /// itself, an input that had the same defect excused, and `force` turning refusals into warnings.
    #[test]
    fn the_check_reads_the_report_alone() {
        let mut r = RemeshReport { spacing: 1.0, ..Default::default() };
        r.quality.hausdorff = 3.9;
        assert_eq!(check_remesh(&r, false).unwrap(), Vec::<String>::new());
        r.quality.hausdorff = 4.1;
        let e = check_remesh(&r, false).unwrap_err().to_string();
        assert!(e.contains("strays") && e.contains("got no quads") && !e.contains("--spacing"), "{e}");
        r.quality.hausdorff = 0.5;
        r.quality.non_manifold_edges = 5;
        r.quality.boundary_edges = 4;
        let e = check_remesh(&r, false).unwrap_err().to_string();
        assert!(
            e.contains("5 edges shared") && e.contains("holes (4 boundary edges)") && e.contains("--spacing"),
            "{e}"
        );
        assert_eq!(e.matches("--spacing").count(), 1, "one hint for both: {e}");
        // An input with such edges and holes of its own is not held to a remesh without them.
        (r.input_non_manifold_edges, r.input_boundary_edges) = (1, 10);
        assert_eq!(check_remesh(&r, false).unwrap(), Vec::<String>::new());
        (r.input_non_manifold_edges, r.input_boundary_edges) = (0, 0);
        let w = check_remesh(&r, true).unwrap();
        assert!(w.len() == 2 && w.iter().all(|w| w.ends_with("(--force)")), "{w:?}");
        // A distance that is not a number fails every comparison: it is a finding of its own.
        (r.quality.non_manifold_edges, r.quality.boundary_edges, r.quality.hausdorff) = (0, 0, Real::NAN);
        let e = check_remesh(&r, false).unwrap_err().to_string();
        assert!(e.contains("could not be measured (NaN)"), "{e}");
    }
}
