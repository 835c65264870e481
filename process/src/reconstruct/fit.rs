//! The extracted surface drawn onto its samples. Marching cubes puts a vertex where the blended
//! indicator crosses its level along a grid edge; the indicator is the samples' normal field
//! integrated and low-passed (eq. 5.4 and the smoothing of 5.3), so its level set is the samples'
//! surface rounded off by a fraction of a cell: on the ten bunny scans AdFFT's mesh at depth 8 sat
//! 0.060 mm (accuracy) and 0.047 mm (completeness) from bun_zipper, where MeshLab's screened Poisson,
//! whose solve is pulled toward the samples by its screening term (Kazhdan & Hoppe 2013), sat 0.057
//! and 0.043.
//!
//! AdFFT has no screening term in its solves; the pull comes after extraction instead, one step of a
//! moving-least-squares projection (as point-set surfaces define theirs): each vertex moves along the
//! samples' local normal onto the plane through their weighted centre. Only samples facing the
//! vertex's way count (a thin sheet's other side, within the radius, would pull both sides to its
//! middle), and no vertex moves more than half a cell: the move corrects the rounding, not the
//! topology the indicator chose. A fold the moves make is left to [`super::self_intersect::repair`],
//! which runs after.

use rayon::prelude::*;
use rig::TriMesh;
use rig::math::{Point3, Real, Vector3};
use serde::{Deserialize, Serialize};

/// Samples a vertex's neighbourhood holds on average: the radius is chosen to hold this many, so the
/// fitted plane averages the scans' noise whatever their density. On the bunny (362,272 samples over
/// 61,658 mm², 1.47 mm) 40 gave a chamfer of 0.0416 mm at depth 8 and 0.0439 at depth 9 (25: 0.0439
/// and 0.0475 in a first try; 100 less still, but a plane through a hundred samples flattens the
/// detail a scan of coarser sampling shows).
pub const SAMPLES_PER_NEIGHBOURHOOD: Real = 40.0;

/// A sample counts for a vertex when its normal is within 60° of the vertex's.
const MIN_COSINE: Real = 0.5;

/// What [`fit_to_samples`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct FitReport {
    /// The neighbourhood's radius.
    pub radius: Real,
    /// Vertices moved. The rest had fewer than 3 samples facing their way within the radius (or
    /// their samples' normals cancelled), or a move that would have turned a face over.
    pub moved: usize,
    /// Of those, moves cut to the limit (half a cell).
    pub limited: usize,
    /// The mean distance a moved vertex moved.
    pub mean_move: Real,
    /// Faces the moves would have turned over; their vertices stayed where they were.
    #[serde(default)]
    pub turned: usize,
}

/// The neighbourhood radius that holds [`SAMPLES_PER_NEIGHBOURHOOD`] samples on average, for `points`
/// samples spread over `area`; never under 1.5 cells (`cell`), so a vertex sees the samples of the
/// cells about it.
pub fn radius(points: usize, area: Real, cell: Real) -> Real {
    let density = if area > 0.0 { points as Real / area } else { 0.0 };
    let by_samples =
        if density > 0.0 { (SAMPLES_PER_NEIGHBOURHOOD / (std::f64::consts::PI * density)).sqrt() } else { 0.0 };
    by_samples.max(1.5 * cell)
}

