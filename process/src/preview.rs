//! Preview images: colour depth maps a person can look at.

use rig::RangeGrid;
use rig::image::Image8;

/// Google's Turbo colormap (a polynomial fit), `t ∈ [0, 1]` → RGB: perceptually smoother than jet.
pub fn turbo(t: f64) -> [u8; 3] {
    let t = t.clamp(0.0, 1.0);
    let r =
        0.13572138 + t * (4.61539260 + t * (-42.66032258 + t * (132.13108234 + t * (-152.94239396 + t * 59.28637943))));
    let g = 0.09140261 + t * (2.19418839 + t * (4.84296658 + t * (-14.18503333 + t * (4.27729857 + t * 2.82956604))));
    let b =
        0.10667330 + t * (12.64194608 + t * (-60.58204836 + t * (110.36276771 + t * (-89.90310912 + t * 27.34824973))));
    [r, g, b].map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8)
}

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
