//! Local shape descriptors for registration with no pose to start from: Fast Point Feature
//! Histograms (Rusu, Blodow and Beetz, "Fast Point Feature Histograms (FPFH) for 3D registration",
//! ICRA 2009). Each point's neighbourhood is described by how the normals turn between it and its
//! neighbours — three angles of the Darboux frame of each pair, binned — which does not change when
//! the cloud is moved, so two scans of the same surface in any poses give matching descriptors.

use crate::kd_tree::PointTree;
use rayon::prelude::*;
use rig::math::{Point3, Real, Vector3};
use std::collections::HashMap;

/// Bins per angle: three angles, 33 numbers a descriptor (as the paper's FPFH).
pub const BINS: usize = 11;
/// Numbers in a descriptor.
pub const LEN: usize = 3 * BINS;

/// A point's descriptor.
pub type Fpfh = [f32; LEN];

/// The cloud thinned to one point per `voxel`-sized cell (the mean of the points in it): even
/// spacing for the descriptors, and a bounded cost whatever the scan's density.
pub fn voxel_thin(points: &[Point3], voxel: Real) -> Vec<Point3> {
    let mut cells: HashMap<(i64, i64, i64), (Vector3, usize)> = HashMap::new();
    for p in points {
        let key = ((p.x / voxel).floor() as i64, (p.y / voxel).floor() as i64, (p.z / voxel).floor() as i64);
        let e = cells.entry(key).or_insert((Vector3::zeros(), 0));
        e.0 += p.coords;
        e.1 += 1;
    }
    let mut keys: Vec<_> = cells.keys().copied().collect();
    // A fixed order: the same cloud gives the same thinned cloud, run after run.
    keys.sort_unstable();
    keys.iter().map(|k| Point3::from(cells[k].0 / cells[k].1 as Real)).collect()
}

/// Unit normals from the neighbours within `radius` (the nearest 6 where fewer), turned away from
/// the cloud's centroid: the sign must follow the surface, not the pose, for the descriptors to
/// match across poses.
pub fn outward_normals(points: &[Point3], tree: &PointTree, radius: Real) -> Vec<Vector3> {
    let centroid = points.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / points.len().max(1) as Real;
    points
        .par_iter()
        .map(|p| {
            let mut nb = tree.within(p, radius);
            if nb.len() < 6 {
                nb = tree.nearest_k(p, 6);
            }
            crate::normals::plane_normal(points, &nb, p.coords - centroid)
        })
        .collect()
}

/// The three Darboux-frame angles of a pair (the point with the smaller angle between its normal and
/// the line to the other is the source): α = v·n_t, φ = u·d, θ = atan2(w·n_t, u·n_t), with u the
/// source's normal, v = u × d, w = u × v and d the unit line between them.
fn pair_angles(ps: &Point3, ns: &Vector3, pt: &Point3, nt: &Vector3) -> Option<(Real, Real, Real)> {
    let d = pt - ps;
    let dist = d.norm();
    if dist < 1e-12 {
        return None;
    }
    let d = d / dist;
    // The source is the point whose normal makes the smaller angle with the line between them.
    let (u, nt, d) = if ns.dot(&d).clamp(-1.0, 1.0).acos() <= (-nt).dot(&d).clamp(-1.0, 1.0).acos() {
        (*ns, *nt, d)
    } else {
        (*nt, *ns, -d)
    };
    let v = u.cross(&d);
    let vn = v.norm();
    if vn < 1e-12 {
        return None;
    }
    let v = v / vn;
    let w = u.cross(&v);
    Some((v.dot(&nt), u.dot(&d), w.dot(&nt).atan2(u.dot(&nt))))
}

/// The descriptor of the same point in the cloud mirrored (any reflection): v = u × d turns with
/// the reflection's sign, so α = v·n_t changes sign while φ and θ keep theirs, and the α histogram
/// (bins symmetric about 0) is read backwards. Describing a mirror image this way costs nothing.
pub fn mirrored(f: &Fpfh) -> Fpfh {
    let mut m = *f;
    m[..BINS].reverse();
    m
}

/// The bin of `x` in `[lo, hi]`.
fn bin(x: Real, lo: Real, hi: Real) -> usize {
    (((x - lo) / (hi - lo) * BINS as Real) as isize).clamp(0, BINS as isize - 1) as usize
}

/// Simplified point feature histograms: each point against its neighbours within `radius`, each of
/// the three histograms summing to 100 (as the paper normalises them).
fn spfh(points: &[Point3], normals: &[Vector3], neighbours: &[Vec<usize>]) -> Vec<Fpfh> {
    points
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let mut h = [0f32; LEN];
            let mut n = 0usize;
            for &j in &neighbours[i] {
                if j == i {
                    continue;
                }
                let Some((a, f, t)) = pair_angles(p, &normals[i], &points[j], &normals[j]) else { continue };
                h[bin(a, -1.0, 1.0)] += 1.0;
                h[BINS + bin(f, -1.0, 1.0)] += 1.0;
                h[2 * BINS + bin(t, -std::f64::consts::PI, std::f64::consts::PI)] += 1.0;
                n += 1;
            }
            if n > 0 {
                let s = 100.0 / n as f32;
                h.iter_mut().for_each(|x| *x *= s);
            }
            h
        })
        .collect()
}