/// Moves each vertex of `mesh` onto the weighted plane of the oriented samples within `radius` (each
/// weighted by (1 − d²/r²)², Wendland's compact weight), by at most `max_move`. The samples count
/// alike, not by their area weights: where ten scans overlap, each scan's noise and misalignment
/// averages out only if the overlap's many small-area samples weigh as much as one scan's few (weighted by
/// area, the bunny's chamfer at depth 8 was 0.0433 mm; alike, 0.0418).
pub fn fit_to_samples(
    mesh: &mut TriMesh,
    positions: &[Point3],
    normals: &[Vector3],
    radius: Real,
    max_move: Real,
) -> FitReport {
    // A radius or limit that is not a positive number moves nothing (and `clamp` would panic on it).
    if !(radius > 0.0 && radius.is_finite() && max_move >= 0.0 && max_move.is_finite()) {
        return FitReport { radius, ..Default::default() };
    }
    let vertex_normals = mesh.vertex_normals();
    let grid = SampleGrid::new(positions, normals, radius);
    // Vertices in one cell of the grid (the radius's edge, or more on a vast cloud) share their
    // candidates: the samples of the 3³ cells about it, a few contiguous runs of the sorted samples.
    // A k-d tree search per vertex had been 0.7 s of the bunny's 7 at depth 9; the fit is now about
    // 0.4 s, most of it the 86 M candidate weights.
    let mut order: Vec<(u64, u32)> =
        mesh.vertices.par_iter().enumerate().filter_map(|(i, p)| grid.key(p).map(|k| (k, i as u32))).collect();
    order.par_sort_unstable();
    let starts: Vec<usize> =
        (0..order.len()).filter(|&i| i == 0 || order[i].0 != order[i - 1].0).chain([order.len()]).collect();
    let vertices = &mesh.vertices;
    let found: Vec<(u32, Vector3)> = starts
        .par_windows(2)
        .flat_map_iter(|w| {
            let group = &order[w[0]..w[1]];
            let near = grid.around(group[0].0, 1, vertices[group[0].1 as usize], radius);
            group
                .iter()
                .filter_map(|&(_, i)| {
                    near.plane_move(&vertices[i as usize], &vertex_normals[i as usize], radius, max_move)
                        .map(|m| (i, m))
                })
                .collect::<Vec<_>>()
        })
        .collect();
    let mut moves: Vec<Option<Vector3>> = vec![None; mesh.vertices.len()];
    for (i, m) in found {
        moves[i as usize] = Some(m);
    }
    let turned = keep_faces_facing(mesh, &mut moves);
    let mut report = FitReport { radius, turned, ..Default::default() };
    let mut total = 0.0;
    for (v, m) in mesh.vertices.iter_mut().zip(&moves) {
        if let Some(m) = m {
            *v += m;
            report.moved += 1;
            let len = m.norm();
            total += len;
            report.limited += usize::from(len >= max_move * (1.0 - 1e-9));
        }
    }
    report.mean_move = if report.moved > 0 { total / report.moved as Real } else { 0.0 };
    // Normals the extraction gave (the indicator's gradient) follow the moved faces.
    if report.moved > 0 && mesh.normals.is_some() {
        mesh.normals = Some(mesh.vertex_normals());
    }
    report
}

/// Drops the moves of the vertices of any face the moves would turn over (its normal against the
/// one it had) or shrink to nothing, until none is: a face turned over is a fold, and marching cubes
/// leaves slivers a hundredth of a cell across that a move of a few hundredths turns. Returns the
/// faces that had been.
fn keep_faces_facing(mesh: &TriMesh, moves: &mut [Option<Vector3>]) -> usize {
    let mut turned_total = 0;
    // Each pass drops at least one move, so this ends; dropping one face's moves can turn its
    // neighbour, hence the passes.
    loop {
        let turned: Vec<usize> = mesh
            .faces
            .par_iter()
            .enumerate()
            .filter(|(_, f)| {
                let at = |i: u32| mesh.vertices[i as usize];
                let moved = |i: u32| at(i) + moves[i as usize].unwrap_or_else(Vector3::zeros);
                let before = (at(f[1]) - at(f[0])).cross(&(at(f[2]) - at(f[0])));
                let after = (moved(f[1]) - moved(f[0])).cross(&(moved(f[2]) - moved(f[0])));
                f.iter().any(|&i| moves[i as usize].is_some())
                    && after.dot(&before).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
            })
            .map(|(k, _)| k)
            .collect();
        if turned.is_empty() {
            break;
        }
        turned_total += turned.len();
        for k in turned {
            mesh.faces[k].iter().for_each(|&i| moves[i as usize] = None);
        }
    }
    turned_total
}

