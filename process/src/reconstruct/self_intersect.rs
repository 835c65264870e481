//! Self-intersections of a triangle mesh, found and repaired. Marching cubes over one continuous
//! field never makes a mesh cut through itself, but AdFFT blends the local solutions of octree leaves
//! (eq. 5.19), and where neighbouring leaves disagree the blended level can fold a thin sheet through
//! its neighbour: closed and manifold, yet self-intersecting — which slicers for 3-D printing reject.
//!
//! Finding: candidate pairs from a uniform grid over the triangles' bounding boxes, then the
//! triangle–triangle test of Möller (1997): each triangle against the other's plane, then the two
//! intervals where they cross the planes' common line (coplanar pairs: edge crossings and containment
//! in the plane). As Open3D does, triangles that share a vertex are not tested: they meet by
//! construction.
//!
//! Repairing: the vertices of intersecting triangles are moved toward the mean of their neighbours
//! (the umbrella operator), which unfolds the small folds blending leaves; the region grows by a ring
//! each round until no pair is left, for a few rounds at most. What is left is reported, never hidden.

use rig::TriMesh;
use rig::math::{Point3, Real, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::HashSet;

/// What [`repair`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct RepairReport {
    /// Intersecting triangle pairs before.
    pub found: usize,
    /// Smoothing rounds run.
    pub rounds: usize,
    /// Vertices moved.
    pub moved: usize,
    /// Intersecting pairs after.
    pub remaining: usize,
}

