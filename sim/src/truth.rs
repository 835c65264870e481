//! Ground truth of a view, written beside the frames in `truth/view_NNN/` as NumPy arrays:
//!
//! | file | shape, type | what |
//! |---|---|---|
//! | `depth.npy` | (H, W) f64 | z of the hit in the camera frame (mm), NaN where nothing is hit |
//! | `part.npy` | (H, W) u8 | 0 nothing, 1 object, 2 platter, 3 board, 4 other |
//! | `normal.npy` | (H, W, 3) f32 | unit normal facing the camera, camera frame |
//! | `projector.npy` | (H, W, 2) f64 | projector (u, v) in px where the projector lights the hit, else NaN |
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

/// Writes a view's truth maps into `dir`.
pub fn write_view(dir: &Path, g: &ViewGeometry, camera_from_object: &Isometry3, fx: Real) -> Result<(), rig::Error> {
    std::fs::create_dir_all(dir).map_err(|e| rig::Error::io(dir, e))?;
    let (w, h) = (g.width, g.height);
    let write = |name: &str, a: NpyArray| rig::npy::write(&dir.join(name), &a);
    write("depth.npy", f64s(vec![h, w], g.point.iter().map(|p| p.z).collect()))?;
    write("part.npy", NpyArray { shape: vec![h, w], data: NpyData::U8(g.kind.clone()) })?;
    let normals = g.normal.iter().flat_map(|n| [n.x as f32, n.y as f32, n.z as f32]).collect();
    write("normal.npy", NpyArray { shape: vec![h, w, 3], data: NpyData::F32(normals) })?;
    write("projector.npy", f64s(vec![h, w, 2], g.projector.iter().flat_map(|p| [p.x, p.y]).collect()))?;
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