/// The samples sorted by the cell of a grid they fall in, coordinates in arrays of their own; cells
/// numbered z fastest, so a column of cells is one run of the arrays.
struct SampleGrid {
    cell: Real,
    lo: Point3,
    keys: Vec<u64>,
    p: [Vec<Real>; 3],
    n: [Vec<Real>; 3],
}

/// Cells of margin about the samples' box, so a vertex just outside it still finds them.
const MARGIN: Real = 4.0;
const BITS: u64 = 21;

impl SampleGrid {
    fn new(positions: &[Point3], normals: &[Vector3], cell: Real) -> Self {
        let finite = |i: &usize| positions[*i].coords.iter().chain(normals[*i].iter()).all(|c| c.is_finite());
        let good: Vec<usize> = (0..positions.len().min(normals.len())).filter(finite).collect();
        let lo = good.iter().fold(Point3::from(Vector3::repeat(Real::INFINITY)), |m, &i| m.inf(&positions[i]));
        let hi = good.iter().fold(Point3::from(Vector3::repeat(Real::NEG_INFINITY)), |m, &i| m.sup(&positions[i]));
        // Cells few enough per axis to number in 21 bits, margin included.
        let span = if good.is_empty() { 0.0 } else { (hi - lo).max() };
        let cell = cell.max(span / ((1u64 << BITS) as Real - 4.0 * MARGIN)).max(Real::MIN_POSITIVE);
        let mut grid = SampleGrid { cell, lo, keys: Vec::new(), p: Default::default(), n: Default::default() };
        let mut sorted: Vec<(u64, usize)> =
            good.iter().filter_map(|&i| grid.key(&positions[i]).map(|k| (k, i))).collect();
        sorted.par_sort_unstable();
        grid.keys = sorted.iter().map(|e| e.0).collect();
        grid.p = std::array::from_fn(|d| sorted.iter().map(|e| positions[e.1][d]).collect());
        grid.n = std::array::from_fn(|d| sorted.iter().map(|e| normals[e.1][d]).collect());
        grid
    }

    fn coords(&self, p: &Point3) -> Option<[u64; 3]> {
        let mut out = [0; 3];
        for d in 0..3 {
            let c = ((p[d] - self.lo[d]) / self.cell).floor() + MARGIN;
            if !(c >= 0.0 && c < (1u64 << BITS) as Real) {
                return None;
            }
            out[d] = c as u64;
        }
        Some(out)
    }

    /// The cell `p` is in, as a key; None off the grid (no sample is near such a point).
    fn key(&self, p: &Point3) -> Option<u64> {
        self.coords(p).map(|[x, y, z]| x << (2 * BITS) | y << BITS | z)
    }

    /// The samples of the cells within `span` cells of the cell `key` on each axis, padded to a
    /// multiple of the lanes with points far off (`far_from` plus ten radii: weight zero).
    fn around(&self, key: u64, span: u64, far_from: Point3, radius: Real) -> Near {
        let mask = (1u64 << BITS) - 1;
        let (x, y, z) = (key >> (2 * BITS), (key >> BITS) & mask, key & mask);
        let mut near = Near { origin: far_from, ..Default::default() };
        for cx in x.saturating_sub(span)..=(x + span).min(mask) {
            for cy in y.saturating_sub(span)..=(y + span).min(mask) {
                let column = cx << (2 * BITS) | cy << BITS;
                let a = self.keys.partition_point(|&k| k < column | z.saturating_sub(span));
                let b = self.keys.partition_point(|&k| k <= column | (z + span).min(mask));
                for d in 0..3 {
                    let o = near.origin[d];
                    near.p[d].extend(self.p[d][a..b].iter().map(|&x| (x - o) as f32));
                    near.n[d].extend(self.n[d][a..b].iter().map(|&x| x as f32));
                }
            }
        }
        while !near.p[0].len().is_multiple_of(LANES) {
            for d in 0..3 {
                near.p[d].push(if d == 0 { (10.0 * radius) as f32 } else { 0.0 });
                near.n[d].push(0.0);
            }
        }
        near
    }
}