/// Every pair of triangles (lower index first) that intersect without sharing a vertex.
///
/// Candidates from a grid of cells no smaller than a triangle's box: each triangle is filed once, by
/// the cell of its box's lower corner, in one sorted list; two boxes that overlap then have their
/// lower corners in the same or neighbouring cells, so each pair of neighbouring cells is looked
/// through once, in parallel. A triangle whose box is larger than a cell (a sliver, in a broken mesh) is kept out and
/// tested against every triangle: a slower search rather than unbounded memory. (At 512³ a serial
/// hash grid with a set of the pairs seen had taken a second for the bunny's 1.2 M triangles, with
/// none to find; filed in every cell its box met, the list had cost 140 MB.)
pub fn intersecting_pairs(mesh: &TriMesh) -> Vec<(u32, u32)> {
    use rayon::prelude::*;
    let faces = &mesh.faces;
    if faces.len() < 2 {
        return Vec::new();
    }
    let tri = |f: usize| faces[f].map(|i| mesh.vertices[i as usize]);
    let boxes: Vec<(Point3, Point3)> = (0..faces.len())
        .into_par_iter()
        .map(|f| {
            let t = tri(f);
            (t[0].inf(&t[1]).inf(&t[2]), t[0].sup(&t[1]).sup(&t[2]))
        })
        .collect();
    let finite = |f: usize| boxes[f].0.coords.iter().chain(boxes[f].1.coords.iter()).all(|c| c.is_finite());
    let extent = |f: usize| (boxes[f].1 - boxes[f].0).max();
    let good: Vec<usize> = (0..faces.len()).filter(|&f| finite(f)).collect();
    if good.is_empty() {
        return Vec::new();
    }
    // A cell the largest box fits in, but no more than 8 mean box extents (past them a triangle counts
    // as a sliver), and cells few enough per axis to number in 21 bits.
    let mean = good.iter().map(|&f| extent(f)).sum::<Real>() / good.len() as Real;
    let largest = good.iter().map(|&f| extent(f)).filter(|&e| e <= 8.0 * mean).fold(0.0, Real::max);
    let lo = good.iter().fold(boxes[good[0]].0, |m, &f| m.inf(&boxes[f].0));
    let hi = good.iter().fold(boxes[good[0]].1, |m, &f| m.sup(&boxes[f].1));
    let cell = largest.max((hi - lo).max() / (1u64 << 20) as Real).max(Real::MIN_POSITIVE);
    let key = |p: &Point3| -> [u64; 3] { std::array::from_fn(|d| ((p[d] - lo[d]) / cell).floor().max(0.0) as u64) };
    let pack = |k: [u64; 3]| k[0] << 42 | k[1] << 21 | k[2];
    let (huge, filed): (Vec<usize>, Vec<usize>) = good.into_iter().partition(|&f| extent(f) > cell);
    let mut entries: Vec<(u64, u32)> = filed.par_iter().map(|&f| (pack(key(&boxes[f].0)), f as u32)).collect();
    entries.par_sort_unstable();
    let overlap = |f: usize, g: usize| {
        let ((la, ha), (lb, hb)) = (boxes[f], boxes[g]);
        (0..3).all(|d| la[d] <= hb[d] && lb[d] <= ha[d])
    };
    let crossing = |f: u32, g: u32| {
        !faces[f as usize].iter().any(|v| faces[g as usize].contains(v))
            && overlap(f as usize, g as usize)
            && triangles_intersect(tri(f as usize), tri(g as usize))
    };
    // The entries of the cells (x, y, z−1 ..= z+1) are contiguous in the sorted list. Cells are taken
    // in that order, a run of them per task, and for each of the nine columns about a cell a cursor
    // only moves forward: the column's start for the next cell is never before this one's. (A binary
    // search per column and cell, 18 per cell, had been most of the search's second at 512³.)
    let starts: Vec<usize> =
        (0..entries.len()).filter(|&i| i == 0 || entries[i].0 != entries[i - 1].0).chain([entries.len()]).collect();
    let cells: Vec<(usize, usize)> = starts.windows(2).map(|w| (w[0], w[1])).collect();
    // Each candidate is first read from a copy of what it needs in the list's own order: its corners'
    // indices and its box in f32, widened outward so that it holds the f64 box. Nearly every candidate
    // fails there, on memory read in sequence; only the few left read the faces and f64 boxes.
    // (Reading those for each candidate, by face index, had been three quarters of the search.)
    let records: Vec<Filed> = entries
        .par_iter()
        .map(|&(_, f)| {
            let (lo, hi) = boxes[f as usize];
            Filed {
                lo: lo.coords.map(f32_below).into(),
                hi: hi.coords.map(f32_above).into(),
                face: f,
                corners: faces[f as usize],
            }
        })
        .collect();
    const MASK: u64 = (1 << 21) - 1;
    // Each pair of cells is looked at once, from the first of the two in the list's order: a cell
    // against itself and the 13 cells after it among the 26 about it (x + 1 with any y and z; x with
    // y + 1 and any z; x, y with z + 1), which lie in five columns of the list. (Every cell had looked
    // through all 27 and kept the pairs from its lower face's side: each candidate read twice.)
    const COLUMNS: [(u64, i64, i64); 5] = [(1, -1, -1), (1, 0, -1), (1, 1, -1), (0, 1, -1), (0, 0, 1)];
    let mut out: Vec<(u32, u32)> = cells
        .par_chunks(512)
        .flat_map_iter(|run| {
            let mut cursors: [Option<usize>; 5] = [None; 5];
            let mut found = Vec::new();
            let mut test = |f: &Filed, g: &Filed| {
                let (f, g) = (f.face.min(g.face), f.face.max(g.face));
                if crossing(f, g) {
                    found.push((f, g));
                }
            };
            for &(a, b) in run {
                let members = &records[a..b];
                for (i, f) in members.iter().enumerate() {
                    for g in members[i + 1..].iter().filter(|g| f.may_cross(g)) {
                        test(f, g);
                    }
                }
                let here = entries[a].0;
                let (x, y, z) = (here >> 42, (here >> 21) & MASK, here & MASK);
                for (&(dx, dy, dz), cursor) in COLUMNS.iter().zip(&mut cursors) {
                    let (cx, Some(cy)) = (x + dx, y.checked_add_signed(dy)) else { continue };
                    let (lo, hi) = (pack([cx, cy, z.saturating_add_signed(dz)]), pack([cx, cy, z + 1]));
                    let mut i = match *cursor {
                        Some(i) => i,
                        None => entries.partition_point(|e| e.0 < lo),
                    };
                    while i < entries.len() && entries[i].0 < lo {
                        i += 1;
                    }
                    *cursor = Some(i);
                    let mut k = i;
                    while k < entries.len() && entries[k].0 <= hi {
                        let g = &records[k];
                        for f in members.iter().filter(|f| f.may_cross(g)) {
                            test(f, g);
                        }
                        k += 1;
                    }
                }
            }
            found
        })
        .collect();
    for &f in &huge {
        let f = f as u32;
        out.extend(
            (0..faces.len() as u32)
                .filter(|&g| g != f && finite(g as usize) && crossing(f, g))
                .map(|g| (f.min(g), f.max(g))),
        );
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// A face as [`intersecting_pairs`] files it: its box in f32 (holding the f64 one) and its corners.
struct Filed {
    lo: [f32; 3],
    hi: [f32; 3],
    face: u32,
    corners: [u32; 3],
}

impl Filed {
    /// Whether the two boxes overlap and the faces share no corner: a candidate for the exact test.
    fn may_cross(&self, other: &Filed) -> bool {
        (0..3).all(|d| self.lo[d] <= other.hi[d] && other.lo[d] <= self.hi[d])
            && !self.corners.iter().any(|v| other.corners.contains(v))
    }
}

/// The largest f32 at or below `x` (finite `x`).
fn f32_below(x: Real) -> f32 {
    let r = x as f32;
    if r as Real > x { r.next_down() } else { r }
}

/// The smallest f32 at or above `x` (finite `x`).
fn f32_above(x: Real) -> f32 {
    let r = x as f32;
    if (r as Real) < x { r.next_up() } else { r }
}

/// The pairs of [`intersecting_pairs`] with a face in `marked` (face indices). After a repair round
/// has moved a few vertices, only the faces about them can have come to cross anything, and this
/// looks at those alone: the marked faces are filed in a hash grid by every cell their box meets, and
/// each face of the mesh looks up the cells its own box meets (one that meets more than 64 is tested
/// against every marked face instead). At 512³ the whole search is most of a second for the bunny's
/// 1.2 M triangles; the repair's rounds after a fit had run it again for a dozen folds.
pub fn intersecting_pairs_with(mesh: &TriMesh, marked: &[u32]) -> Vec<(u32, u32)> {
    use rayon::prelude::*;
    use std::collections::HashMap;
    let faces = &mesh.faces;
    let tri = |f: usize| faces[f].map(|i| mesh.vertices[i as usize]);
    let bbox = |f: usize| {
        let t = tri(f);
        (t[0].inf(&t[1]).inf(&t[2]), t[0].sup(&t[1]).sup(&t[2]))
    };
    let finite = |b: &(Point3, Point3)| b.0.coords.iter().chain(b.1.coords.iter()).all(|c| c.is_finite());
    let mut marked: Vec<u32> = marked.iter().copied().filter(|&f| (f as usize) < faces.len()).collect();
    marked.sort_unstable();
    marked.dedup();
    let marked_boxes: Vec<(u32, (Point3, Point3))> =
        marked.iter().map(|&f| (f, bbox(f as usize))).filter(|(_, b)| finite(b)).collect();
    if marked_boxes.is_empty() {
        return Vec::new();
    }
    // Cells the size of the marked faces' mean box: a marked face meets a few.
    let cell = (marked_boxes.iter().map(|(_, b)| (b.1 - b.0).max()).sum::<Real>() / marked_boxes.len() as Real)
        .max(Real::MIN_POSITIVE);
    let range = |b: &(Point3, Point3)| -> ([i64; 3], [i64; 3]) {
        let at = |p: &Point3| std::array::from_fn(|d| (p[d] / cell).floor().clamp(-1e15, 1e15) as i64);
        (at(&b.0), at(&b.1))
    };
    // Counted in floating point: three axes of up to 2·10¹⁵ cells each overflow any integer.
    let cells_in = |(lo, hi): &([i64; 3], [i64; 3])| (0..3).map(|d| (hi[d] - lo[d] + 1).max(0) as f64).product::<f64>();
    const MAX_CELLS: f64 = 64.0;
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    let mut wide: Vec<u32> = Vec::new();
    for (f, b) in &marked_boxes {
        let r = range(b);
        if cells_in(&r) > MAX_CELLS {
            wide.push(*f);
            continue;
        }
        for x in r.0[0]..=r.1[0] {
            for y in r.0[1]..=r.1[1] {
                for z in r.0[2]..=r.1[2] {
                    grid.entry([x, y, z]).or_default().push(*f);
                }
            }
        }
    }
    let boxes: HashMap<u32, (Point3, Point3)> = marked_boxes.iter().copied().collect();
    let overlap = |a: &(Point3, Point3), b: &(Point3, Point3)| (0..3).all(|d| a.0[d] <= b.1[d] && b.0[d] <= a.1[d]);
    let mut out: Vec<(u32, u32)> = (0..faces.len())
        .into_par_iter()
        .flat_map_iter(|g| {
            let bg = bbox(g);
            let mut found = Vec::new();
            if !finite(&bg) {
                return found;
            }
            let mut test = |f: u32| {
                let (fu, gu) = (f as usize, g);
                if fu != gu
                    && !faces[fu].iter().any(|v| faces[gu].contains(v))
                    && overlap(&boxes[&f], &bg)
                    && triangles_intersect(tri(fu), tri(gu))
                {
                    found.push((f.min(g as u32), f.max(g as u32)));
                }
            };
            wide.iter().for_each(|&f| test(f));
            let r = range(&bg);
            if cells_in(&r) > MAX_CELLS {
                grid.values().flatten().for_each(|&f| test(f));
            } else {
                for x in r.0[0]..=r.1[0] {
                    for y in r.0[1]..=r.1[1] {
                        for z in r.0[2]..=r.1[2] {
                            grid.get(&[x, y, z]).into_iter().flatten().for_each(|&f| test(f));
                        }
                    }
                }
            }
            found
        })
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

/// Whether two triangles intersect (touching counts).
pub fn triangles_intersect(a: [Point3; 3], b: [Point3; 3]) -> bool {
    // Distances are scaled by the plane normal's length (twice the triangle's area): the tolerance
    // for "in the plane" is a distance, rounding at the coordinates' size, times that length.
    let scale = a.iter().chain(&b).map(|p| p.coords.amax()).fold(0.0, Real::max).max(Real::MIN_POSITIVE);
    let plane = |t: &[Point3; 3]| {
        let n = (t[1] - t[0]).cross(&(t[2] - t[0]));
        (n, -n.dot(&t[0].coords), 1e-12 * scale * n.norm())
    };
    let (nb, db, eps_b) = plane(&b);
    let da = a.map(|p| snap(nb.dot(&p.coords) + db, eps_b));
    if same_side(da) {
        return false;
    }
    let (na, dna, eps_a) = plane(&a);
    let dbs = b.map(|p| snap(na.dot(&p.coords) + dna, eps_a));
    if same_side(dbs) {
        return false;
    }
    if da.iter().all(|&d| d == 0.0) {
        return coplanar_intersect(&a, &b, &na);
    }
    // Both cross the other's plane: compare where along the planes' common line.
    let line = na.cross(&nb);
    let axis = line.iamax();
    let (Some(ia), Some(ib)) = (interval(a.map(|p| p[axis]), da), interval(b.map(|p| p[axis]), dbs)) else {
        return coplanar_intersect(&a, &b, &na);
    };
    ia.0 <= ib.1 && ib.0 <= ia.1
}

fn snap(d: Real, eps: Real) -> Real {
    if d.abs() < eps { 0.0 } else { d }
}

/// All three strictly on one side of the plane.
fn same_side(d: [Real; 3]) -> bool {
    (d[0] > 0.0 && d[1] > 0.0 && d[2] > 0.0) || (d[0] < 0.0 && d[1] < 0.0 && d[2] < 0.0)
}

/// Where a triangle crosses the other's plane, as an interval of the projections `p` on the common
/// line, from the signed distances `d` of its corners (`None`: it lies in the plane).
fn interval(p: [Real; 3], d: [Real; 3]) -> Option<(Real, Real)> {
    // The corner alone on its side (Möller's case analysis).
    let (lone, o1, o2) = if d[0] * d[1] > 0.0 {
        (2, 0, 1)
    } else if d[0] * d[2] > 0.0 {
        (1, 0, 2)
    } else if d[1] * d[2] > 0.0 || d[0] != 0.0 {
        (0, 1, 2)
    } else if d[1] != 0.0 {
        (1, 0, 2)
    } else if d[2] != 0.0 {
        (2, 0, 1)
    } else {
        return None;
    };
    let at = |o: usize| p[lone] + (p[o] - p[lone]) * d[lone] / (d[lone] - d[o]);
    let (t1, t2) = (at(o1), at(o2));
    Some((t1.min(t2), t1.max(t2)))
}

/// Two triangles in one plane (normal `n`): an edge of one crosses an edge of the other, or one holds
/// a corner of the other.
fn coplanar_intersect(a: &[Point3; 3], b: &[Point3; 3], n: &Vector3) -> bool {
    // Drop the normal's largest axis: the projection keeps the triangles' shapes non-degenerate.
    let drop = n.iamax();
    let (i, j) = ((drop + 1) % 3, (drop + 2) % 3);
    let flat = |t: &[Point3; 3]| t.map(|p| (p[i], p[j]));
    let (a, b) = (flat(a), flat(b));
    let cross =
        |o: (Real, Real), p: (Real, Real), q: (Real, Real)| (p.0 - o.0) * (q.1 - o.1) - (p.1 - o.1) * (q.0 - o.0);
    let segments_cross = |p1, p2, q1, q2| {
        let (d1, d2) = (cross(q1, q2, p1), cross(q1, q2, p2));
        let (d3, d4) = (cross(p1, p2, q1), cross(p1, p2, q2));
        d1 * d2 <= 0.0 && d3 * d4 <= 0.0 && !(d1 == 0.0 && d2 == 0.0 && d3 == 0.0 && d4 == 0.0)
    };
    for k in 0..3 {
        for l in 0..3 {
            if segments_cross(a[k], a[(k + 1) % 3], b[l], b[(l + 1) % 3]) {
                return true;
            }
        }
    }
    let inside = |t: &[(Real, Real); 3], p: (Real, Real)| {
        let s = [cross(t[0], t[1], p), cross(t[1], t[2], p), cross(t[2], t[0], p)];
        s.iter().all(|&x| x >= 0.0) || s.iter().all(|&x| x <= 0.0)
    };
    inside(&b, a[0]) || inside(&a, b[0])
}

/// Which of `n` vertices are in `set`.
fn membership(n: usize, set: &HashSet<u32>) -> Vec<bool> {
    let mut is = vec![false; n];
    set.iter().filter(|&&v| (v as usize) < n).for_each(|&v| is[v as usize] = true);
    is
}

/// The neighbours along edges of the vertices in `region`, each list sorted (only the region's: the
/// mesh's every vertex's had been a tenth of a second at 512³, for the dozen folds a fit leaves).
fn neighbours_of(faces: &[[u32; 3]], region: &HashSet<u32>) -> std::collections::HashMap<u32, Vec<u32>> {
    let n_vertices = faces.iter().flatten().map(|&v| v as usize + 1).max().unwrap_or(0);
    let is = membership(n_vertices, region);
    let mut n: std::collections::HashMap<u32, Vec<u32>> = std::collections::HashMap::new();
    for f in faces {
        for (k, &v) in f.iter().enumerate() {
            if is[v as usize] {
                n.entry(v).or_default().extend([f[(k + 1) % 3], f[(k + 2) % 3]]);
            }
        }
    }
    n.values_mut().for_each(|l| {
        l.sort_unstable();
        l.dedup();
    });
    n
}

/// Removes self-intersections by smoothing the vertices of intersecting triangles (see the module
/// notes), for at most `max_rounds` rounds.
pub fn repair(mesh: &mut TriMesh, max_rounds: usize) -> RepairReport {
    let mut pairs = intersecting_pairs(mesh);
    let mut report = RepairReport { found: pairs.len(), ..Default::default() };
    if pairs.is_empty() {
        return report;
    }
    let mut region: HashSet<u32> = HashSet::new();
    let mut moved: HashSet<u32> = HashSet::new();
    while !pairs.is_empty() && report.rounds < max_rounds {
        for &(f, g) in &pairs {
            region.extend(mesh.faces[f as usize]);
            region.extend(mesh.faces[g as usize]);
        }
        // Each round reaches a ring further, so a fold wider than its triangles unfolds too.
        if report.rounds > 0 {
            let ring: Vec<u32> = neighbours_of(&mesh.faces, &region).into_values().flatten().collect();
            region.extend(ring);
        }
        let neighbours = neighbours_of(&mesh.faces, &region);
        for _ in 0..4 {
            let targets: Vec<(u32, Point3)> = neighbours
                .iter()
                .filter(|(_, n)| !n.is_empty())
                .map(|(&v, n)| {
                    let mean =
                        n.iter().fold(Vector3::zeros(), |s, &u| s + mesh.vertices[u as usize].coords) / n.len() as Real;
                    (v, Point3::from(0.5 * (mesh.vertices[v as usize].coords + mean)))
                })
                .collect();
            for (v, p) in targets {
                mesh.vertices[v as usize] = p;
                moved.insert(v);
            }
        }
        report.rounds += 1;
        // Only faces about the moved vertices can cross anything now: every pair found before had
        // its vertices put in the region, and the region's vertices all moved.
        let in_region = membership(mesh.vertices.len(), &region);
        let marked: Vec<u32> = (0..mesh.faces.len() as u32)
            .filter(|&f| mesh.faces[f as usize].iter().any(|&v| in_region[v as usize]))
            .collect();
        pairs = intersecting_pairs_with(mesh, &marked);
    }
    report.moved = moved.len();
    report.remaining = pairs.len();
    report
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: Real, y: Real, z: Real) -> Point3 {
        Point3::new(x, y, z)
    }

    #[test]
    fn crossing_touching_apart_and_coplanar_pairs() {
        let a = [p(0.0, 0.0, 0.0), p(2.0, 0.0, 0.0), p(0.0, 2.0, 0.0)];
        // Pierces a through its interior.
        assert!(triangles_intersect(a, [p(0.5, 0.5, -1.0), p(0.5, 0.5, 1.0), p(1.5, 0.5, 1.0)]));
        // Above it.
        assert!(!triangles_intersect(a, [p(0.5, 0.5, 0.1), p(0.5, 0.5, 1.0), p(1.5, 0.5, 1.0)]));
        // Crosses a's plane outside a.
        assert!(!triangles_intersect(a, [p(3.0, 3.0, -1.0), p(3.0, 3.0, 1.0), p(4.0, 3.0, 1.0)]));
        // In a's plane, overlapping; and apart.
        assert!(triangles_intersect(a, [p(0.5, 0.5, 0.0), p(3.0, 0.5, 0.0), p(0.5, 3.0, 0.0)]));
        assert!(!triangles_intersect(a, [p(3.0, 3.0, 0.0), p(4.0, 3.0, 0.0), p(3.0, 4.0, 0.0)]));
        // One inside the other, coplanar.
        assert!(triangles_intersect(a, [p(0.2, 0.2, 0.0), p(0.4, 0.2, 0.0), p(0.2, 0.4, 0.0)]));
    }

    /// The grid search finds exactly the pairs a brute-force search over all pairs finds.
    #[test]
    fn the_grid_search_agrees_with_brute_force() {
        let mut rng = fixtures::Lcg::new(11);
        let mut mesh = TriMesh::default();
        for _ in 0..300 {
            let c = p(rng.uniform() * 10.0, rng.uniform() * 10.0, rng.uniform() * 10.0);
            let base = mesh.vertices.len() as u32;
            for _ in 0..3 {
                mesh.vertices.push(c + Vector3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 1.5);
            }
            mesh.faces.push([base, base + 1, base + 2]);
        }
        // Slivers across the whole cloud, larger than any cell: searched apart, against every triangle.
        for k in 0..4 {
            let base = mesh.vertices.len() as u32;
            let y = 2.0 + 2.0 * k as Real;
            mesh.vertices.extend([p(-1.0, y, 5.0), p(11.0, y + 0.3, 5.2), p(5.0, y + 0.1, 5.0 + 0.5 * k as Real)]);
            mesh.faces.push([base, base + 1, base + 2]);
        }
        let tri = |f: usize| mesh.faces[f].map(|i| mesh.vertices[i as usize]);
        let mut brute = Vec::new();
        for f in 0..mesh.faces.len() {
            for g in f + 1..mesh.faces.len() {
                if triangles_intersect(tri(f), tri(g)) {
                    brute.push((f as u32, g as u32));
                }
            }
        }
        assert!(brute.len() > 10, "the test needs intersections: {}", brute.len());
        assert_eq!(intersecting_pairs(&mesh), brute);
        // Those with a marked face: every 7th, and a sliver.
        let marked: Vec<u32> = (0..mesh.faces.len() as u32).filter(|&f| f % 7 == 3 || f == 301).collect();
        let with: Vec<(u32, u32)> =
            brute.iter().copied().filter(|(f, g)| marked.contains(f) || marked.contains(g)).collect();
        assert!(with.len() > 3 && with.len() < brute.len(), "{} of {}", with.len(), brute.len());
        assert_eq!(intersecting_pairs_with(&mesh, &marked), with);
    }

    /// A closed box with one corner pushed through the opposite face intersects itself; repaired,
    /// it does not, and the rest of the box is where it was.
    #[test]
    fn a_fold_is_smoothed_out() {
        let mut mesh = fixtures::box_mesh(Point3::origin(), Vector3::repeat(1.0));
        let corner = mesh.vertices.iter().position(|v| v.x > 0.0 && v.y > 0.0 && v.z > 0.0).unwrap();
        // Through the opposite face's middle and out.
        mesh.vertices[corner] = p(-3.0, -0.2, -0.3);
        assert!(!intersecting_pairs(&mesh).is_empty());
        let r = repair(&mut mesh, 8);
        assert!(r.found > 0 && r.remaining == 0, "{r:?}");
        assert!(intersecting_pairs(&mesh).is_empty());
    }
}