/// Each point's FPFH over its neighbours within `radius`: its own histogram plus its neighbours',
/// weighted by the inverse of their distance (Rusu et al., eq. 4).
pub fn fpfh(points: &[Point3], normals: &[Vector3], tree: &PointTree, radius: Real) -> Vec<Fpfh> {
    let neighbours: Vec<Vec<usize>> = points.par_iter().map(|p| tree.within(p, radius)).collect();
    let own = spfh(points, normals, &neighbours);
    points
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let mut f = own[i];
            let mut k = 0usize;
            let mut acc = [0f32; LEN];
            for &j in &neighbours[i] {
                let d = (points[j] - p).norm();
                if j == i || d < 1e-12 {
                    continue;
                }
                let w = (1.0 / d) as f32;
                for (a, s) in acc.iter_mut().zip(&own[j]) {
                    *a += w * s;
                }
                k += 1;
            }
            if k > 0 {
                let s = 1.0 / k as f32;
                for (x, a) in f.iter_mut().zip(&acc) {
                    *x += s * a;
                }
            }
            f
        })
        .collect()
}

/// Squared distance between two descriptors.
pub fn distance2(a: &Fpfh, b: &Fpfh) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// The index of `f`'s nearest descriptor in `among` (brute force: 33 numbers defeat a k-d tree).
pub fn nearest(f: &Fpfh, among: &[Fpfh]) -> usize {
    let mut best = (f32::INFINITY, 0);
    for (j, g) in among.iter().enumerate() {
        let d = distance2(f, g);
        if d < best.0 {
            best = (d, j);
        }
    }
    best.1
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::math::{Isometry3, Translation3, UnitQuaternion};

    /// Points on a bumpy bowl (curved, so that "away from the centroid" is one side everywhere).
    fn patch() -> Vec<Point3> {
        (0..40)
            .flat_map(|i| (0..40).map(move |j| (i as Real, j as Real)))
            .map(|(x, y)| {
                let bowl = 0.02 * ((x - 20.0).powi(2) + (y - 20.0).powi(2));
                Point3::new(x, y, bowl + 3.0 * (x / 6.0).sin() * (y / 9.0).cos())
            })
            .collect()
    }

    #[test]
    fn descriptors_do_not_change_when_the_cloud_moves() {
        let pts = patch();
        let pose = Isometry3::from_parts(
            Translation3::new(40.0, -7.0, 12.0),
            UnitQuaternion::from_euler_angles(0.7, -0.4, 2.1),
        );
        let moved: Vec<Point3> = pts.iter().map(|p| pose * p).collect();
        let describe = |p: &[Point3]| {
            let tree = PointTree::new(p);
            // Radii between the grid's distances, so no neighbour sits on the boundary.
            let n = outward_normals(p, &tree, 2.55);
            fpfh(p, &n, &tree, 5.45)
        };
        let (a, b) = (describe(&pts), describe(&moved));
        let worst = a.iter().zip(&b).map(|(x, y)| distance2(x, y)).fold(0f32, f32::max);
        assert!(worst < 1e-3, "{worst}");
        // And they tell places apart: a point's nearest descriptor in the moved cloud is its own for
        // most interior points.
        let interior: Vec<usize> =
            (0..pts.len()).filter(|&k| (8..32).contains(&(k / 40)) && (8..32).contains(&(k % 40))).collect();
        let own = interior.iter().filter(|&&k| nearest(&a[k], &b) == k).count();
        assert!(own * 10 >= interior.len() * 5, "{own} of {}", interior.len());
    }

    /// A mirror image's descriptors, computed afresh, are the originals read as a reflection reads
    /// them (the α histogram backwards), up to the rare angle that falls on a bin's edge.
    #[test]
    fn a_mirror_images_descriptors_are_the_originals_reflected() {
        let pts = patch();
        let flipped: Vec<Point3> = pts.iter().map(|p| Point3::new(-p.x, p.y, p.z)).collect();
        let describe = |p: &[Point3]| {
            let tree = PointTree::new(p);
            let n = outward_normals(p, &tree, 2.55);
            fpfh(p, &n, &tree, 5.45)
        };
        let (a, b) = (describe(&pts), describe(&flipped));
        let worst = a.iter().zip(&b).map(|(x, y)| distance2(&mirrored(x), y)).fold(0f32, f32::max);
        assert!(worst < 1e-3, "{worst}");
        // Not the descriptors as they were: the reflection changes them.
        let unread = a.iter().zip(&b).map(|(x, y)| distance2(x, y)).fold(0f32, f32::max);
        assert!(unread > 1.0, "{unread}");
    }

    #[test]
    fn thinning_keeps_one_point_a_cell() {
        let pts = patch();
        let thin = voxel_thin(&pts, 4.0);
        // At least one point a 4 × 4 column of the grid, and far fewer than the grid has.
        assert!(thin.len() < pts.len() / 4 && thin.len() >= pts.len() / 16, "{}", thin.len());
    }
}