const LANES: usize = 8;

/// Candidate samples, coordinates in arrays of their own, a multiple of [`LANES`] long: positions as
/// offsets from `origin` (a point of the vertices' cell) and normals, in single precision, so eight
/// go through a vector register at once (a hundred-thousandth of a millimetre at most, against moves
/// of hundredths).
#[derive(Default)]
struct Near {
    origin: Point3,
    p: [Vec<f32>; 3],
    n: [Vec<f32>; 3],
}

impl Near {
    /// The move of the vertex at `v` (normal `nv`) onto the plane of the candidates within `radius`
    /// that face its way: `None` with fewer than three. The weight is (1 − d²/r²)², Wendland's
    /// compact one: no call to exp, and zero at the radius. Computed branch-free in lanes of eight
    /// with an accumulator per lane, so the loop runs in vector registers: whether a candidate is
    /// within the radius is not predictable, and the branch had been most of the fit's time.
    fn plane_move(&self, v: &Point3, nv: &Vector3, radius: Real, max_move: Real) -> Option<Vector3> {
        let inv_r2 = (1.0 / (radius * radius)) as f32;
        let (o, vn) = (v - self.origin, nv.map(|c| c as f32));
        let (vx, vy, vz) = (o.x as f32, o.y as f32, o.z as f32);
        let cos = MIN_COSINE as f32;
        let zero = [0f32; LANES];
        let (mut sw, mut cx, mut cy, mut cz) = (zero, zero, zero, zero);
        let (mut nx, mut ny, mut nz, mut count) = (zero, zero, zero, zero);
        // Fixed-size arrays, so the compiler sees every index in bounds and keeps the lanes in
        // vector registers (indexing the slices, it kept bounds checks and went scalar: 8 ns a
        // candidate).
        for c in 0..self.p[0].len() / LANES {
            let r = c * LANES..(c + 1) * LANES;
            let (Ok(px), Ok(py), Ok(pz), Ok(qx), Ok(qy), Ok(qz)) = (
                <&[f32; LANES]>::try_from(&self.p[0][r.clone()]),
                <&[f32; LANES]>::try_from(&self.p[1][r.clone()]),
                <&[f32; LANES]>::try_from(&self.p[2][r.clone()]),
                <&[f32; LANES]>::try_from(&self.n[0][r.clone()]),
                <&[f32; LANES]>::try_from(&self.n[1][r.clone()]),
                <&[f32; LANES]>::try_from(&self.n[2][r]),
            ) else {
                continue;
            };
            for l in 0..LANES {
                let (dx, dy, dz) = (px[l] - vx, py[l] - vy, pz[l] - vz);
                let t = 1.0 - (dx * dx + dy * dy + dz * dz) * inv_r2;
                let facing = qx[l] * vn.x + qy[l] * vn.y + qz[l] * vn.z >= cos;
                let w = if facing && t > 0.0 { t * t } else { 0.0 };
                sw[l] += w;
                cx[l] += w * dx;
                cy[l] += w * dy;
                cz[l] += w * dz;
                nx[l] += w * qx[l];
                ny[l] += w * qy[l];
                nz[l] += w * qz[l];
                count[l] += if w > 0.0 { 1.0 } else { 0.0 };
            }
        }
        let acc = [sw, cx, cy, cz, nx, ny, nz, count];
        let [sw, cx, cy, cz, nx, ny, nz, count] = acc.map(|a| a.iter().map(|&x| x as Real).sum::<Real>());
        if count < 3.0 || sw.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        let n = Vector3::new(nx, ny, nz).try_normalize(1e-12)?;
        // The signed distance from the vertex to the plane through the samples' centre.
        let s = Vector3::new(cx, cy, cz).dot(&n) / sw;
        s.is_finite().then(|| s.clamp(-max_move, max_move) * n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mesh of a sphere of radius 10.3 drawn onto samples of radius 10: every vertex lands on the
    /// samples' sphere to a fraction of the offset, none moves more than the limit, and a vertex with
    /// samples only on the far side of a thin sheet does not move.
    #[test]
    fn an_offset_sphere_comes_onto_its_samples() {
        let sphere = |r: Real, n: usize| -> (Vec<Point3>, Vec<Vector3>) {
            // A Fibonacci sphere: near-uniform samples.
            let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
            (0..n)
                .map(|i| {
                    let z = 1.0 - 2.0 * (i as Real + 0.5) / n as Real;
                    let (rho, t) = ((1.0 - z * z).sqrt(), golden * i as Real);
                    let u = Vector3::new(rho * t.cos(), rho * t.sin(), z);
                    (Point3::from(r * u), u)
                })
                .unzip()
        };
        let (positions, normals) = sphere(10.0, 20_000);
        let r = radius(positions.len(), 4.0 * std::f64::consts::PI * 100.0, 0.5);
        assert!((r - (40.0 * 400.0 * std::f64::consts::PI / (20_000.0 * std::f64::consts::PI)).sqrt()).abs() < 1e-9);
        let (vertices, _) = sphere(10.3, 2_000);
        // Faces do not matter to the moves beyond the vertex normals: a fan of degenerate faces with
        // each vertex's outward normal would do, but a real mesh is simpler to trust; the normals come
        // from `vertex_normals`, so give each vertex one outward face of its own.
        let mut mesh = TriMesh::default();
        for v in &vertices {
            let u = v.coords.normalize();
            let a = u.cross(&Vector3::x()).try_normalize(1e-6).unwrap_or_else(|| u.cross(&Vector3::y()).normalize());
            let b = u.cross(&a);
            let i = mesh.vertices.len() as u32;
            mesh.vertices.extend([*v, v + 0.01 * a, v + 0.01 * b]);
            mesh.faces.push([i, i + 1, i + 2]);
        }
        let report = fit_to_samples(&mut mesh, &positions, &normals, r, 0.5);
        assert_eq!(report.moved, mesh.vertices.len(), "{report:?}");
        assert_eq!(report.limited, 0, "{report:?}");
        let worst = mesh.vertices.iter().map(|p| (p.coords.norm() - 10.0).abs()).fold(0.0, Real::max);
        // The plane through a cap of a sphere of radius 10 sits inside it by about r²/(4·10)·(its
        // weighting): a few hundredths, against the 0.3 offset.
        assert!(worst < 0.05, "worst {worst}; {report:?}");

        // Limited: an offset of 2 moves by 0.5 only.
        let mut far =
            TriMesh { vertices: mesh.vertices.iter().map(|p| Point3::from(p.coords * 1.2)).collect(), ..mesh.clone() };
        let report = fit_to_samples(&mut far, &positions, &normals, 3.0, 0.5);
        assert!(report.limited > 0 && report.mean_move <= 0.5 + 1e-9, "{report:?}");

        // Inside-out faces: the samples face the other way, so nothing moves.
        let mut flipped = mesh.clone();
        flipped.faces.iter_mut().for_each(|f| f.swap(1, 2));
        let before = flipped.vertices.clone();
        let report = fit_to_samples(&mut flipped, &positions, &normals, r, 0.5);
        assert_eq!((report.moved, flipped.vertices == before), (0, true), "{report:?}");

        // A limit or radius that is not a positive number moves nothing, and does not panic.
        for (r, limit) in [(r, Real::NAN), (r, -0.1), (Real::NAN, 0.5), (0.0, 0.5)] {
            let mut m = mesh.clone();
            assert_eq!(fit_to_samples(&mut m, &positions, &normals, r, limit).moved, 0);
            assert_eq!(m.vertices, mesh.vertices);
        }
    }
}
