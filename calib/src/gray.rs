//! A floating-point grey image: what corner detection and sub-pixel refinement work on.

use rig::image::Image8;

/// Grey values in `[0, 1]`, row-major.
#[derive(Debug, Clone)]
pub struct Gray {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `width · height` values.
    pub data: Vec<f32>,
}

impl Gray {
    /// Luminance of an 8-bit frame (grey or RGB).
    pub fn from_image(img: &Image8) -> Self {
        let g = if img.channels == 1 { img.clone() } else { img.to_gray() };
        Gray {
            width: g.width as usize,
            height: g.height as usize,
            data: g.data.iter().map(|&v| v as f32 / 255.0).collect(),
        }
    }

    /// The value at integer coordinates, clamped to the border.
    pub fn at(&self, x: isize, y: isize) -> f32 {
        let x = x.clamp(0, self.width as isize - 1) as usize;
        let y = y.clamp(0, self.height as isize - 1) as usize;
        self.data[y * self.width + x]
    }

    /// Bilinear interpolation at `(x, y)` (pixel centres at integers), clamped to the border.
    pub fn sample(&self, x: f64, y: f64) -> f32 {
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
        let (x0, y0) = (x0 as isize, y0 as isize);
        let a = self.at(x0, y0) * (1.0 - fx) + self.at(x0 + 1, y0) * fx;
        let b = self.at(x0, y0 + 1) * (1.0 - fx) + self.at(x0 + 1, y0 + 1) * fx;
        a * (1.0 - fy) + b * fy
    }

    /// Separable Gaussian blur with standard deviation `sigma` pixels, clamped to the border
    /// ([`rig::convolve::convolve_clamped`], which gives the bits of the tap-by-tap definition:
    /// reading each tap through the clamping [`Gray::at`] had been half of the FabScanPi sweep's
    /// calibration time, 100 frames of 1232 × 1640).
    pub fn blur(&self, sigma: f64) -> Gray {
        let r = (3.0 * sigma).ceil().max(1.0) as isize;
        let kernel: Vec<f32> = (-r..=r).map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp() as f32).collect();
        let norm: f32 = kernel.iter().sum();
        let kernel: Vec<f32> = kernel.iter().map(|k| k / norm).collect();
        let data = rig::convolve::convolve_clamped(&self.data, self.width, self.height, &kernel);
        Gray { width: self.width, height: self.height, data }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The blur as defined: each tap read through the clamping `at`, summed in the kernel's order.
    fn blur_by_taps(img: &Gray, sigma: f64) -> Gray {
        let r = (3.0 * sigma).ceil().max(1.0) as isize;
        let kernel: Vec<f32> = (-r..=r).map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp() as f32).collect();
        let norm: f32 = kernel.iter().sum();
        let kernel: Vec<f32> = kernel.iter().map(|k| k / norm).collect();
        let (w, h) = (img.width, img.height);
        let pass = |src: &Gray, along_rows: bool| {
            let mut out = vec![0f32; w * h];
            for y in 0..h {
                for x in 0..w {
                    let mut s = 0.0;
                    for (k, &kv) in kernel.iter().enumerate() {
                        let o = k as isize - r;
                        s += kv
                            * if along_rows {
                                src.at(x as isize + o, y as isize)
                            } else {
                                src.at(x as isize, y as isize + o)
                            };
                    }
                    out[y * w + x] = s;
                }
            }
            Gray { width: w, height: h, data: out }
        };
        pass(&pass(img, true), false)
    }

    /// The row-at-a-time blur gives the same bits as the tap-by-tap definition, on images smaller
    /// than the kernel too, and an empty image stays empty.
    #[test]
    fn the_blur_equals_its_tap_by_tap_definition() {
        let mut state = 12345u64;
        for (w, h, sigma) in [(37, 23, 0.7), (64, 48, 2.5), (3, 2, 2.5), (1, 9, 1.0), (50, 1, 0.4)] {
            let data = (0..w * h)
                .map(|_| {
                    state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    (state >> 40) as f32 / (1u64 << 24) as f32
                })
                .collect();
            let img = Gray { width: w, height: h, data };
            assert_eq!(img.blur(sigma).data, blur_by_taps(&img, sigma).data, "{w} × {h}, σ {sigma}");
        }
        let empty = Gray { width: 0, height: 5, data: Vec::new() };
        assert!(empty.blur(1.0).data.is_empty());
    }
}
