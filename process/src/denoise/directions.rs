//! Displacement directions: least-squares normals (additive noise) or lines of sight (view-dependent
//! noise), one unit vector per valid cell, zero where none can be found.

use super::Direction;
use rayon::prelude::*;
use rig::math::Vector3;
use rig::{RangeGrid, Sensor};

/// The normal of the least-squares plane through the valid cells of the `(2·half + 1)²` window around
/// each cell (the eigenvector of the smallest eigenvalue of their covariance), turned toward the sensor;
/// zero with fewer than 3 valid cells or no distinct smallest eigenvalue.
///
/// Rows are processed as whole single-precision vectors (the window's moments about the centre point,
/// then the smallest eigenvector by Newton steps on the characteristic cubic), vectorised with AVX2
/// where the processor has it.
pub fn least_squares_normals(grid: &RangeGrid, half: usize) -> Vec<Vector3> {
    let (w, h) = (grid.width, grid.height);
    let padded = Padded::new(grid, half);
    let mut out = vec![Vector3::zeros(); w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(r, row)| {
        let [nx, ny, nz] = pulp::Arch::new().dispatch(NormalRow { grid: &padded, half, r });
        for (c, o) in row.iter_mut().enumerate() {
            let i = r * w + c;
            let n = Vector3::new(f64::from(nx[c]), f64::from(ny[c]), f64::from(nz[c]));
            // Only the sign matters here, so the sensor's direction need not be normalised.
            let toward = match &grid.sensor {
                Sensor::Center(s) => s - grid.points[i],
                Sensor::Direction(d) => d.into_inner(),
                Sensor::PerCell(d) => d[i].into_inner(),
            };
            *o = if n.dot(&toward) < 0.0 { -n } else { n };
        }
    });
    out
}

/// A grid's positions as single-precision planes relative to its mean, with a border of `half`
/// invalid cells so every window is a plain slice.
struct Padded {
    w: usize,
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
    m: Vec<f32>,
}

impl Padded {
    fn new(grid: &RangeGrid, half: usize) -> Self {
        let origin = super::planes::valid_mean(grid);
        let (w, h) = (grid.width + 2 * half, grid.height + 2 * half);
        let (mut x, mut y, mut z, mut m) = (vec![0.0; w * h], vec![0.0; w * h], vec![0.0; w * h], vec![0.0; w * h]);
        for r in 0..grid.height {
            for c in 0..grid.width {
                let i = r * grid.width + c;
                if grid.valid[i] {
                    let j = (r + half) * w + c + half;
                    let p = grid.points[i] - origin;
                    (x[j], y[j], z[j], m[j]) = (p.x as f32, p.y as f32, p.z as f32, 1.0);
                }
            }
        }
        Padded { w, x, y, z, m }
    }
}

/// The normals of one row (unoriented; zero where none), as a pulp operation.
struct NormalRow<'a> {
    grid: &'a Padded,
    half: usize,
    r: usize,
}

