//! The scanned object: a mesh from a file placed on the platter, or the built-in fluted vase.

use rig::math::{Point3, Real, Vector3};
use rig::{PolyMesh, TriMesh};

/// Which axis of a mesh file points up (most OBJ/PLY models are y-up).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum UpAxis {
    /// +y is up (the default: Stanford, libigl and most OBJ models).
    #[default]
    Y,
    /// +z is up.
    Z,
}

/// Scales a mesh so its largest extent is `size_mm`, turns its up axis to +z, and stands it on the
/// platter: the bottom of its bounding box at z = 0, its box centred on the axis, then moved by `offset`.
pub fn place_on_platter(mesh: &PolyMesh, size_mm: Real, up: UpAxis, offset: Vector3) -> TriMesh {
    let mut tri = mesh.triangulate();
    if up == UpAxis::Y {
        // (x, y, z) → (x, −z, y): y becomes z, keeping a right-handed frame.
        for v in &mut tri.vertices {
            *v = Point3::new(v.x, -v.z, v.y);
        }
    }
    let Some(b) = tri.bounding_box() else { return tri };
    let extent = (b.max - b.min).max();
    let scale = if extent > 0.0 { size_mm / extent } else { 1.0 };
    let centre = Vector3::new((b.min.x + b.max.x) / 2.0, (b.min.y + b.max.y) / 2.0, b.min.z);
    for v in &mut tri.vertices {
        *v = Point3::from((v.coords - centre) * scale + offset);
    }
    tri.normals = None;
    tri
}

/// How the object lies in pass `pass` (from 1) of a scan of several passes, as an operator turns it
/// over between passes: 1 as placed, 2 on its side (a quarter turn about x), 3 upside down (a half
/// turn about x), 4 on its other side (a quarter turn about y), 5 and 6 the remaining sides. The
/// turned object stands on the platter again (bounding box's bottom at z = 0, centred on the axis).
/// Returns the turned mesh and the motion that took the first pass's object there — the truth a
/// test of pass alignment needs.
pub fn turned_over(object: &TriMesh, pass: u32) -> (TriMesh, rig::math::Isometry3) {
    use rig::math::{Isometry3, Translation3, UnitQuaternion};
    use std::f64::consts::{FRAC_PI_2, PI};
    let turn = match pass {
        2 => UnitQuaternion::from_axis_angle(&Vector3::x_axis(), FRAC_PI_2),
        3 => UnitQuaternion::from_axis_angle(&Vector3::x_axis(), PI),
        4 => UnitQuaternion::from_axis_angle(&Vector3::y_axis(), FRAC_PI_2),
        5 => UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -FRAC_PI_2),
        6 => UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -FRAC_PI_2),
        _ => UnitQuaternion::identity(),
    };
    let mut tri = object.clone();
    for v in &mut tri.vertices {
        *v = turn * *v;
    }
    let shift = match tri.bounding_box() {
        Some(b) => Vector3::new(-(b.min.x + b.max.x) / 2.0, -(b.min.y + b.max.y) / 2.0, -b.min.z),
        None => Vector3::zeros(),
    };
    for v in &mut tri.vertices {
        *v += shift;
    }
    tri.normals = None;
    (tri, Isometry3::from_parts(Translation3::from(shift), turn))
}

/// The largest object, as a multiple of the platter's diameter: bigger is no object a turntable holds.
pub const MAX_SIZE_PLATTERS: Real = 4.0;

/// Checks an object's size and offset against the platter before anything is rendered: a size of
/// 0, NaN or infinity, or an object moved off the platter, would give a scan of nothing.
pub fn validate_placement(
    cfg: &crate::SimConfig,
    size_mm: Real,
    offset: Vector3,
) -> Result<(), rig::limits::ParamError> {
    // A scene without a platter (radius 0) still has a bench: half a metre either way.
    let platter = if cfg.scene.platter_radius_mm > 0.0 { cfg.scene.platter_radius_mm } else { 500.0 };
    let largest = MAX_SIZE_PLATTERS * 2.0 * platter;
    if !(size_mm > 0.0 && size_mm <= largest) {
        return Err(rig::limits::ParamError {
            option: "--size",
            value: size_mm.to_string(),
            why: format!(
                "the object's size must be a positive length in mm up to {largest} ({MAX_SIZE_PLATTERS} platter diameters)"
            ),
        });
    }
    let off_axis = offset.x.hypot(offset.y);
    if !(offset.iter().all(|c| c.is_finite()) && off_axis <= platter && offset.z.abs() <= platter) {
        return Err(rig::limits::ParamError {
            option: "--offset",
            value: format!("{},{},{}", offset.x, offset.y, offset.z),
            why: format!(
                "the object must stay on the platter: at most {platter} mm from its centre, and as far up or down"
            ),
        });
    }
    Ok(())
}

