//! Singularities of a per-face vector field: the index of eq. 6.5,
//! `I(v) = (1/2π) Σ_{e ∋ v} Θ(e) + A_d(v)`, summed around each interior vertex. Θ(e) is the field's turn
//! across edge e (each side's vector measured from the shared edge in its own face, which unfolds the
//! two faces), and A_d(v) = (2π − Σ corner angles)/2π the angle defect that curved surfaces add. Regular
//! vertices have index 0; a saddle −1; a source, sink or centre +1.

use rig::TriMesh;
use rig::math::{Real, Vector3};
use std::f64::consts::{PI, TAU};

/// The signed angle from `e` to `g` about the face normal `n` (any length; the face's own plane).
fn angle(e: &Vector3, g: &Vector3, n: &Vector3) -> Real {
    e.cross(g).dot(&n.normalize()).atan2(e.dot(g))
}

/// The index of every vertex for the per-face field `field` (one vector per face); `None` for boundary
/// vertices, non-manifold fans and vertices where a face's vector vanishes.
pub fn vertex_indices(mesh: &TriMesh, field: &[Vector3]) -> Vec<Option<Real>> {
    let n = mesh.vertices.len();
    // Per vertex, its corners: (face, next vertex, previous vertex) in the face's counter-clockwise order.
    let mut corners: Vec<Vec<(usize, u32, u32)>> = vec![Vec::new(); n];
    for (f, face) in mesh.faces.iter().enumerate() {
        for k in 0..3 {
            corners[face[k] as usize].push((f, face[(k + 1) % 3], face[(k + 2) % 3]));
        }
    }
    (0..n)
        .map(|v| {
            let fan = &corners[v];
            if fan.len() < 3 {
                return None;
            }
            // Walk the fan: the face after (v, a, b) is the one whose first edge is v → b.
            let mut order = vec![0usize];
            while order.len() < fan.len() {
                let (_, _, b) = fan[*order.last().expect("non-empty")];
                let next = fan.iter().position(|c| c.1 == b)?;
                if next == order[0] {
                    return None; // closed early: more than one fan
                }
                order.push(next);
            }
            if fan[order[order.len() - 1]].2 != fan[order[0]].1 {
                return None; // open fan: a boundary vertex
            }
            let p = mesh.vertices[v];
            let mut turn = 0.0;
            let mut corner_sum = 0.0;
            for (k, &c) in order.iter().enumerate() {
                let (f, a, b) = fan[c];
                let (g, g_next) = (field[f], field[fan[order[(k + 1) % order.len()]].0]);
                if g.norm_squared() == 0.0 || g_next.norm_squared() == 0.0 {
                    return None;
                }
                let (ea, eb) = (mesh.vertices[a as usize] - p, mesh.vertices[b as usize] - p);
                let normal = ea.cross(&eb);
                corner_sum += ea.angle(&eb);
                // Across the shared edge v → b: this face's vector and the next face's, each measured from
                // that edge in its own plane.
                let f_next = mesh.faces[fan[order[(k + 1) % order.len()]].0];
                let [x, y, z] = f_next.map(|i| mesh.vertices[i as usize]);
                let normal_next = (y - x).cross(&(z - x));
                let mut d = angle(&eb, &g_next, &normal_next) - angle(&eb, &g, &normal);
                d = (d + PI).rem_euclid(TAU) - PI;
                turn += d;
            }
            Some(turn / TAU + (TAU - corner_sum) / TAU)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::remesh::harmonic::face_gradients;
    use rig::math::Point3;

    /// A fan-shaped disc: a centre vertex and rings of vertices, flat or lifted into a cone.
    fn disc(rings: usize, sectors: usize, lift: Real) -> TriMesh {
        let mut m = TriMesh { vertices: vec![Point3::origin()], ..Default::default() };
        for r in 1..=rings {
            for s in 0..sectors {
                let a = TAU * (s as Real + 0.5 * (r % 2) as Real) / sectors as Real;
                m.vertices.push(Point3::new(r as Real * a.cos(), r as Real * a.sin(), lift * r as Real));
            }
        }
        let id = |r: usize, s: usize| if r == 0 { 0 } else { (1 + (r - 1) * sectors + s % sectors) as u32 };
        for s in 0..sectors {
            m.faces.push([0, id(1, s), id(1, s + 1)]);
        }
        for r in 1..rings {
            for s in 0..sectors {
                let (a, b) = (id(r, s), id(r, s + 1));
                let (c, d) = (id(r + 1, s + 1), id(r + 1, s));
                m.faces.push([a, d, c]);
                m.faces.push([a, c, b]);
            }
        }
        m
    }

    fn index_at_centre(m: &TriMesh, f: impl Fn(&Point3) -> Real) -> Real {
        let u: Vec<Real> = m.vertices.iter().map(&f).collect();
        vertex_indices(m, &face_gradients(m, &u))[0].expect("centre is interior")
    }

    #[test]
    fn saddles_sources_and_regular_points_have_their_indices() {
        let m = disc(3, 12, 0.0);
        assert!((index_at_centre(&m, |p| p.x) - 0.0).abs() < 1e-9);
        assert!((index_at_centre(&m, |p| p.x * p.x + p.y * p.y) - 1.0).abs() < 1e-9);
        assert!((index_at_centre(&m, |p| p.x * p.x - p.y * p.y) + 1.0).abs() < 1e-9);
        // On a cone the angle defect is not zero, yet a field that crosses the tip is regular there.
        let cone = disc(3, 12, 0.6);
        assert!((index_at_centre(&cone, |p| p.x) - 0.0).abs() < 1e-9);
        // Boundary vertices have none.
        let u: Vec<Real> = m.vertices.iter().map(|p| p.x).collect();
        let idx = vertex_indices(&m, &face_gradients(&m, &u));
        assert!(idx[m.vertices.len() - 1].is_none());
    }
}