impl pulp::WithSimd for NormalRow<'_> {
    type Output = [Vec<f32>; 3];

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> [Vec<f32>; 3] {
        let NormalRow { grid: g, half, r } = self;
        let n = g.w - 2 * half;
        let centre = (r + half) * g.w + half;
        let (px, py, pz, pm) = (&g.x[centre..][..n], &g.y[centre..][..n], &g.z[centre..][..n], &g.m[centre..][..n]);
        // Moments of the window about the centre: Σ d (x y z), Σ d·dᵀ (xx xy xz yy yz zz), count.
        let mut acc: [Vec<f32>; 10] = std::array::from_fn(|_| vec![0.0; n]);
        for rr in 0..=2 * half {
            for cc in 0..=2 * half {
                let s = (r + rr) * g.w + cc;
                let (qx, qy, qz, qm) = (&g.x[s..][..n], &g.y[s..][..n], &g.z[s..][..n], &g.m[s..][..n]);
                let [sx, sy, sz, xx, xy, xz, yy, yz, zz, cnt] = &mut acc;
                let (sx, sy, sz, xx, xy, xz) =
                    (&mut sx[..n], &mut sy[..n], &mut sz[..n], &mut xx[..n], &mut xy[..n], &mut xz[..n]);
                let (yy, yz, zz, cnt) = (&mut yy[..n], &mut yz[..n], &mut zz[..n], &mut cnt[..n]);
                for k in 0..n {
                    let m = qm[k];
                    let (dx, dy, dz) = (m * (qx[k] - px[k]), m * (qy[k] - py[k]), m * (qz[k] - pz[k]));
                    sx[k] += dx;
                    sy[k] += dy;
                    sz[k] += dz;
                    xx[k] += dx * dx;
                    xy[k] += dx * dy;
                    xz[k] += dx * dz;
                    yy[k] += dy * dy;
                    yz[k] += dy * dz;
                    zz[k] += dz * dz;
                    cnt[k] += m;
                }
            }
        }
        let mut out: [Vec<f32>; 3] = std::array::from_fn(|_| vec![0.0; n]);
        let [sx, sy, sz, xx, xy, xz, yy, yz, zz, cnt] = &acc;
        let (sx, sy, sz, xx, xy, xz) = (&sx[..n], &sy[..n], &sz[..n], &xx[..n], &xy[..n], &xz[..n]);
        let (yy, yz, zz, cnt) = (&yy[..n], &yz[..n], &zz[..n], &cnt[..n]);
        let [ox, oy, oz] = &mut out;
        let (ox, oy, oz) = (&mut ox[..n], &mut oy[..n], &mut oz[..n]);
        for k in 0..n {
            let count = cnt[k].max(1.0);
            let (mx, my, mz) = (sx[k] / count, sy[k] / count, sz[k] / count);
            let cov = [
                xx[k] - count * mx * mx,
                xy[k] - count * mx * my,
                xz[k] - count * mx * mz,
                yy[k] - count * my * my,
                yz[k] - count * my * mz,
                zz[k] - count * mz * mz,
            ];
            let v = smallest_eigenvector_f32(cov);
            let keep = (pm[k] > 0.0) & (cnt[k] >= 3.0);
            (ox[k], oy[k], oz[k]) = if keep { (v[0], v[1], v[2]) } else { (0.0, 0.0, 0.0) };
        }
        out
    }
}

