//! Dropping the small components a reconstruction leaves beside the surface: blobs around outliers,
//! bubbles where an open scan's border lets the indicator cross its level.

use rig::TriMesh;
use rig::math::Real;
use rig::union_find::UnionFind;

/// Removes the faces (and then unused vertices) of every edge-connected component whose area is below
/// `min_fraction` of the largest component's. Returns the number of components removed.
pub fn prune_small_components(mesh: &mut TriMesh, min_fraction: Real) -> usize {
    if min_fraction <= 0.0 {
        return 0;
    }
    prune_components(mesh, |area, largest, _, _| area >= min_fraction * largest)
}

/// Removes what [`prune_small_components`] would (components under `min_fraction` of the largest's
/// area) and every component fewer than half of whose vertices lie within `max_distance` of a sample:
/// surface the data never asked for (AdFFT's local solids close themselves away from their points).
/// A component of more than [`PRUNE_SAMPLE`] vertices is judged on that many spread evenly over its
/// vertex list. One labelling of the components serves both (each had labelled the bunny's 1.2 M
/// faces at 512³ on its own). Returns the number removed.
pub fn prune_small_or_away(
    mesh: &mut TriMesh,
    min_fraction: Real,
    samples: &crate::kd_tree::PointTree,
    max_distance: Real,
) -> usize {
    use rayon::prelude::*;
    prune_components(mesh, |area, largest, vertices, positions| {
        if min_fraction > 0.0 && area < min_fraction * largest {
            return false;
        }
        // Kept when at least half its vertices are near. The whole mesh's nearest queries had been a
        // sixth of AdFFT's run at 512³, then a tenth with an early exit (the main component still asked
        // half its 600,000 vertices): an even sample of 16,384 puts the fraction within ±0.8 % (two
        // standard errors), so only a component within a hair of half near could be judged otherwise.
        let stride = vertices.len().div_ceil(PRUNE_SAMPLE).max(1);
        let picked: Vec<u32> = vertices.iter().step_by(stride).copied().collect();
        let need = picked.len().div_ceil(2);
        let (mut near, mut checked) = (0, 0);
        for chunk in picked.chunks(4096) {
            near += chunk.par_iter().filter(|&&v| samples.any_within(&positions[v as usize], max_distance)).count();
            checked += chunk.len();
            if near >= need || near + (picked.len() - checked) < need {
                break;
            }
        }
        near >= need
    })
}

/// The most vertices of one component [`prune_small_or_away`] asks the samples about.
pub const PRUNE_SAMPLE: usize = 16_384;

/// Keeps the components for which `keep(area, largest area, vertex ids, the mesh's vertices)` holds.
fn prune_components(mesh: &mut TriMesh, keep_part: impl Fn(Real, Real, &[u32], &[rig::Point3]) -> bool) -> usize {
    if mesh.faces.is_empty() {
        return 0;
    }
    let n = mesh.vertices.len();
    let mut sets = UnionFind::new(n);
    for f in &mesh.faces {
        sets.union(f[0] as usize, f[1] as usize);
        sets.union(f[0] as usize, f[2] as usize);
    }
    let mut area = vec![0.0; n];
    let face_root: Vec<u32> = mesh.faces.iter().map(|f| sets.find(f[0] as usize) as u32).collect();
    for (f, &r) in mesh.faces.iter().zip(&face_root) {
        let [a, b, c] = f.map(|i| mesh.vertices[i as usize]);
        area[r as usize] += (b - a).cross(&(c - a)).norm() / 2.0;
    }
    let largest = area.iter().copied().fold(0.0, Real::max);
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); n];
    for v in 0..n {
        members[sets.find(v)].push(v as u32);
    }
    let verdict: Vec<bool> =
        (0..n).map(|r| area[r] > 0.0 && keep_part(area[r], largest, &members[r], &mesh.vertices)).collect();
    let keep = |r: u32| verdict[r as usize];
    let removed = (0..n).filter(|&r| area[r] > 0.0 && !verdict[r]).count();
    if removed == 0 {
        return 0;
    }
    let faces: Vec<[u32; 3]> = mesh.faces.iter().zip(&face_root).filter(|(_, r)| keep(**r)).map(|(f, _)| *f).collect();
    // Compact the vertices, keeping their order.
    let mut used = vec![u32::MAX; n];
    for f in &faces {
        for &v in f {
            used[v as usize] = 0;
        }
    }
    let mut vertices = Vec::new();
    for (v, slot) in used.iter_mut().enumerate() {
        if *slot == 0 {
            *slot = vertices.len() as u32;
            vertices.push(mesh.vertices[v]);
        }
    }
    mesh.normals = mesh.normals.take().map(|ns| (0..n).filter(|&v| used[v] != u32::MAX).map(|v| ns[v]).collect());
    mesh.faces = faces.into_iter().map(|f| f.map(|v| used[v as usize])).collect();
    mesh.vertices = vertices;
    removed
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::math::Point3;

    /// Closed tetrahedra of edge `s`, their corners at x = `o`, one after another in one mesh.
    fn tetrahedra(shapes: &[(Real, Real)]) -> TriMesh {
        let mut mesh = TriMesh::default();
        for &(s, o) in shapes {
            let b = mesh.vertices.len() as u32;
            let p = |x: Real, y: Real, z: Real| Point3::new(o + x, y, z);
            mesh.vertices.extend([p(0.0, 0.0, 0.0), p(s, 0.0, 0.0), p(0.0, s, 0.0), p(0.0, 0.0, s)]);
            mesh.faces.extend([[b, b + 2, b + 1], [b, b + 1, b + 3], [b, b + 3, b + 2], [b + 1, b + 2, b + 3]]);
        }
        mesh
    }

    #[test]
    fn the_small_tetrahedron_goes_and_the_big_one_stays() {
        let mut mesh = tetrahedra(&[(0.1, 5.0), (1.0, 0.0)]);
        assert_eq!(prune_small_components(&mut mesh, 0.05), 1);
        assert_eq!((mesh.vertices.len(), mesh.faces.len()), (4, 4));
        assert_eq!(mesh.vertices[1], Point3::new(1.0, 0.0, 0.0));
        assert!(mesh.faces.iter().flatten().all(|&v| v < 4));
    }

    /// A component too small and one away from the samples both go, in one pass; the big one on the
    /// samples stays.
    #[test]
    fn small_and_far_components_go_together() {
        // Small on the samples, big on them, big 20 away.
        let shapes = [(0.1, 5.0), (1.0, 0.0), (1.0, 20.0)];
        let mut mesh = tetrahedra(&shapes);
        let samples = crate::kd_tree::PointTree::new(&mesh.vertices[..8]);
        assert_eq!(prune_small_or_away(&mut mesh, 0.05, &samples, 0.5), 2);
        assert_eq!((mesh.vertices.len(), mesh.faces.len()), (4, 4));
        assert_eq!(mesh.vertices[1], Point3::new(1.0, 0.0, 0.0));
        // Without the size test only the far one goes.
        let mut mesh = tetrahedra(&shapes);
        assert_eq!(prune_small_or_away(&mut mesh, 0.0, &samples, 0.5), 1);
        assert_eq!(mesh.faces.len(), 8);
    }
}
