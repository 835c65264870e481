//! Ground truth of a view, written beside the frames in `truth/view_NNN/` as NumPy arrays:
//!
//! | file | shape, type | what |
//! |---|---|---|
//! | `depth.npy` | (H, W) f64 | z of the hit in the camera frame (mm), NaN where nothing is hit |
//! | `part.npy` | (H, W) u8 | 0 nothing, 1 object, 2 platter, 3 board, 4 other |
//! | `normal.npy` | (H, W, 3) f32 | unit normal facing the camera, camera frame |
//! | `projector.npy` | (H, W, 2) f64 | projector (u, v) in px where the projector lights the hit, else NaN; only for a rig with a projector |
//! | `lit.npy` | (H, W) u8 | bit 0: projector lights the hit; bit 1 + k: laser k's emitter sees it |
//! | `laser{k}_centres.npy` | (H, 4) f64 | per row, the sub-pixel columns where laser k's plane crosses the lit surface, NaN-padded |
//! | `pose.npy` | (4, 4) f64 | camera_from_object of the view: X_cam = pose · X_obj |

use crate::geometry::ViewGeometry;
use rig::math::{Isometry3, Real};
use rig::npy::{NpyArray, NpyData};
use std::path::Path;

/// How many laser crossings per row the truth keeps.
pub const MAX_CROSSINGS: usize = 4;

/// Per row, the sub-pixel columns where laser `k`'s plane crosses a surface its emitter lights, found by
/// linear interpolation of the signed plane distance between horizontally adjacent pixels on the same
/// continuous surface (not across a depth jump).
pub fn laser_centres(g: &ViewGeometry, k: usize, fx: Real) -> Vec<[Real; MAX_CROSSINGS]> {
    let (w, h) = (g.width, g.height);
    (0..h)
        .map(|r| {
            let mut out = [Real::NAN; MAX_CROSSINGS];
            let mut n = 0;
            for c in 0..w.saturating_sub(1) {
                let (i, j) = (r * w + c, r * w + c + 1);
                if g.kind[i] == 0 || g.kind[j] == 0 || g.laser_cos[k][i] <= 0.0 || g.laser_cos[k][j] <= 0.0 {
                    continue;
                }
                let (di, dj) = (g.laser_distance[k][i] as Real, g.laser_distance[k][j] as Real);
                let continuous = (g.point[i] - g.point[j]).norm() < 4.0 * g.point[i].z / fx;
                if continuous && di != dj && (di == 0.0 || di.signum() != dj.signum()) && n < MAX_CROSSINGS {
                    out[n] = c as Real + di / (di - dj);
                    n += 1;
                }
            }
            out
        })
        .collect()
}

fn f64s(shape: Vec<usize>, v: Vec<f64>) -> NpyArray {
    NpyArray { shape, data: NpyData::F64(v) }
}

/// Writes a view's truth maps into `dir`; `projector.npy` only where the rig has a projector (`projector`).
pub fn write_view(
    dir: &Path,
    g: &ViewGeometry,
    camera_from_object: &Isometry3,
    fx: Real,
    projector: bool,
) -> Result<(), rig::Error> {
    std::fs::create_dir_all(dir).map_err(|e| rig::Error::io(dir, e))?;
    let (w, h) = (g.width, g.height);
    let write = |name: &str, a: NpyArray| rig::npy::write(&dir.join(name), &a);
    write("depth.npy", f64s(vec![h, w], g.point.iter().map(|p| p.z).collect()))?;
    write("part.npy", NpyArray { shape: vec![h, w], data: NpyData::U8(g.kind.clone()) })?;
    let normals = g.normal.iter().flat_map(|n| [n.x as f32, n.y as f32, n.z as f32]).collect();
    write("normal.npy", NpyArray { shape: vec![h, w, 3], data: NpyData::F32(normals) })?;
    // A laser rig's would be NaN throughout: 16 bytes a pixel (20 MB a view at 1280 × 960) that say
    // nothing.
    if projector {
        write("projector.npy", f64s(vec![h, w, 2], g.projector.iter().flat_map(|p| [p.x, p.y]).collect()))?;
    }
    let lit = (0..w * h)
        .map(|i| {
            let mut b = u8::from(g.projector_cos[i] > 0.0);
            for (k, cos) in g.laser_cos.iter().enumerate().take(7) {
                b |= u8::from(cos[i] > 0.0) << (1 + k);
            }
            b
        })
        .collect();
    write("lit.npy", NpyArray { shape: vec![h, w], data: NpyData::U8(lit) })?;
    for k in 0..g.laser_cos.len() {
        let c = laser_centres(g, k, fx).into_iter().flatten().collect();
        write(&format!("laser{k}_centres.npy"), f64s(vec![h, MAX_CROSSINGS], c))?;
    }
    let m = camera_from_object.to_homogeneous();
    write("pose.npy", f64s(vec![4, 4], m.transpose().iter().copied().collect()))
}