/// The unit eigenvector of a symmetric positive semi-definite 3 × 3 matrix's smallest eigenvalue, for a
/// matrix given as (xx, xy, xz, yy, yz, zz); zero where the smallest eigenvalue is not distinct (no
/// plane: a line or a single point). The eigenvalue is the smallest root of the characteristic cubic,
/// reached by Newton's method from 0 (below every root of a real-rooted cubic, so the steps rise
/// monotonically onto the smallest); the vector is the largest cross product of two rows of `A − λI`,
/// which are all orthogonal to it. A fixed number of steps and no branches, so it vectorises.
#[inline(always)]
fn smallest_eigenvector_f32(a: [f32; 6]) -> [f32; 3] {
    let [xx, xy, xz, yy, yz, zz] = a;
    let tr = xx + yy + zz;
    let minors = xx * yy - xy * xy + xx * zz - xz * xz + yy * zz - yz * yz;
    let det = xx * (yy * zz - yz * yz) - xy * (xy * zz - yz * xz) + xz * (xy * yz - yy * xz);
    // On range grid windows (λ₁ ≪ λ₂) Newton converges quadratically and 8 steps leave it at rounding
    // level; near a double root (λ₁ ≈ λ₂, where the plane is barely defined) it converges linearly, and
    // windows that still pass the test below can be off by ~1e-3 rad.
    let mut lambda = 0.0f32;
    for _ in 0..8 {
        let f = ((lambda - tr) * lambda + minors) * lambda - det;
        let df = (3.0 * lambda - 2.0 * tr) * lambda + minors;
        lambda -= if df > 0.0 { f / df } else { 0.0 };
    }
    let (a0, a1, a2) = ([xx - lambda, xy, xz], [xy, yy - lambda, yz], [xz, yz, zz - lambda]);
    let cross =
        |u: [f32; 3], v: [f32; 3]| [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
    let norm2 = |u: [f32; 3]| u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
    let (c01, c02, c12) = (cross(a0, a1), cross(a0, a2), cross(a1, a2));
    let (n01, n02, n12) = (norm2(c01), norm2(c02), norm2(c12));
    let (best, len2) = if n01 >= n02 && n01 >= n12 {
        (c01, n01)
    } else if n02 >= n12 {
        (c02, n02)
    } else {
        (c12, n12)
    };
    // Where the two smallest eigenvalues coincide (rank-1 rows) only the error of λ is left in the cross
    // products; Newton's steps slow down near a double root, which leaves λ good to ~1e-3·tr there.
    if len2 > (3e-3 * tr * tr).powi(2) {
        let inv = 1.0 / len2.sqrt();
        [best[0] * inv, best[1] * inv, best[2] * inv]
    } else {
        [0.0; 3]
    }
}

/// The displacement direction of cell `i` alone (zero where it has none): for the few cells a
/// bandwidth estimate samples. Normals as [`least_squares_normals`].
pub fn direction_at(grid: &RangeGrid, how: Direction, normal_half: usize, i: usize) -> Vector3 {
    if !grid.valid[i] {
        return Vector3::zeros();
    }
    let los = grid.line_of_sight(i).into_inner();
    if how == Direction::LineOfSight {
        return los;
    }
    let (w, h) = (grid.width, grid.height);
    let (c, r) = (i % w, i / w);
    let pts: Vec<Vector3> = (r.saturating_sub(normal_half)..=(r + normal_half).min(h - 1))
        .flat_map(|rr| (c.saturating_sub(normal_half)..=(c + normal_half).min(w - 1)).map(move |cc| rr * w + cc))
        .filter(|&j| grid.valid[j])
        .map(|j| grid.points[j] - grid.points[i])
        .collect();
    if pts.len() < 3 {
        return Vector3::zeros();
    }
    let mean = pts.iter().sum::<Vector3>() / pts.len() as f64;
    let cov = pts.iter().fold([0.0; 6], |mut a, d| {
        let e = d - mean;
        for (k, v) in [e.x * e.x, e.x * e.y, e.x * e.z, e.y * e.y, e.y * e.z, e.z * e.z].into_iter().enumerate() {
            a[k] += v;
        }
        a
    });
    // The same eigenvector, and the same test for a window without a plane, as the whole grid's.
    let [x, y, z] = smallest_eigenvector_f32(cov.map(|v| v as f32));
    let n = Vector3::new(f64::from(x), f64::from(y), f64::from(z));
    if n.dot(&los) < 0.0 { -n } else { n }
}

/// The displacement direction of every cell.
pub fn directions(grid: &RangeGrid, how: Direction, normal_half: usize) -> Vec<Vector3> {
    match how {
        Direction::Normal => least_squares_normals(grid, normal_half),
        Direction::LineOfSight => (0..grid.points.len())
            .map(|i| if grid.valid[i] { grid.line_of_sight(i).into_inner() } else { Vector3::zeros() })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::math::Matrix3;

    /// Against nalgebra's iterative eigen-decomposition in double precision on random covariances,
    /// including nearly flat ones such as a range grid's windows give.
    #[test]
    fn newton_smallest_eigenvector_matches_the_full_decomposition() {
        let mut rng = fixtures::Lcg::new(12345);
        let mut rnd = || rng.uniform() - 0.5;
        for k in 0..2000 {
            let flat = [0.1, 0.03, 1e-3, 1e-6][k % 4];
            let rot = rig::math::Rotation3::from_scaled_axis(Vector3::new(rnd(), rnd(), rnd()) * 6.0);
            let d = Matrix3::from_diagonal(&Vector3::new(1.0 + rnd(), 2.0 + rnd(), flat * (0.6 + rnd())));
            let a = rot.matrix() * d * rot.matrix().transpose();
            let eig = a.symmetric_eigen();
            let truth = eig.eigenvectors.column(eig.eigenvalues.imin()).into_owned();
            let m = [a[(0, 0)], a[(0, 1)], a[(0, 2)], a[(1, 1)], a[(1, 2)], a[(2, 2)]].map(|x| x as f32);
            let v = smallest_eigenvector_f32(m);
            let got = Vector3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2]));
            assert!((got.norm() - 1.0).abs() < 1e-6, "case {k}: unit length");
            assert!(got.cross(&truth).norm() < 1e-5, "case {k}: {got} vs {truth}");
        }
        let line = [1.0f32, 2.0, 2.0];
        let rank1 = [1.0, 2.0, 2.0, 4.0, 4.0, 4.0].map(|x: f32| x * line[0]);
        assert_eq!(smallest_eigenvector_f32(rank1), [0.0; 3]);
        assert_eq!(smallest_eigenvector_f32([0.0; 6]), [0.0; 3]);
    }
}

