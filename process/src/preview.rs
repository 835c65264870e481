//! Preview images: colour depth maps a person can look at.

use rig::RangeGrid;
use rig::image::Image8;

pub use decode::colormap::turbo;

/// A colour depth map of a range grid: near red, far blue (z from its 2nd to 98th percentile), black
/// where invalid.
pub fn depth_image(grid: &RangeGrid) -> Image8 {
    let mut z: Vec<f64> = (0..grid.points.len()).filter(|&i| grid.valid[i]).map(|i| grid.points[i].z).collect();
    z.sort_by(f64::total_cmp);
    let (lo, hi) = match z.len() {
        0 => (0.0, 1.0),
        n => (z[n / 50], z[(n - 1) - n / 50].max(z[n / 50] + 1e-9)),
    };
    let mut data = Vec::with_capacity(grid.points.len() * 3);
    for i in 0..grid.points.len() {
        if grid.valid[i] {
            data.extend(turbo(1.0 - (grid.points[i].z - lo) / (hi - lo)));
        } else {
            data.extend([0, 0, 0]);
        }
    }
    Image8 { width: grid.width as u32, height: grid.height as u32, channels: 3, data }
}