/// How a range grid of one simulated view compares with that view's truth.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ViewAccuracy {
    /// Per decoded pixel on the object: its point's distance from the truth surface (mm) — the offset
    /// from the truth point of the same pixel, along the truth normal (the tangent plane's distance).
    pub distances: Vec<Real>,
    /// Pixels the truth marks as object, visible and lit by the projector.
    pub visible_lit: usize,
    /// Of those, pixels with a point.
    pub decoded_of_visible_lit: usize,
    /// Pixels with a point.
    pub decoded: usize,
    /// Pixels with a point farther than `far_mm` from the truth, or where the truth sees nothing.
    pub far: usize,
}

impl ViewAccuracy {
    /// Adds another view's counts and distances.
    pub fn add(&mut self, other: ViewAccuracy) {
        self.distances.extend(other.distances);
        self.visible_lit += other.visible_lit;
        self.decoded_of_visible_lit += other.decoded_of_visible_lit;
        self.decoded += other.decoded;
        self.far += other.far;
    }

    /// The median distance (mm), NaN without points.
    pub fn median(&self) -> Real {
        let mut d = self.distances.clone();
        if d.is_empty() {
            return Real::NAN;
        }
        let mid = d.len() / 2;
        *d.select_nth_unstable_by(mid, Real::total_cmp).1
    }
}

/// Compares `grid` (camera frame, one cell per pixel) with the truth in `dir` (a `truth/view_NNN`
/// folder) seen through the simulator's `camera`.
pub fn view_accuracy(
    dir: &Path,
    camera: &rig::PinholeCamera,
    grid: &rig::RangeGrid,
    far_mm: Real,
) -> Result<ViewAccuracy, rig::Error> {
    let read = |name: &str| -> Result<Vec<Real>, rig::Error> { Ok(rig::npy::read(&dir.join(name))?.to_f64()) };
    let (depth, part, lit, normal) = (read("depth.npy")?, read("part.npy")?, read("lit.npy")?, read("normal.npy")?);
    let w = camera.width as usize;
    let n = w * camera.height as usize;
    let sizes_agree = [depth.len(), part.len(), lit.len(), grid.points.len(), grid.valid.len()].iter().all(|&l| l == n);
    if !sizes_agree || normal.len() != 3 * n {
        let msg = format!("truth maps and range grid must both be {}x{}", camera.width, camera.height);
        return Err(rig::ParseError::new(rig::Location::File, rig::Problem::Invalid(msg)).with_path(dir));
    }
    let object = crate::scene::PartKind::Object as u8 as Real;
    let mut acc = ViewAccuracy::default();
    for i in 0..n {
        let on_object = part[i] == object;
        if on_object && (lit[i] as u8) & 1 == 1 {
            acc.visible_lit += 1;
            acc.decoded_of_visible_lit += usize::from(grid.valid[i]);
        }
        if !grid.valid[i] {
            continue;
        }
        acc.decoded += 1;
        let ray = camera.unproject(rig::math::Point2::new((i % w) as Real, (i / w) as Real));
        let Some(truth) = ray.filter(|_| depth[i].is_finite()).map(|d| d.into_inner() * (depth[i] / d.z)) else {
            acc.far += 1; // a point where the truth sees nothing
            continue;
        };
        let nrm = rig::math::Vector3::new(normal[3 * i], normal[3 * i + 1], normal[3 * i + 2]);
        let d = (grid.points[i].coords - truth).dot(&nrm).abs();
        acc.far += usize::from(d > far_mm);
        if on_object {
            acc.distances.push(d);
        }
    }
    Ok(acc)
}