#[cfg(test)]
mod normal_tests {
    use super::*;
    use rig::math::Matrix3;
    use rig::math::Point3;

    /// The vectorised single-precision normals against the double-precision eigen-decomposition of
    /// each window, on a wavy, noisy grid with holes.
    #[test]
    fn vectorised_normals_match_the_windows_eigenvectors() {
        let (w, h) = (37usize, 29usize);
        let mut g = RangeGrid::empty(w, h, Sensor::Center(Point3::new(0.0, 0.0, -500.0)));
        let mut rng = fixtures::Lcg::new(99);
        for i in 0..w * h {
            let noise = (rng.uniform() - 0.5) * 0.05;
            let (c, r) = ((i % w) as f64 * 0.5, (i / w) as f64 * 0.5);
            g.points[i] = Point3::new(c + 200.0, r - 100.0, 400.0 + 3.0 * (c * 0.3).sin() + r * 0.4 + noise);
            g.valid[i] = i % 13 != 5 && i % 17 != 2;
        }
        for half in [1usize, 2] {
            let normals = least_squares_normals(&g, half);
            let mut checked = 0;
            for i in (0..w * h).filter(|&i| g.valid[i]) {
                let (c, r) = (i % w, i / w);
                let pts: Vec<Point3> = (r.saturating_sub(half)..=(r + half).min(h - 1))
                    .flat_map(|rr| (c.saturating_sub(half)..=(c + half).min(w - 1)).map(move |cc| rr * w + cc))
                    .filter(|&j| g.valid[j])
                    .map(|j| g.points[j])
                    .collect();
                if pts.len() < 3 {
                    assert_eq!(normals[i], Vector3::zeros());
                    continue;
                }
                let mean = pts.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / pts.len() as f64;
                let cov =
                    pts.iter().fold(Matrix3::zeros(), |a, p| a + (p.coords - mean) * (p.coords - mean).transpose());
                let eig = cov.symmetric_eigen();
                let truth = eig.eigenvectors.column(eig.eigenvalues.imin()).into_owned();
                let got = normals[i];
                assert!(got.cross(&truth).norm() < 2e-5, "cell ({c}, {r}), half {half}: {got} vs {truth}");
                let one = direction_at(&g, Direction::Normal, half, i);
                assert!((one - got).norm() < 2e-5, "cell ({c}, {r}), half {half}: alone {one} vs {got}");
                assert!(got.dot(&g.line_of_sight(i)) > 0.0, "faces the sensor");
                checked += 1;
            }
            assert!(checked > 900);
        }
    }
}
