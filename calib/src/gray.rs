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

    /// Separable Gaussian blur with standard deviation `sigma` pixels.
    pub fn blur(&self, sigma: f64) -> Gray {
        let r = (3.0 * sigma).ceil().max(1.0) as isize;
        let kernel: Vec<f32> = (-r..=r).map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp() as f32).collect();
        let norm: f32 = kernel.iter().sum();
        let kernel: Vec<f32> = kernel.iter().map(|k| k / norm).collect();
        let (w, h) = (self.width, self.height);
        let mut tmp = vec![0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let mut s = 0.0;
                for (k, &kv) in kernel.iter().enumerate() {
                    s += kv * self.at(x as isize + k as isize - r, y as isize);
                }
                tmp[y * w + x] = s;
            }
        }
        let src = Gray { width: w, height: h, data: tmp };
        let mut out = vec![0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let mut s = 0.0;
                for (k, &kv) in kernel.iter().enumerate() {
                    s += kv * src.at(x as isize, y as isize + k as isize - r);
                }
                out[y * w + x] = s;
            }
        }
        Gray { width: w, height: h, data: out }
    }
}
