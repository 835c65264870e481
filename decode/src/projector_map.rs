//! The camera-pixel → projector-pixel correspondence a structured-light decode produces.

use rig::image::Image8;
use rig::npy::{NpyArray, NpyData};

/// Per camera pixel (row-major), the projector coordinates that lit it, in projector pixels with the
/// pixel-centre convention (column `c` covers `u ∈ [c − 0.5, c + 0.5)`); NaN where undecoded.
#[derive(Debug, Clone, PartialEq)]
pub struct ProjectorMap {
    /// Camera image width.
    pub width: usize,
    /// Camera image height.
    pub height: usize,
    /// Projector column coordinate u, NaN where not decoded.
    pub u: Vec<f64>,
    /// Projector row coordinate v, NaN where rows are not coded or not decoded.
    pub v: Vec<f64>,
    /// Decoding confidence in [0, 1]: the pattern's contrast relative to the white − black swing.
    pub confidence: Vec<f32>,
}

impl ProjectorMap {
    /// An all-undecoded map.
    pub fn empty(width: usize, height: usize) -> Self {
        use rayon::prelude::*;
        let n = width * height;
        // NaN is not all-zero bits, so these are real writes (21 MB at 1280 × 1024): both cores share them.
        let nans = || (0..n).into_par_iter().map(|_| f64::NAN).collect::<Vec<f64>>();
        ProjectorMap { width, height, u: nans(), v: nans(), confidence: vec![0.0; n] }
    }

    /// Pixels with a decoded column.
    pub fn decoded(&self) -> usize {
        self.u.iter().filter(|u| u.is_finite()).count()
    }

    /// The map as a NumPy array of shape (H, W, 3): u, v, confidence (NaN where undecoded), which
    /// `numpy.load` and OpenCV-based tools read.
    pub fn to_npy(&self) -> NpyArray {
        let data = (0..self.u.len()).flat_map(|i| [self.u[i], self.v[i], self.confidence[i] as f64]).collect();
        NpyArray { shape: vec![self.height, self.width, 3], data: NpyData::F64(data) }
    }

    /// Reads back [`ProjectorMap::to_npy`]'s layout.
    pub fn from_npy(a: &NpyArray) -> Option<ProjectorMap> {
        let [h, w, 3] = a.shape[..] else { return None };
        let d = a.to_f64();
        let mut m = ProjectorMap::empty(w, h);
        for i in 0..w * h {
            m.u[i] = d[3 * i];
            m.v[i] = d[3 * i + 1];
            m.confidence[i] = d[3 * i + 2] as f32;
        }
        Some(m)
    }

    /// A colour preview: hue from u, brightness from v (grey where rows are not coded), black undecoded.
    pub fn preview(&self, proj_width: u32, proj_height: u32) -> Image8 {
        let mut data = Vec::with_capacity(self.u.len() * 3);
        for i in 0..self.u.len() {
            let (u, v) = (self.u[i], self.v[i]);
            if !u.is_finite() {
                data.extend([0, 0, 0]);
                continue;
            }
            let rgb = crate::colormap::turbo(u / proj_width as f64);
            let shade = if v.is_finite() { 0.45 + 0.55 * (v / proj_height as f64).clamp(0.0, 1.0) } else { 1.0 };
            data.extend(rgb.map(|c| (c as f64 * shade) as u8));
        }
        Image8 { width: self.width as u32, height: self.height as u32, channels: 3, data }
    }
}
