//! The mesh held to the working volume's top. A reconstruction closes the surface over the highest
//! samples with a rounded dome (the FFT's low-pass, and, with few laser lines, a bulge between them)
//! that can rise well above the object: the FabScanPi sample's five lines gave a top 20 mm over the
//! head. Where the merge knows the object's top ([`crate::pipeline::volume`]), the mesh is cut there
//! and closed by a flat cap: the base cut ([`super::base::cut_base`]) on the mesh mirrored top to
//! bottom, so both ends of the object are cut by one tested routine.

use super::base::{Base, BaseError, BaseReport, cut_base};
use rig::TriMesh;
use rig::math::Real;

/// The mesh mirrored in z (faces turned so they still face out).
fn mirrored(mesh: &TriMesh) -> TriMesh {
    TriMesh {
        vertices: mesh.vertices.iter().map(|p| rig::math::Point3::new(p.x, p.y, -p.z)).collect(),
        faces: mesh.faces.iter().map(|f| [f[0], f[2], f[1]]).collect(),
        normals: mesh.normals.as_ref().map(|n| n.iter().map(|v| rig::math::Vector3::new(v.x, v.y, -v.z)).collect()),
    }
}

/// Cuts away what of `mesh` lies above z = `top` and closes the cut by a flat cap there; `None`
/// where nothing rises above it (the mesh is left as it is).
pub fn cut_top(mesh: &TriMesh, top: Real) -> Result<Option<(TriMesh, BaseReport)>, BaseError> {
    let high = mesh.vertices.iter().map(|p| p.z).fold(Real::NEG_INFINITY, Real::max);
    if high.partial_cmp(&top) != Some(std::cmp::Ordering::Greater) {
        return Ok(None);
    }
    let (cut, mut report) = cut_base(&mirrored(mesh), Base::Flat, -top, 0.0)?;
    report.z = top;
    Ok(Some((mirrored(&cut), report)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_dome_above_the_top_is_cut_flat_and_the_mesh_stays_closed() {
        // An octahedron standing on its lower tip, 20 high: cut at 15.
        let v = |x: Real, y: Real, z: Real| rig::math::Point3::new(x, y, z);
        let mesh = TriMesh {
            vertices: vec![
                v(0.0, 0.0, 0.0),
                v(5.0, 0.0, 10.0),
                v(0.0, 5.0, 10.0),
                v(-5.0, 0.0, 10.0),
                v(0.0, -5.0, 10.0),
                v(0.0, 0.0, 20.0),
            ],
            faces: vec![[0, 2, 1], [0, 3, 2], [0, 4, 3], [0, 1, 4], [5, 1, 2], [5, 2, 3], [5, 3, 4], [5, 4, 1]],
            normals: None,
        };
        let (cut, report) = cut_top(&mesh, 15.0).unwrap().unwrap();
        let high = cut.vertices.iter().map(|p| p.z).fold(Real::NEG_INFINITY, Real::max);
        assert!((high - 15.0).abs() < 1e-9, "{high}");
        assert!(report.closed && report.cap_triangles > 0, "{report:?}");
        // The lower half is untouched.
        assert!(cut.vertices.iter().any(|p| p.z == 0.0));
        assert!(cut_top(&mesh, 20.0).unwrap().is_none());
    }
}