/// The object on the platter, as `scanrig sim` and `scan --simulate` place it: a mesh file scaled to
/// `size_mm` (its PLY vertex colours, where it has them, as the albedo: their luma) or, without a file,
/// the built-in fluted vase, with the config's constant albedo.
pub fn object_on_platter(
    cfg: &crate::SimConfig,
    mesh: Option<&std::path::Path>,
    size_mm: Real,
    up: UpAxis,
    offset: Vector3,
) -> Result<(TriMesh, crate::Albedo), rig::Error> {
    use crate::Albedo;
    let Some(path) = mesh else {
        let vase = place_on_platter(&fluted_vase(size_mm).to_poly(), size_mm, UpAxis::Z, offset);
        return Ok((vase, Albedo::Constant(cfg.scene.object_albedo)));
    };
    let placed = place_on_platter(&rig::read_mesh(path)?, size_mm, up, offset);
    let colors =
        if rig::MeshFormat::of(path) == Some(rig::MeshFormat::Ply) { rig::ply::read_cloud(path)?.colors } else { None };
    let albedo = match colors {
        Some(c) => Albedo::PerVertex {
            faces: placed.faces.clone(),
            values: c
                .iter()
                .map(|p| (0.299 * p[0] as Real + 0.587 * p[1] as Real + 0.114 * p[2] as Real) / 255.0)
                .collect(),
        },
        None => Albedo::Constant(cfg.scene.object_albedo),
    };
    Ok((placed, albedo))
}

/// The built-in object: a fluted vase `height_mm` tall, standing on the platter centre (object frame).
///
/// Five concave flutes, a waist and a lip give self-occlusion and shadows from every side, so a scan
/// of it exercises what real objects do, without any file.
pub fn fluted_vase(height_mm: Real) -> TriMesh {
    fluted_vase_tessellated(height_mm, 120, 180)
}

/// The fluted vase with `rings × segments` vertices on its side (≈ 2·rings·segments triangles), for
/// benchmarks that need a given triangle count.
pub fn fluted_vase_tessellated(height_mm: Real, rings: usize, segments: usize) -> TriMesh {
    let radius = |s: Real, phi: Real| {
        // Profile: a bulb, a waist at 70 %, a flared lip; flutes fade toward the base and lip.
        let profile = 0.32 + 0.10 * (std::f64::consts::PI * s * 1.4).sin() - 0.07 * (-((s - 0.7) / 0.08).powi(2)).exp()
            + 0.05 * s.powi(6);
        let flute = 0.07 * (5.0 * phi).cos() * (std::f64::consts::PI * s).sin();
        height_mm * profile * (1.0 + flute)
    };
    let mut vertices = Vec::with_capacity(rings * segments + 2);
    for i in 0..rings {
        let s = i as Real / (rings - 1) as Real;
        for j in 0..segments {
            let phi = std::f64::consts::TAU * j as Real / segments as Real;
            let r = radius(s, phi);
            vertices.push(Point3::new(r * phi.cos(), r * phi.sin(), s * height_mm));
        }
    }
    let (bottom, top) = (vertices.len() as u32, vertices.len() as u32 + 1);
    vertices.push(Point3::new(0.0, 0.0, 0.0));
    vertices.push(Point3::new(0.0, 0.0, height_mm));
    let idx = |i: usize, j: usize| (i * segments + j % segments) as u32;
    let mut faces = Vec::with_capacity(2 * rings * segments);
    for i in 0..rings - 1 {
        for j in 0..segments {
            // Counter-clockwise seen from outside: outward normals.
            faces.push([idx(i, j), idx(i, j + 1), idx(i + 1, j + 1)]);
            faces.push([idx(i, j), idx(i + 1, j + 1), idx(i + 1, j)]);
        }
    }
    for j in 0..segments {
        faces.push([bottom, idx(0, j + 1), idx(0, j)]);
        faces.push([top, idx(rings - 1, j), idx(rings - 1, j + 1)]);
    }
    TriMesh { vertices, faces, normals: None }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vase_is_closed_with_outward_normals() {
        let m = fluted_vase(120.0);
        // Signed volume by the divergence theorem is positive for outward-facing triangles.
        let vol = m.signed_volume();
        assert!(vol > 0.0);
        // V − E + F = 2 for a closed sphere-like surface: E = 3F/2.
        assert_eq!(m.vertices.len() as i64 - (3 * m.faces.len() / 2) as i64 + m.faces.len() as i64, 2);
    }

    #[test]
    fn a_turned_over_object_stands_on_the_platter_and_its_motion_says_how() {
        let vase = fluted_vase(100.0);
        for pass in 1..=6 {
            let (turned, motion) = turned_over(&vase, pass);
            let b = turned.bounding_box().unwrap();
            assert!(b.min.z.abs() < 1e-9 && (b.min.x + b.max.x).abs() < 1e-9, "pass {pass}: {b:?}");
            for (a, t) in vase.vertices.iter().zip(&turned.vertices).step_by(97) {
                assert!((motion * a - t).norm() < 1e-9, "pass {pass}");
            }
        }
    }

    #[test]
    fn placement_stands_the_mesh_on_the_platter() {
        let cube = PolyMesh::from_faces(
            (0..8).map(|i| Point3::new((i & 1) as f64, ((i >> 1) & 1) as f64 + 5.0, ((i >> 2) & 1) as f64)).collect(),
            [[0u32, 1, 3, 2]],
        );
        let m = place_on_platter(&cube, 50.0, UpAxis::Y, Vector3::new(0.0, 0.0, 2.0));
        let b = m.bounding_box().unwrap();
        assert!((b.min.z - 2.0).abs() < 1e-12 && ((b.max - b.min).max() - 50.0).abs() < 1e-12);
        assert!((b.min.x + b.max.x).abs() < 1e-12 && (b.min.y + b.max.y).abs() < 1e-12);
    }
}
